"""Headless image output of the spectral draw path: EXR (linear XYZ, linear sRGB) and PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...core.colour import pipeline as colour_pipeline
from ...core.formats.exr import write_exr
from ..lights import scene_lights
from . import draw


def write_scene_images(scene, stem: str | Path, *, width: int | None = None,
                       height: int | None = None) -> dict:
    """Render ``scene`` from its camera to ``<stem>_xyz.exr``, ``_srgb.exr`` and ``.png``.

    * ``_xyz.exr``: linear CIE XYZ (X, Y, Z) and coverage (A), as the shaders
      compute it before any display step;
    * ``_srgb.exr``: linear sRGB (R, G, B, A) after Bradford adaptation from the
      scene's adaptation white to D65 and the exposure, no tone map;
    * ``.png``: the display image the viewport shows (the GLSL pipeline: sigmoid
      tone map and sRGB encoding), alpha = coverage.

    Returns the paths, the image size and the draw statistics.
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    xyz, stats = draw.render_camera(scene, width=width, height=height, output="XYZ")
    shown, _ = draw.render_camera(scene, width=width, height=height, output="DISPLAY")
    display = scene_lights.display_settings(scene)
    alpha = xyz[..., 3]
    adapted = colour_pipeline.bradford_adapt(xyz[..., :3].astype(np.float64) * display.exposure,
                                             np.asarray(display.scene_white))
    srgb = colour_pipeline.xyz_to_linear_srgb(adapted) * alpha[..., None]
    attributes = {"spectralMaterials": f"scene '{scene.name}', camera '{scene.camera.name}'",
                  "adaptationWhite": scene.spectral.adaptation_white}
    paths = {
        "xyz_exr": write_exr(stem.with_name(stem.name + "_xyz.exr"),
                             {"X": xyz[..., 0], "Y": xyz[..., 1], "Z": xyz[..., 2], "A": alpha},
                             attributes),
        "srgb_exr": write_exr(stem.with_name(stem.name + "_srgb.exr"),
                              {"R": srgb[..., 0], "G": srgb[..., 1], "B": srgb[..., 2],
                               "A": alpha}, attributes),
    }
    import imageio.v3 as iio

    rgba = np.concatenate([shown[..., :3], alpha[..., None]], axis=-1)[::-1]
    png = stem.with_suffix(".png")
    iio.imwrite(png, (np.clip(rgba, 0.0, 1.0) * 255 + 0.5).astype(np.uint8))
    paths["png"] = png
    return {"paths": {k: str(v) for k, v in paths.items()}, "size": list(xyz.shape[1::-1]),
            "objects": stats.objects, "materials": stats.materials,
            "triangles": stats.triangles, "texture_bytes": stats.texture_bytes,
            "variants": len(stats.variants), "xyz": xyz}
