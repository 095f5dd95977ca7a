#!/usr/bin/env python3
"""The PRT albedo-packing benchmark, ``benchmarks/prt_packing.py``.

The same as ``python -m benchmarks.prt_packing`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.prt_packing import main

if __name__ == "__main__":
    sys.exit(main())
