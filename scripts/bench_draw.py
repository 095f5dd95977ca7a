#!/usr/bin/env python3
"""The draw benchmark, ``benchmarks/draw.py``.

The same as ``python -m benchmarks.draw`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

# main, and the names shared/gpu-replay/export_cases.py reads from this script (it
# imports it as a module to record the benchmark's draws for a GPU without Blender).
from benchmarks.draw import (  # noqa: F401
    DISC_FRACTION,
    MODES,
    VIEW_ORIGIN,
    Bench,
    main,
    make_lights,
    mesh_batches,
    sphere_arrays,
    synthetic_model,
    view_projection,
)

if __name__ == "__main__":
    sys.exit(main())
