#!/usr/bin/env python3
"""How often a fresh process dies while Blender starts its GPU context.

Each run is a new interpreter that imports bpy, registers the add-on, calls
``ensure_gpu`` and frees one 4 × 4 offscreen, as a user's script starts (the same steps as
``tests/blender/gpu/test_gpu_state.py::test_initialising_the_gpu_prints_nothing_a_user_cannot_act_on``).
The backend is whatever the environment picks (``VK_ICD_FILENAMES`` chooses lavapipe or
none). ``--tree PATH`` runs the package of another checkout (for example a ``git worktree``
of an older commit). Prints ``died N of RUNS`` with the exit codes; exits 1 when any died.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
# The second import is the layout before issue 17, for --tree runs on older commits.
_CHILD = """import bpy
from spectral_materials import blender as addon
addon.register()
try:
    from spectral_materials.blender.gpu import context as gpu_context
except ImportError:
    from spectral_materials.blender import gpu_context
gpu_context.ensure_gpu()
import gpu
gpu.types.GPUOffScreen(4, 4).free()
print("drawn")
gpu_context.exit_process(0)
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--tree", type=Path, default=REPO,
                        help="the checkout whose package the runs import (default: this one)")
    args = parser.parse_args(argv)
    codes: Counter[int] = Counter()
    for _ in range(args.runs):
        done = subprocess.run([sys.executable, "-c", _CHILD], cwd=args.tree.resolve(),
                              capture_output=True, text=True, timeout=600, check=False)
        ok = done.returncode == 0 and done.stdout.strip().endswith("drawn")
        codes[0 if ok else done.returncode or -1] += 1
    died = args.runs - codes[0]
    print(f"died {died} of {args.runs} (exit codes: {dict(sorted(codes.items()))})")
    return 1 if died else 0


if __name__ == "__main__":
    sys.exit(main())
