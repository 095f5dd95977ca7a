#!/usr/bin/env python3
"""The draw benchmark, ``benchmarks/draw.py``.

The same as ``python -m benchmarks.draw`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.draw import main

if __name__ == "__main__":
    sys.exit(main())
