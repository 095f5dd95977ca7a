#!/usr/bin/env python3
"""The main job (``demos/main.py``): ``python scripts/demo.py [--quick] [--out DIR]``, the
same as ``python -m demos`` from the repository root; ``scripts/demo`` sets up the
environment first."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from demos.backend import choose_backend

choose_backend(sys.argv[1:])    # before demos.main imports bpy

from demos.main import run

if __name__ == "__main__":
    run()
