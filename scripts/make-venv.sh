#!/usr/bin/env bash
# Makes the project's Python environment: scripts/make-venv.sh [VENV_DIR] (default build/venv).
# Debian's python3 (python3-venv from scripts/install-deps.sh), the pinned packages of
# python/requirements.txt from PyPI, and the repository's python/ folder on the venv's path (a
# .pth file, so `auger import` runs the checked-out code). Idempotent: pip runs only when the
# venv is new or the requirements file changed since the last successful install.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv=${1:-$root/build/venv}
req=$root/python/requirements.txt
python=${AUGER_VENV_PYTHON:-/usr/bin/python3}
stamp=$venv/.requirements.sha256

want=$(sha256sum "$req" | cut -d' ' -f1)
if [[ -x $venv/bin/python3 && -f $stamp && $(cat "$stamp") == "$want" ]] &&
   "$venv/bin/python3" -c 'import sys' 2>/dev/null; then
  echo "make-venv: $venv up to date"
else
  if ! "$venv/bin/python3" -c 'import sys' 2>/dev/null; then
    if [[ -e $venv && ! -f $venv/pyvenv.cfg ]]; then
      echo "make-venv: $venv exists and is not a Python venv; not touching it" >&2
      exit 1
    fi
    rm -rf "$venv"
    "$python" -m venv "$venv"
  fi
  start=$(date +%s)
  "$venv/bin/python3" -m pip install --quiet --no-input --disable-pip-version-check \
    --requirement "$req"
  echo "$want" > "$stamp"
  echo "make-venv: installed python/requirements.txt into $venv in $(( $(date +%s) - start )) s"
fi
# Always rewritten (cheap): the tree this venv belongs to may have moved.
site=$("$venv/bin/python3" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$root/python" > "$site/auger.pth"
