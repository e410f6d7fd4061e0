#!/usr/bin/env bash
# Installs everything this project needs on Debian 12, idempotently:
# system packages through apt (OpenFOAM v1912, libraries the gmsh/VTK wheels load) and the
# Python packages into .venv/ at the repository root.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
APT_PACKAGES="python3 python3-venv python3-dev build-essential openfoam \
  libglu1-mesa libgl1 libxrender1 libxcursor1 libxft2 libxinerama1"
missing=""
for pkg in $APT_PACKAGES; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing="$missing $pkg"
done
if [ -n "$missing" ]; then
  echo "setup: installing system packages:$missing" >&2
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q $missing
fi

if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
stamp=".venv/.installed-$(sha1sum pyproject.toml | cut -c1-12)"
if [ ! -f "$stamp" ]; then
  echo "setup: installing Python packages into .venv" >&2
  .venv/bin/pip install -q --upgrade pip
  .venv/bin/pip install -q -e ".[dev,cluster,post]"
  rm -f .venv/.installed-*
  touch "$stamp"
fi
