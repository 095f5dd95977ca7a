#!/usr/bin/env python3
"""The horizon edge rule's frame cost, ``benchmarks/edge_cost.py``.

The same as ``python -m benchmarks.edge_cost`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.edge_cost import main

if __name__ == "__main__":
    sys.exit(main())
