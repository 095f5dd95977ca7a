#!/usr/bin/env bash
# The factor benchmark of the paper's Figure 3 (the main job is scripts/demo).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/python scripts/bench_factor.py "$@"
