#!/usr/bin/env python3
"""The reader_memory benchmark, ``benchmarks/reader_memory.py``.

The same as ``python -m benchmarks.reader_memory`` from the repository root; arguments as
there (``--help``).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.reader_memory import main

if __name__ == "__main__":
    sys.exit(main())
