#!/usr/bin/env python3
"""Render a .blend's factored materials headless through the spectral GPU shaders.

Either inside Blender::

    blender --background scene.blend --python scripts/render_spectral.py -- --out out/frame

or with the ``bpy`` module (Python 3.11)::

    python scripts/render_spectral.py scene.blend --out out/frame [--width W --height H]

Writes ``<out>_xyz.exr`` (linear CIE XYZ + coverage), ``<out>_srgb.exr`` (linear sRGB
after Bradford adaptation) and ``<out>.png`` (the display image) from the scene camera.
Exit status: 0 done, 1 an error (the message names the problem), 2 bad arguments.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import blender_addon  # noqa: E402  (scripts/, next to this file)


def _parse(argv: list[str], inside_blender: bool) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="render_spectral.py", description=__doc__.split("\n")[1])
    if not inside_blender:
        parser.add_argument("blend", type=Path, help=".blend file to open")
    parser.add_argument("--out", type=Path, required=True, metavar="STEM",
                        help="output path without extension")
    parser.add_argument("--width", type=int, help="pixels (default: the scene's resolution)")
    parser.add_argument("--height", type=int, help="pixels (default: the scene's resolution)")
    parser.add_argument("--scene", help="scene name (default: the file's active scene)")
    return parser.parse_args(argv)


def run(args: argparse.Namespace, inside_blender: bool) -> int:
    import importlib

    import bpy

    if not inside_blender:
        if not args.blend.is_file():
            print(f"render_spectral: error: {args.blend} does not exist", file=sys.stderr)
            return 1
        addon = blender_addon.addon()
        bpy.ops.wm.open_mainfile(filepath=str(args.blend.resolve()))
    else:
        addon = blender_addon.addon()
    render_output = importlib.import_module(addon.__name__ + ".viewport.render_output")
    scene = bpy.data.scenes.get(args.scene) if args.scene else bpy.context.scene
    if scene is None:
        print(f"render_spectral: error: no scene named {args.scene!r}", file=sys.stderr)
        return 1
    try:
        result = render_output.write_scene_images(scene, args.out, width=args.width,
                                                  height=args.height)
    except (ValueError, OSError, RuntimeError) as exc:
        print(f"render_spectral: error: {exc}", file=sys.stderr)
        return 1
    width, height = result["size"]
    print(f"{width}×{height}: {len(result['objects'])} object(s), materials "
          f"{', '.join(result['materials'])}; {result['triangles']} triangles, "
          f"{result['texture_bytes'] / 1024:.1f} KiB of factor textures")
    for path in result["paths"].values():
        print(f"wrote {path}")
    return 0


def main() -> int:
    try:
        import bpy
    except ImportError:
        print("render_spectral: error: needs Blender or the bpy module (pip install bpy==5.0.1)",
              file=sys.stderr)
        return 1
    # The bpy module has no Blender binary; a script run by Blender itself does.
    inside_blender = bool(bpy.app.binary_path) and "--python" in " ".join(sys.argv)
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    try:
        args = _parse(argv, inside_blender)
    except SystemExit as exc:
        return int(exc.code or 0)
    return run(args, inside_blender)


if __name__ == "__main__":
    from spectral_materials.blender.gpu.context import exit_process

    exit_process(main())
