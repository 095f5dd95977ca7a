#!/usr/bin/env bash
# Create .venv with the pinned dependencies (idempotent). Debian: installs python3.11 and the
# GL/EGL libraries bpy needs if they are missing. Quiet unless something fails: each step's
# output goes to a log that is printed only when the step fails.
set -euo pipefail
cd "$(dirname "$0")/.."

log="$(mktemp)"
trap 'rm -f "$log"' EXIT
# quietly WHAT COMMAND...: run COMMAND with its output in the log; on failure say WHAT
# failed, show the log and stop.
quietly() {
  local what="$1"
  shift
  if ! "$@" >"$log" 2>&1; then
    echo "setup_env: $what failed:" >&2
    cat "$log" >&2
    exit 1
  fi
}
apt_install() {
  command -v apt-get >/dev/null 2>&1 || return 1
  quietly "apt-get update" apt-get update -qq
  quietly "apt-get install $*" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@"
}

PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  PY="$(command -v python3.11 || true)"
fi
if [ -z "$PY" ]; then
  apt_install python3.11 python3.11-venv ||
    { echo "setup_env: Python 3.11 is required (bpy 5.0.1 supports only 3.11)" >&2; exit 1; }
  PY="$(command -v python3.11)"
fi
if [ ! -x .venv/bin/python ] || ! .venv/bin/python -c 'import sys; assert sys.version_info[:2] == (3, 11)' 2>/dev/null; then
  rm -rf .venv
  if ! "$PY" -m venv .venv >/dev/null 2>&1; then
    apt_install python3.11-venv || true
    quietly "creating .venv with $PY" "$PY" -m venv .venv
  fi
fi
stamp=.venv/.requirements.sha
want="$(cat requirements/*.txt pyproject.toml scripts/setup_env.sh | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  quietly "upgrading pip" .venv/bin/python -m pip install --upgrade pip
  quietly "installing requirements/dev.txt" .venv/bin/python -m pip install -r requirements/dev.txt
  # The project itself, editable, so `python -m spectral_materials` works from anywhere.
  quietly "installing the project (editable)" \
    .venv/bin/python -m pip install --no-deps -e .
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
  apt_install libxrender1 libxi6 libxkbcommon0 libxxf86vm1 libxfixes3 libsm6 \
    libgl1 libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libglu1-mesa || true
  quietly "importing bpy 5.0.1 (X11/GL libraries missing?)" .venv/bin/python -c 'import bpy'
fi
