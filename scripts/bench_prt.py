#!/usr/bin/env python3
"""The prt benchmark, ``benchmarks/prt.py``.

The same as ``python -m benchmarks.prt`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

# main, and the names shared/gpu-replay/export_cases.py reads from this script (it
# imports it as a module to record the benchmark's draws for a GPU without Blender).
from benchmarks.prt import (  # noqa: F401
    DEFAULT_WINDOW,
    FLOOR_SUBDIVISIONS,
    ILLUMINANTS,
    MAIN_BANDS,
    MAIN_BASIS,
    MAIN_RAYS,
    RAYS,
    SIZE,
    SUBDIVISIONS,
    FrameBench,
    build_scene,
    main,
)

if __name__ == "__main__":
    sys.exit(main())
