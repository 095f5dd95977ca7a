#!/usr/bin/env python3
"""The benchmarks' shared helpers under their name before issue 17 (now
``benchmarks/harness.py``): ``shared/gpu-replay/export_cases.py`` imports ``gpu_machine``
from here."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.harness import gpu_machine  # noqa: F401
