#!/usr/bin/env bash
# Installs the Python packages that the tests use as independent references (pycocotools for
# the COCO export, OpenCV's fisheye and omnidir modules for the camera models, kitti360scripts
# for the KITTI-360 readers, nuscenes-devkit for the nuScenes tables, pandas for the PandaSet
# pickles that tests/pandaset_nuscenes.py rebuilds as nuScenes tables) into a virtual
# environment of their own, `<repo>/.venv-test/`, from PyPI.
#
# kitti360scripts is installed without its declared dependencies: the loaders the tests use
# (calibration, fisheye YAML, 3D boxes, camera projections) need only numpy and PyYAML, while
# its 2D-annotation and viewer helpers pull matplotlib and scikit-image (with SciPy), which the
# tests stub (tests/kitti360_scripts.py). nuscenes-devkit likewise: its table loader, poses and
# projections need numpy, OpenCV and pyquaternion; its renderers' and map helpers' imports
# (matplotlib, scikit-learn, Pillow, tqdm, cachetools, shapely) are stubbed
# (tests/nuscenes_devkit.py).
#
# Idempotent: nothing is downloaded when the environment already holds these pinned versions.
# Always prints the absolute path of the environment's python on stdout (last line), e.g. to
# use as PANOCONV_TEST_PYTHON.
#
# Environment:
#   PYTHON   interpreter that makes the environment (default: python3)
set -euo pipefail

PYTHON="${PYTHON:-python3}"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$REPO/.venv-test"
REQUIREMENTS=(
    "numpy==2.2.6"
    "pycocotools==2.0.11"
    "opencv-contrib-python-headless==4.11.0.86"
    "PyYAML==6.0.2"
    "pandas==2.2.3"
)
NO_DEPS=(
    "kitti360Scripts==1.0.0"
    "nuscenes-devkit==1.2.0"
    "pyquaternion==0.9.9"
)
STAMP="$VENV/.panoconv-requirements"
WANT="$(printf '%s\n' "${REQUIREMENTS[@]}" "${NO_DEPS[@]}")"

if [[ -x "$VENV/bin/python" && -f "$STAMP" && "$(cat "$STAMP")" == "$WANT" ]]; then
    echo "$VENV/bin/python"
    exit 0
fi

echo "install_test_python: installing ${REQUIREMENTS[*]} ${NO_DEPS[*]} into $VENV" >&2
rm -rf "$VENV"
"$PYTHON" -m venv "$VENV" >&2
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
    "${REQUIREMENTS[@]}" >&2
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
    --no-deps "${NO_DEPS[@]}" >&2
printf '%s\n' "$WANT" >"$STAMP"
echo "$VENV/bin/python"
