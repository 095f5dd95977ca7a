#!/usr/bin/env bash
# The test command: set up the pinned environment, lint, run the default (non-slow) suite,
# then the main job in its quick mode (every demo section at small sizes), so that what CI
# proves includes the demo running to the end in one process on a clean checkout.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/ruff check .
.venv/bin/python -m pytest -q "$@"
demo_out="$(mktemp -d)"
trap 'rm -rf "$demo_out"' EXIT
if ! .venv/bin/python scripts/demo.py --quick --quiet --out "$demo_out" >"$demo_out/log" 2>&1
then
  cat "$demo_out/log" >&2
  echo "run_tests: the quick demo (scripts/demo --quick) failed" >&2
  exit 1
fi
echo "demo --quick: $(tail -n 1 "$demo_out/log")"
