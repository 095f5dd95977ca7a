"""The demo's factor-pack figures: per material the panel's error-against-packs plot, the
sphere pictures (reference | stored factors | ΔE94 under D65 and FL2), and the check that
the saved .blend reopens bit for bit in a fresh process."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import bpy
import numpy as np

from spectral_materials.blender.brdf import sources, storage
from spectral_materials.core.brdf import metrics
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

from .images import write_linear_png

REPO = Path(__file__).resolve().parent.parent


def sphere_figure(name: str, material, path: Path, size: int = 128) -> dict:
    """Reference | stored factors | ΔE94 under D65 and FL2, light at 60°."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    brdf = sources.material_inputs(material).brdf()
    model = storage.load_factored(material)
    view = metrics.sphere_directions(60.0, size)
    fig, axes = plt.subplots(2, 3, figsize=(8.4, 5.6))
    stats = {}
    for row, illum in enumerate(("D65", "FL2")):
        ref = metrics.reference_xyz(brdf, view.wi, view.wo, illum)
        test = model.xyz(view.wi, view.wo, illum)
        white = colour_pipeline.white_xyz(illum, spectra.WAVELENGTHS_REFERENCE)
        de = metrics.delta_e94_image(ref, test, illum)
        stats[illum] = {"mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
                        "max": float(de.max())}
        for col, xyz in enumerate((ref, test)):
            image = np.zeros((size, size, 3))
            image[view.mask] = colour_pipeline.xyz_to_display(xyz, white)
            axes[row, col].imshow(image)
        heat = np.full((size, size), np.nan)
        heat[view.mask] = de
        shown = axes[row, 2].imshow(heat, cmap="magma", vmin=0.0,
                                    vmax=max(1.0, float(np.nanmax(heat))))
        fig.colorbar(shown, ax=axes[row, 2], fraction=0.046)
        axes[row, 0].set_title(f"{illum}: reference (5 nm)", fontsize=8)
        axes[row, 1].set_title(f"{illum}: {model.packs} packs, {model.spectral_size} coeffs",
                               fontsize=8)
        axes[row, 2].set_title(f"ΔE94 mean {de.mean():.2f}", fontsize=8)
    for ax in axes.ravel():
        ax.axis("off")
    fig.suptitle(f"{name}, light at 60°", fontsize=10)
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return stats


_RELOAD = textwrap.dedent("""
    import sys, numpy as np, bpy
    sys.path.insert(0, sys.argv[3])
    from spectral_materials import blender as addon
    from spectral_materials.blender.brdf import storage
    from spectral_materials.core.brdf.metrics import random_direction_pairs
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
    wi, wo = random_direction_pairs(5000)
    values = {m.name: storage.load_factored(m).evaluate(wi, wo)
              for m in bpy.data.materials if m.spectral.result.image is not None}
    np.savez(sys.argv[2], **values)
""")


def reload_check(blend: Path, expected: dict, scratch: Path) -> dict:
    """Reopen the saved .blend in a fresh process; compare every material bit for bit."""
    out = scratch / "reload.npz"
    subprocess.run([sys.executable, "-c", _RELOAD, str(blend), str(out), str(REPO)],
                   check=True, capture_output=True, timeout=600)
    with np.load(out) as data:
        return {name: bool(name in data.files and np.array_equal(data[name], values))
                for name, values in expected.items()}




def factor_figures(names: list[str], out: Path, sphere_px: int) -> tuple[dict, dict]:
    """Per factored material: the plot and sphere PNGs under ``out/images`` with the
    sphere statistics, and its values at 5000 seeded direction pairs (for
    :func:`reload_check`)."""
    figures, expected = {}, {}
    wi, wo = metrics.random_direction_pairs(5000)
    for name in names:
        material = bpy.data.materials[name]
        slug = name.lower().replace(" ", "_")
        width, height = material.spectral.result.plot.size
        plot_pixels = np.empty(width * height * 4, np.float32)
        material.spectral.result.plot.pixels.foreach_get(plot_pixels)
        write_linear_png(plot_pixels.reshape(height, width, 4),
                         out / "images" / f"plot_{slug}.png")
        stats = sphere_figure(name, material, out / "images" / f"spheres_{slug}.png",
                              sphere_px)
        figures[name] = {"plot": f"images/plot_{slug}.png",
                         "spheres": f"images/spheres_{slug}.png", "stats": stats}
        expected[name] = storage.load_factored(material).evaluate(wi, wo)
    return figures, expected
