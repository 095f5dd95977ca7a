#!/usr/bin/env python3
"""The draw-variants benchmark, ``benchmarks/draw_variants.py``.

The same as ``python -m benchmarks.draw_variants`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.draw_variants import main

if __name__ == "__main__":
    sys.exit(main())
