#!/usr/bin/env bash
# The main job (until the Blender add-on lands): the factor benchmark of the paper's Figure 3.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/python scripts/bench_factor.py "$@"
