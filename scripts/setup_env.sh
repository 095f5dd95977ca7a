#!/usr/bin/env bash
# bash scripts/setup_env.sh [LEG]: create .venvs/LEG with the pinned dependencies of one test
# leg (idempotent), LEG one of 4.5, 5.0 (Python 3.11, numpy 1.26), 5.2, 5.3 (Python 3.13,
# numpy 2); the pins are requirements/leg-LEG.txt. Without LEG: the default leg, $DEFAULT_LEG
# below, and .venv (what scripts/demo, the README's commands and a plain
# `.venv/bin/python -m pytest` use) becomes a link to it. Debian: installs the Python and the
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

DEFAULT_LEG=5.3
LEG="${1:-$DEFAULT_LEG}"
case "$LEG" in
  4.5 | 5.0) pyver=3.11 ;;
  5.2 | 5.3) pyver=3.13 ;;
  *) echo "setup_env: unknown leg '$LEG' (one of 4.5, 5.0, 5.2, 5.3)" >&2; exit 2 ;;
esac
venv=".venvs/$LEG"
requirements="requirements/leg-$LEG.txt"

# The leg's Python: $PYTHON if it is that version, pythonX.Y on PATH, pyenv's, else Debian's.
is_python() { [ -n "$1" ] && "$1" -c "import sys; assert '%d.%d' % sys.version_info[:2] == '$pyver'" 2>/dev/null; }
PY=""
for candidate in "${PYTHON:-}" "$(command -v "python$pyver" || true)" \
  "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$pyver"*/bin/python"$pyver"; do
  if is_python "$candidate"; then PY="$candidate"; break; fi
done
if [ -z "$PY" ]; then
  (apt_install "python$pyver" "python$pyver-venv") >/dev/null 2>&1 || true
  is_python "$(command -v "python$pyver")" && PY="$(command -v "python$pyver")"
fi
if [ -z "$PY" ]; then
  echo "setup_env: leg $LEG needs Python $pyver: put python$pyver on PATH (\`pyenv install" \
    "$pyver\` or \`apt-get install python$pyver python$pyver-venv\`) or set PYTHON=/path/to/it" >&2
  exit 1
fi
if [ ! -x "$venv/bin/python" ] ||
  ! is_python "$venv/bin/python"
then
  rm -rf "$venv"
  mkdir -p .venvs
  if ! "$PY" -m venv "$venv" >/dev/null 2>&1; then
    apt_install "python$pyver-venv" || true
    quietly "creating $venv with $PY" "$PY" -m venv "$venv"
  fi
fi
stamp="$venv/.requirements.sha"
want="$(cat requirements/*.txt pyproject.toml scripts/setup_env.sh | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  quietly "upgrading pip in $venv" "$venv/bin/python" -m pip install --upgrade pip
  quietly "installing $requirements" "$venv/bin/python" -m pip install -r "$requirements"
  # The project itself, editable, so `python -m spectral_materials` works from anywhere.
  quietly "installing the project (editable) in $venv" \
    "$venv/bin/python" -m pip install --no-deps -e .
  echo "$want" > "$stamp"
fi
if [ $# -eq 0 ]; then
  # .venv: the default leg (a link; an older checkout's .venv directory is replaced).
  if [ "$(readlink .venv 2>/dev/null)" != "$venv" ]; then
    rm -rf .venv
    ln -s "$venv" .venv
  fi
fi
# bpy loads X11/GL/EGL libraries at import even headless; a bare Debian image lacks some.
# Headless drawing (the gpu tests, offscreen renders, EEVEE) also needs Mesa's EGL, GBM
# and software rasteriser, which bpy's import does not check.
# Mesa's software Vulkan (lavapipe) too, so that the Vulkan leg of run_tests.sh can draw.
gpu_libraries_present() {
  ldconfig -p | grep -q 'libEGL_mesa.so.0' && ldconfig -p | grep -q 'libgbm.so.1' &&
    ldconfig -p | grep -q 'libvulkan.so.1' && compgen -G '/usr/share/vulkan/icd.d/lvp_icd.*.json' >/dev/null &&
    { compgen -G '/usr/lib/*/dri/swrast_dri.so' >/dev/null || [ -e /usr/lib/dri/swrast_dri.so ]; }
}
if ! "$venv/bin/python" -c 'import bpy' >/dev/null 2>&1 || ! gpu_libraries_present; then
  apt_install libxrender1 libxi6 libxkbcommon0 libxxf86vm1 libxfixes3 libsm6 \
    libgl1 libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libglu1-mesa \
    libvulkan1 mesa-vulkan-drivers || true
  quietly "importing bpy in $venv (X11/GL libraries missing?)" "$venv/bin/python" -c 'import bpy'
fi
