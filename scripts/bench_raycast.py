#!/usr/bin/env python3
"""The raycast benchmark, ``benchmarks/raycast.py``.

The same as ``python -m benchmarks.raycast`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.raycast import main

if __name__ == "__main__":
    sys.exit(main())
