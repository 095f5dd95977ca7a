#!/bin/bash
# One call on a lent GPU machine (the `device` tool), from the repository root:
#   carry .gl (GLVND loader .debs), .whl (moderngl, glcontext for its Python) and
#   .replay/data (export_cases.py's output, sensitivity masks made on llvmpipe).
# Writes $OUT/gpu_results.json and $OUT/log.txt. Arguments go to run_gpu.py.
set -u
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site
vendor=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$vendor" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$vendor
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv
SM_REQUIRE_GPU=1 PYTHONUNBUFFERED=1 python3 benchmarks/gpu_replay/run_gpu.py \
    --data .replay/data --out "$OUT/gpu_results.json" "$@" 2>&1 | tee "$OUT/log.txt"
