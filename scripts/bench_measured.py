#!/usr/bin/env python3
"""The measured benchmark, ``benchmarks/measured.py``.

The same as ``python -m benchmarks.measured`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.measured import main

if __name__ == "__main__":
    sys.exit(main())
