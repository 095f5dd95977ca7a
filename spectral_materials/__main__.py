"""``python -m spectral_materials``: the command line (see :mod:`spectral_materials.cli`)."""

import sys

from .cli import main

if __name__ == "__main__":
    code = main()
    if "bpy" in sys.modules:         # it used Blender: see blender.gpu.context.exit_process
        from .blender.gpu.context import exit_process

        exit_process(code)
    raise SystemExit(code)
