#!/usr/bin/env bash
# Random cameras at training time (benches/random_cameras.py) with the extension module built as
# `pip install .` builds it: cargo's release profile. The module goes into
# target/bench-python/panoconv/ beside a copy of python/panoconv/'s Python files, so the Python
# tests' module (scripts/install_python_package.sh's dev-profile build) is left alone. The
# Python that runs it is $PYTHON, else benches/.venv (opencv-python-headless and numpy, pinned; set up on
# first use as benches/run.sh does).
#   benches/random_cameras.sh [--kitti DIR] [--samples N] [--workers N] [--rounds R] [--dataset-only]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
if [ -z "${PYTHON:-}" ]; then
    venv="$here/.venv"
    if ! "$venv/bin/python" -c 'import cv2, numpy' 2>/dev/null; then
        python3 -m venv "$venv"
        "$venv/bin/pip" install --quiet opencv-python-headless==5.0.0.93 numpy==2.4.6
    fi
    PYTHON="$venv/bin/python"
fi
(cd "$root" && cargo build --locked --release --quiet -p panoconv-python --lib)
target="${CARGO_TARGET_DIR:-$root/target}"
package="$target/bench-python/panoconv"
rm -rf "$package"
mkdir -p "$package"
cp "$root"/python/panoconv/*.py "$root/python/panoconv/py.typed" "$package/"
cp "$target/release/lib_native.so" "$package/_native.abi3.so"
# per core: one thread (numpy's BLAS and panoconv's rayon pool would otherwise add threads
# whose idle spinning counts as the process's CPU time)
export OPENBLAS_NUM_THREADS=1 RAYON_NUM_THREADS=1
PYTHONPATH="$target/bench-python" exec "$PYTHON" "$here/random_cameras.py" "$@"
