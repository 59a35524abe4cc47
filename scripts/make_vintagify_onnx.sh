#!/usr/bin/env bash
# A real trained CycleGAN generator as panoconv's style model, for realistic style benchmarks:
# downloads the PyPI wheel of vintagify 0.1.2 (MIT; its PyTorch state dict, not its
# dependencies), and converts the state dict to ONNX without PyTorch
# (scripts/make_vintagify_onnx.py) into <repo>/.style/vintagify.onnx (git-ignored, 45 MB).
#
# Idempotent: nothing is downloaded when the model is already there. Prints the model's path
# on stdout (last line).
#
# Environment:
#   PYTHON   interpreter that makes the environment (default: python3)
set -euo pipefail

PYTHON="${PYTHON:-python3}"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEST="$REPO/.style"
MODEL="$DEST/vintagify.onnx"
if [[ -f "$MODEL" ]]; then
    echo "$MODEL"
    exit 0
fi
mkdir -p "$DEST"
VENV="$DEST/venv"
if [[ ! -x "$VENV/bin/python" ]]; then
    "$PYTHON" -m venv "$VENV" >&2
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
        "numpy==2.2.6" "onnx==1.23.2" >&2
fi
TMP="$(mktemp -d "$DEST/.download.XXXXXX")"
trap 'rm -rf "$TMP"' EXIT
"$VENV/bin/python" -m pip download --quiet --disable-pip-version-check --no-deps \
    "vintagify==0.1.2" -d "$TMP" >&2
(cd "$TMP" && "$VENV/bin/python" -m zipfile -e vintagify-0.1.2-py3-none-any.whl wheel >&2)
"$VENV/bin/python" "$REPO/scripts/make_vintagify_onnx.py" \
    --pth "$TMP/wheel/vintagify/resources/G_A2B_epoch33.pth" --out "$TMP/vintagify.onnx" >&2
mv "$TMP/vintagify.onnx" "$MODEL"
echo "$MODEL"
