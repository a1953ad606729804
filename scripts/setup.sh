#!/usr/bin/env bash
# Set up pnmold on a fresh Debian 12 machine with Python 3.11: system packages (apt),
# then a virtualenv in .venv with pnmold and its test extra (pip, PyPI). Safe to re-run.
#
#   bash scripts/setup.sh            the versions pinned in requirements.lock (pip constraints), as CI
#   bash scripts/setup.sh --relock   the newest versions pyproject.toml allows, then requirements.lock
#                                    rewritten from .venv (commit it with what the upgrade changed)
#
# The lock pins every package of .venv, so timings and sweep rows are reproducible; pyproject.toml
# keeps the ranges pnmold works with (a user's `pip install pnmold` reads those, not the lock).
set -euo pipefail
cd "$(dirname "$0")/.."

relock=0
case "${1:-}" in
    "") ;;
    --relock) relock=1 ;;
    *) echo "usage: bash scripts/setup.sh [--relock]" >&2; exit 2 ;;
esac

bash scripts/install-system-deps.sh

PY=${PYTHON:-$(command -v python3.11 || command -v python3)}
if [ ! -x .venv/bin/python ]; then
    "$PY" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
if [ "$relock" -eq 1 ]; then
    .venv/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager -e '.[test]'
    {
        echo "# Every package of .venv at its tested version: pip constraints for scripts/setup.sh and CI."
        echo "# Written by 'bash scripts/setup.sh --relock' ($(.venv/bin/python --version), $(uname -m)); do not edit."
        .venv/bin/python -m pip list --format=freeze --exclude-editable | grep -v -E '^pip=='
    } > requirements.lock.tmp
    mv requirements.lock.tmp requirements.lock
    echo "setup: wrote requirements.lock ($(grep -vc '^#' requirements.lock) packages)"
else
    .venv/bin/python -m pip install --quiet -c requirements.lock -e '.[test]'
fi
echo "setup: pnmold $(.venv/bin/python -c 'import pnmold; print(pnmold.__version__)') ready in .venv"
