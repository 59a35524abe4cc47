#!/usr/bin/env bash
# Makes docs/images/pandaset_equirect.png: frame 20 of the real PandaSet sequence in
# ../shared/pandaset/002 (PandaSet, Hesai and Scale AI, CC BY 4.0) converted by the Python
# adapter (`python -m panoconv pandaset`) into a 360° panorama, its cuboids drawn by
# `panoconv preview` from the written files alone (cropped to the rows the cameras cover).
#
# Usage: scripts/make_pandaset_picture.sh [PYTHON]
#   PYTHON: an interpreter with the package and pandas (default: the tests' .venv-python,
#   made by scripts/install_python_package.sh). $PANOCONV_SHARED: the shared data (../shared).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
python="${1:-.venv-python/bin/python}"
seq="${PANOCONV_SHARED:-../shared}/pandaset/002"
[[ -d "$seq/camera" ]] || { echo "no PandaSet sequence at $seq" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$python" -m panoconv pandaset --input "$seq" --to equirect --pano-width 1600 --crop 0,230,1600,360 --output "$work/out" --quiet
"$python" -m panoconv preview "$work/out" --frame 20 --no-depth --no-text --tile-width 1600 --output docs/images/pandaset_equirect.png
