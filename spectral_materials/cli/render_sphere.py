"""``render-sphere``: draw saved factors on the protocol sphere through the GPU (or EEVEE)
and write linear CIE XYZ to OpenEXR (see :mod:`spectral_materials.cli`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .arguments import int_in
from .common import Progress, UsageError, check_output_path


def _check_options(args) -> Path:
    """Refuse what can be refused before the GPU starts → the ``--out`` path."""
    from ..core.colour import spectra

    if args.illuminant not in spectra.ILLUMINANT_NAMES:
        raise UsageError(f"unknown illuminant {args.illuminant!r}; choose one of "
                         f"{', '.join(spectra.ILLUMINANT_NAMES)}")
    if not -90.0 < args.incidence < 90.0:
        raise UsageError(f"--incidence must be in (-90, 90) degrees, got {args.incidence}")
    out = Path(args.out)
    if out.suffix.lower() != ".exr":
        raise UsageError(f"--out must name an .exr file, got {out}")
    check_output_path("--out", out)
    check_output_path("--png", Path(args.png) if args.png else None)
    return out


def _render_eevee(args, model, progress: Progress) -> np.ndarray:
    """An EEVEE render through the material node group, as XYZ plus an alpha of 1."""
    import bpy

    from .. import blender as addon
    from ..blender.eevee import render as eevee

    if not hasattr(bpy.types.Material, "spectral"):
        addon.register()      # the render stores the factors on a scratch material

    xyz, facts = eevee.render_sphere_eevee(
        model if args.packs is None else model.truncated(args.packs), args.incidence,
        args.illuminant, args.size)
    progress.info(f"EEVEE: {facts['nodes']} nodes, {facts['images']} texture(s), "
                  f"rendered in {facts['seconds']:.1f} s ({facts['working_space']})")
    return np.concatenate([xyz, np.ones(xyz.shape[:2] + (1,))], axis=-1)


def _write_xyz(out: Path, image: np.ndarray, model, args) -> None:
    from ..core.formats.exr import write_exr

    xyz = image[..., :3]
    write_exr(out, {"X": xyz[..., 0], "Y": xyz[..., 1], "Z": xyz[..., 2]}, {
        "spectralMaterials": "linear CIE XYZ (1931 2°), sphere protocol: a white Lambertian "
                             "lit head-on reflects Y = 1",
        "illuminant": args.illuminant, "incidenceDegrees": f"{args.incidence:g}",
        "packs": str(model.packs if args.packs is None else min(args.packs, model.packs)),
        "engine": args.engine,
    })


def _display_rgba(image: np.ndarray, model, args) -> np.ndarray:
    """The ``--png`` image, bottom row first: EEVEE's XYZ through the display transform, or
    the GPU path drawn again with its own display output (alpha from the XYZ draw)."""
    from ..core.colour import pipeline as colour_pipeline

    white = colour_pipeline.white_xyz(args.illuminant, model.wavelengths)
    if args.engine == "eevee":
        return colour_pipeline.xyz_to_display(image[..., :3], white)[::-1]
    from ..blender.brdf.sphere import render_sphere
    from ..blender.gpu.display import DisplaySettings

    display = render_sphere(model, args.incidence, args.illuminant, args.size,
                            packs=args.packs, output="DISPLAY",
                            display=DisplaySettings(scene_white=tuple(white)))
    return np.concatenate([display[..., :3], image[..., 3:]], axis=-1)[::-1]


def cmd_render_sphere(args, progress: Progress) -> int:
    """Run ``render-sphere``: draw, write the EXR, and the PNG if asked."""
    from ..core.brdf.factored import FactoredBRDF

    out = _check_options(args)
    model = FactoredBRDF.load(args.factors)
    progress.info("initialising the GPU (the first headless draw compiles shaders)")
    import bpy  # noqa: F401  (loading Blender is the slow start the message announces)

    from ..blender.brdf.sphere import render_sphere

    if args.engine == "eevee":
        image = _render_eevee(args, model, progress)
    else:
        image = render_sphere(model, args.incidence, args.illuminant, args.size,
                              packs=args.packs)
    _write_xyz(out, image, model, args)
    progress.info(f"wrote {out}")
    if args.png:
        import imageio.v3 as iio

        rgba = _display_rgba(image, model, args)
        iio.imwrite(args.png, (np.clip(rgba, 0, 1) * 255 + 0.5).astype(np.uint8))
        progress.info(f"wrote {args.png}")
    return 0


def add_parser(sub) -> None:
    """The ``render-sphere`` subcommand on ``sub`` (argparse's subparsers)."""
    p = sub.add_parser(
        "render-sphere", help="draw saved factors on the protocol sphere through the GPU",
        description="Render a saved FactoredBRDF (.npz from 'factor --out') on the protocol "
                    "sphere with the GPU shaders and write linear CIE XYZ to OpenEXR.")
    p.add_argument("factors", metavar="FACTORS.npz")
    p.add_argument("--incidence", type=float, default=0.0, metavar="DEG",
                   help="light angle from the view direction in the x-z plane (default 0)")
    p.add_argument("--illuminant", default="D65", metavar="NAME",
                   help="CIE illuminant: A, D50, D65, FL1..FL12 (default D65)")
    p.add_argument("--out", required=True, metavar="FILE.exr")
    p.add_argument("--size", type=int_in(1, 8192), default=256, metavar="N",
                   help="pixels a side (default 256, the protocol's)")
    p.add_argument("--packs", type=int_in(1, 4096), default=None, metavar="N",
                   help="draw only the first N packs (default all)")
    p.add_argument("--png", metavar="FILE.png", help="also write the display image")
    p.add_argument("--engine", choices=("gpu", "eevee"), default="gpu",
                   help="gpu: the add-on's shaders (default); eevee: an EEVEE render through "
                        "the material node group")
    p.add_argument("--quiet", action="store_true", help="no messages on stderr")
    p.set_defaults(handler=cmd_render_sphere)
