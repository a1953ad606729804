#!/usr/bin/env bash
# Install the Debian 12 packages pnmold needs outside PyPI; safe to run again.
#
#   python3-venv      `python3 -m venv` for the project's virtualenv
#   libglu1-mesa ...  shared libraries the PyPI wheels of gmsh and cadquery-ocp load
#   prusa-slicer      the real slicer behind pnmold.checks.slicer (its CLI runs headless as is)
#   libegl-mesa0 ...  EGL with Mesa's software renderer: pnmold.report.render draws the report's
#                     pictures with VTK off screen, without a display or a GPU
#   chromium ...      headless browser and its WebDriver: the test of report.html opens the page
#   calculix-ccx      CalculiX: tests/test_export.py runs pnmold's exported Abaqus/CalculiX deck
#
# Only missing packages are installed (checked with `dpkg -s`); when nothing is missing,
# apt is not touched and root is not needed. Otherwise run as root, or with sudo present.
set -euo pipefail

PACKAGES=(
    python3-venv
    libglu1-mesa libgl1 libxrender1 libxcursor1 libxft2 libxinerama1 libgomp1 libxi6
    libxext6
    prusa-slicer
    libegl1 libegl-mesa0 libgl1-mesa-dri
    chromium chromium-driver
    calculix-ccx
)

is_installed() {
    dpkg -s "$1" 2>/dev/null | grep -q '^Status: install ok installed$'
}

missing=()
for pkg in "${PACKAGES[@]}"; do
    is_installed "$pkg" || missing+=("$pkg")
done

if [ "${#missing[@]}" -eq 0 ]; then
    echo "install-system-deps: all ${#PACKAGES[@]} packages already installed, nothing to do"
    exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
    as_root=()
elif command -v sudo >/dev/null 2>&1; then
    as_root=(sudo)
else
    echo "install-system-deps: missing ${missing[*]}; run as root or install sudo" >&2
    exit 1
fi

echo "install-system-deps: installing ${missing[*]}"
apt_opts=(-o DPkg::Lock::Timeout=600 -y -q --no-install-recommends)
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get -q -o DPkg::Lock::Timeout=600 update
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install "${apt_opts[@]}" "${missing[@]}"

for pkg in "${missing[@]}"; do
    is_installed "$pkg" || { echo "install-system-deps: $pkg failed to install" >&2; exit 1; }
done
echo "install-system-deps: done"
