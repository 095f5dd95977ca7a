#!/usr/bin/env python3
"""The colour-targets benchmark, ``benchmarks/colour_targets.py``.

The same as ``python -m benchmarks.colour_targets`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.colour_targets import main

if __name__ == "__main__":
    sys.exit(main())
