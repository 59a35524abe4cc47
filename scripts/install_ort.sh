#!/usr/bin/env bash
# Installs the ONNX Runtime shared library used by the style-transfer pass (`panoconv::style`).
#
# ort 2.0.0-rc.15 is built with `load-dynamic`: nothing is linked at build time, the library is
# opened at run time. We take it from the official PyPI wheel `onnxruntime==1.31.1` (CPU build),
# unpacking only `onnxruntime/capi/` into `<repo>/.ort/`.
#
# Idempotent: if the library is already there, nothing is downloaded. Always prints the absolute
# path of the .so on stdout (last line), e.g. to use as ORT_DYLIB_PATH.
#
# Environment:
#   ORT_VERSION   wheel version (default 1.31.1)
#   PYTHON        python interpreter with pip (default: python3)
set -euo pipefail

ORT_VERSION="${ORT_VERSION:-1.31.1}"
PYTHON="${PYTHON:-python3}"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEST="$REPO/.ort"
LIB="$DEST/libonnxruntime.so.$ORT_VERSION"

if [[ -f "$LIB" ]]; then
    echo "$LIB"
    exit 0
fi

mkdir -p "$DEST"
TMP="$(mktemp -d "$DEST/.download.XXXXXX")"
trap 'rm -rf "$TMP"' EXIT

echo "install_ort: downloading onnxruntime==$ORT_VERSION wheel from PyPI" >&2
"$PYTHON" -m pip download --quiet --disable-pip-version-check \
    "onnxruntime==$ORT_VERSION" --no-deps --only-binary=:all: -d "$TMP" >&2

WHEEL="$(ls "$TMP"/onnxruntime-"$ORT_VERSION"-*.whl 2>/dev/null | head -n 1 || true)"
if [[ -z "$WHEEL" ]]; then
    echo "install_ort: no onnxruntime $ORT_VERSION wheel for this platform" >&2
    exit 1
fi

# A wheel is a zip; unpack only the native part.
if command -v unzip >/dev/null 2>&1; then
    unzip -q -o "$WHEEL" 'onnxruntime/capi/*' -d "$TMP/x"
else
    "$PYTHON" - "$WHEEL" "$TMP/x" <<'EOF'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    z.extractall(sys.argv[2], [n for n in z.namelist() if n.startswith("onnxruntime/capi/")])
EOF
fi

shopt -s nullglob
found=0
for f in "$TMP"/x/onnxruntime/capi/libonnxruntime*.so*; do
    cp -f "$f" "$DEST/"
    found=1
done
if [[ $found -eq 0 || ! -f "$LIB" ]]; then
    echo "install_ort: $LIB not found in $(basename "$WHEEL")" >&2
    exit 1
fi
# Convenience name for tools that look for the unversioned file.
ln -sf "$(basename "$LIB")" "$DEST/libonnxruntime.so"
echo "$LIB"
