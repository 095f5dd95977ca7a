#!/usr/bin/env bash
# Create .venv with the pinned dependencies (idempotent). Debian: installs python3.11 if missing.
set -euo pipefail
cd "$(dirname "$0")/.."
PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  PY="$(command -v python3.11 || true)"
fi
if [ -z "$PY" ]; then
  if command -v apt-get >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq python3.11 python3.11-venv >/dev/null
    PY="$(command -v python3.11)"
  else
    echo "Python 3.11 is required (bpy 5.0.1 supports only 3.11)" >&2
    exit 1
  fi
fi
if [ ! -x .venv/bin/python ] || ! .venv/bin/python -c 'import sys; assert sys.version_info[:2] == (3, 11)' 2>/dev/null; then
  rm -rf .venv
  if ! "$PY" -m venv .venv 2>/dev/null; then
    apt-get update -qq && apt-get install -y -qq python3.11-venv >/dev/null
    "$PY" -m venv .venv
  fi
fi
stamp=.venv/.requirements.sha
want="$(cat requirements/*.txt pyproject.toml | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -r requirements/dev.txt
  # The project itself, editable, so `python -m spectral_materials` works from anywhere.
  .venv/bin/python -m pip install -q --no-deps -e .
  echo "$want" > "$stamp"
fi
# bpy loads X11/GL/EGL libraries at import even headless; a bare Debian image lacks some.
# Headless drawing (the gpu tests, offscreen renders, EEVEE) also needs Mesa's EGL, GBM
# and software rasteriser, which bpy's import does not check.
gpu_libraries_present() {
  ldconfig -p | grep -q 'libEGL_mesa.so.0' && ldconfig -p | grep -q 'libgbm.so.1' &&
    { compgen -G '/usr/lib/*/dri/swrast_dri.so' >/dev/null || [ -e /usr/lib/dri/swrast_dri.so ]; }
}
if ! .venv/bin/python -c 'import bpy' >/dev/null 2>&1 || ! gpu_libraries_present; then
  if command -v apt-get >/dev/null 2>&1; then
    apt-get update -qq
    apt-get install -y -qq libxrender1 libxi6 libxkbcommon0 libxxf86vm1 libxfixes3 libsm6 \
      libgl1 libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libglu1-mesa >/dev/null
  fi
  .venv/bin/python -c 'import bpy' || { echo "bpy 5.0.1 does not import; see above" >&2; exit 1; }
fi
