#!/usr/bin/env bash
# End-to-end benchmark: panoconv vs the OpenCV-Python converter vs the codec floor (alone and
# with the I/O every converted frame does).
#   benches/run.sh [--frames N] [--rounds R] [--jobs J] [--tmp DIR] [--compression default] [--old BIN]
# Sets up benches/.venv (opencv-python-headless, numpy) on first use, builds the release binary and
# the codec_floor example, and runs benches/run.py. Nothing is written into the repository except
# benches/.venv (ignored by git); the frame sets live in a temporary folder that is removed after.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
venv="$here/.venv"
if ! "$venv/bin/python" -c 'import cv2, numpy' 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet opencv-python-headless==5.0.0.93 numpy==2.4.6
fi
(cd "$root" && cargo build --release --quiet --bin panoconv --example codec_floor)
target="${CARGO_TARGET_DIR:-$root/target}"
exec "$venv/bin/python" "$here/run.py" --bin "$target/release/panoconv" \
    --floor "$target/release/examples/codec_floor" "$@"
