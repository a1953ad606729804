#!/usr/bin/env bash
# Set up pnmold on a fresh Debian 12 machine with Python 3.11: system packages (apt),
# then a virtualenv in .venv with pnmold and its test extra (pip, PyPI). Safe to re-run.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-system-deps.sh

PY=${PYTHON:-$(command -v python3.11 || command -v python3)}
if [ ! -x .venv/bin/python ]; then
    "$PY" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e '.[test]'
echo "setup: pnmold $(.venv/bin/python -c 'import pnmold; print(pnmold.__version__)') ready in .venv"
