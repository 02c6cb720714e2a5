#!/usr/bin/env bash
# Build everything mjasc needs on a fresh machine, and nothing twice.
#   - Debian's libosmesa6 (offscreen software OpenGL for the MP4 video), installed when missing
#     and we are root; otherwise a clear message saying what to install.
#   - A virtual environment in .venv with the pinned packages of requirements.lock and mjasc
#     itself (editable, with the test extras). Rebuilt only when pyproject.toml or the lock changes.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"

if ! ldconfig -p 2>/dev/null | grep -q 'libOSMesa\.so'; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null; then
    echo "[bootstrap] installing Debian package libosmesa6 (offscreen rendering)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libosmesa6 >/dev/null
  else
    echo "[bootstrap] libOSMesa is missing: install Debian's 'libosmesa6' (sudo apt-get install libosmesa6)." >&2
    echo "[bootstrap] Continuing: everything but offscreen video works without it." >&2
  fi
fi

# The interpreter: $PYTHON when set; otherwise the distribution's own CPython (/usr/bin/python3) when
# it is 3.11 or newer, else python3 on PATH. Distributions build CPython optimised (profile-guided,
# the interpreter linked statically); a default self-built one (pyenv's: a shared libpython, no
# profile) runs mjasc's Python ~5–10 % slower (docs/speed.md, "The interpreter").
usable() { "$1" -c 'import sys, ensurepip, venv; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; }
if [ -n "${PYTHON:-}" ]; then
  py="$PYTHON"
elif [ -x /usr/bin/python3 ] && /usr/bin/python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
  py=/usr/bin/python3
  if ! usable "$py" && [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null; then
    echo "[bootstrap] installing Debian package python3-venv (the distribution's interpreter makes .venv)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null || true
  fi
  usable "$py" || py=python3
else
  py=python3
fi
# What .venv was built from (rebuilt when the interpreter changes, as when the pins do).
want="$("$py" -c 'import sys, os; print(os.path.realpath(sys.executable), sys.version.split()[0])')"
stamp=".venv/.mjasc-installed"
if [ ! -x .venv/bin/python ] || [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ requirements.lock -nt "$stamp" ] \
    || [ "$(cat "$stamp")" != "$want" ]; then
  echo "[bootstrap] building .venv with $want (pinned by requirements.lock)"
  rm -rf .venv
  "$py" -m venv .venv
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -c requirements.lock -e ".[dev]"
  echo "$want" > "$stamp"
fi
# Byte-compile mjasc's modules (only those changed since the last time): an editable install
# writes them at first import, unless the environment forbids it (PYTHONDONTWRITEBYTECODE), and
# then every process — each campaign child too — would compile ~230 modules from source (~0.3 s).
.venv/bin/python -m compileall -q mjasc >/dev/null
