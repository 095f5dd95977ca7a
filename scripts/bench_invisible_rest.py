#!/usr/bin/env python3
"""The invisible-rest sweep, ``benchmarks/invisible_rest.py``.

The same as ``python -m benchmarks.invisible_rest`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.invisible_rest import main

if __name__ == "__main__":
    sys.exit(main())
