#!/usr/bin/env bash
# The test command: set up the pinned environment, lint, run the default (non-slow) suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/ruff check .
.venv/bin/python -m pytest -q "$@"
