#!/usr/bin/env python3
"""Analyse and factor a .blend's spectral materials headless, with a JSON report.

Either inside Blender::

    blender --background scene.blend --python scripts/factor_scene.py -- [options]

or with the ``bpy`` module (Python 3.11)::

    python scripts/factor_scene.py scene.blend [options]

Exit status: 0 done, 1 an error (the message names the problem; the file is not
saved), 2 bad arguments, 130 interrupted (Ctrl-C: the job stops at its next step and stores
nothing; a second Ctrl-C stops it at once; either way the file is not saved).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import blender_addon  # noqa: E402  (scripts/, next to this file)


def _parse(argv: list[str], inside_blender: bool) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="factor_scene.py",
        description="Scene analysis and factorisation of a .blend's spectral materials.")
    if not inside_blender:
        parser.add_argument("blend", type=Path, help=".blend file to open")
    parser.add_argument("--materials", nargs="+", metavar="NAME",
                        help="factor only these materials (the basis still serves the scene)")
    parser.add_argument("--force", action="store_true",
                        help="factor even materials whose stored factors are up to date")
    parser.add_argument("--basis-only", action="store_true",
                        help="analyse the scene and build its basis; factor nothing")
    parser.add_argument("--tolerance", type=float, metavar="DE94",
                        help="basis tolerance (ΔE94) instead of the scene's setting")
    parser.add_argument("--scene", help="scene name (default: the file's active scene)")
    parser.add_argument("--report", type=Path, metavar="JSON", help="write the report here")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--save", action="store_true", help="save the .blend in place")
    group.add_argument("--output", type=Path, metavar="BLEND", help="save to this .blend")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser.parse_args(argv)


class _Refused(Exception):
    """A problem with the arguments or the file, printed as one error line (exit status 1)."""


def _open(args: argparse.Namespace, inside_blender: bool):
    """The add-on package, with the .blend opened unless Blender opened it already."""
    import bpy

    if inside_blender:
        return blender_addon.addon()
    if not args.blend.is_file():
        raise _Refused(f"{args.blend} does not exist")
    addon = blender_addon.addon()
    bpy.ops.wm.open_mainfile(filepath=str(args.blend.resolve()))
    return addon


def _scene_and_materials(args: argparse.Namespace):
    """The scene to factor (with ``--tolerance`` applied) and the materials (None: all)."""
    import bpy

    scene = bpy.data.scenes.get(args.scene) if args.scene else bpy.context.scene
    if scene is None:
        raise _Refused(f"no scene named {args.scene!r}")
    if args.save and not bpy.data.filepath:
        raise _Refused("--save needs a file; use --output")
    if args.tolerance is not None:
        scene.spectral.basis_tolerance = args.tolerance
    if not args.materials:
        return scene, None
    missing = [name for name in args.materials if name not in bpy.data.materials]
    if missing:
        raise _Refused(f"no material named {', '.join(missing)}")
    return scene, [bpy.data.materials[name] for name in args.materials]


def _report_and_save(args: argparse.Namespace, result, scene, start: float) -> None:
    """Print the summary, write ``--report`` and save the file as asked (``start``: the job's
    ``perf_counter``)."""
    import bpy

    analysis = result.analysis()
    analysis["file"] = bpy.data.filepath
    analysis["scene"] = scene.name
    analysis["wall_seconds"] = time.perf_counter() - start
    print(analysis["summary"])
    for name, row in analysis["factored"].items():
        de = row["de94"]
        print(f"  {name}: {row['packs']} packs, ΔE94 mean {de['mean']:.3f} p95 {de['p95']:.3f} "
              f"max {de['max']:.3f}, {row['seconds']:.1f} s, {row['bytes'] / 1024:.1f} KiB")
    if args.report:
        args.report.parent.mkdir(parents=True, exist_ok=True)
        args.report.write_text(json.dumps(analysis, indent=2, default=str))
    if args.save:
        bpy.ops.wm.save_mainfile()
    elif args.output:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=str(args.output.resolve()), copy=True)


def run(args: argparse.Namespace, inside_blender: bool) -> int:
    """Open, factor, report and save → the exit status."""
    from importlib import import_module

    try:
        addon = _open(args, inside_blender)
        scene, only = _scene_and_materials(args)
    except _Refused as exc:
        print(f"factor_scene: error: {exc}", file=sys.stderr)
        return 1
    jobs = import_module(addon.__name__ + ".brdf.jobs")
    core = import_module(addon.__name__.rsplit(".", 1)[0] + ".core")
    progress_module = import_module(core.__name__ + ".progress")
    progress = progress_module.TerminalProgress(quiet=args.quiet)
    start = time.perf_counter()
    try:
        with progress_module.ctrl_c_cancels(progress):
            result = jobs.factor_scene(scene, progress, only=only, force=args.force,
                                       factor=not args.basis_only)
    except core.Cancelled:
        print("\nfactor_scene: interrupted; nothing was stored", file=sys.stderr)
        return 130
    except KeyboardInterrupt:  # the second Ctrl-C: the job stopped where it was
        print("\nfactor_scene: interrupted at once; the file was not saved", file=sys.stderr)
        return 130
    except (ValueError, OSError) as exc:
        print(f"\nfactor_scene: error: {exc}", file=sys.stderr)
        return 1
    _report_and_save(args, result, scene, start)
    return 0


def main() -> int:
    try:
        import bpy
    except ImportError:
        print("factor_scene: error: needs Blender or the bpy module (pip install bpy==5.0.1)",
              file=sys.stderr)
        return 1
    # The bpy module has no Blender binary; a script run by Blender itself does.
    inside_blender = bool(bpy.app.binary_path) and "--python" in " ".join(sys.argv)
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    args = _parse(argv, inside_blender)
    return run(args, inside_blender)


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    if "bpy" in sys.modules and sys.modules["bpy"].app.background and "--" in sys.argv:
        # Inside Blender, sys.exit from a --python script does not set the exit status.
        import os

        os._exit(code)
    sys.exit(code)
