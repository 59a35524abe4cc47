#!/usr/bin/env bash
# Installs the ONNX Runtime shared library used by the style-transfer pass (`panoconv::style`).
#
# ort 2.0.0-rc.15 is built with `load-dynamic`: nothing is linked at build time, the library is
# opened at run time. We take it from the official PyPI wheels, unpacking only what is native.
#
#   scripts/install_ort.sh                      CPU: onnxruntime==1.31.1 into <repo>/.ort/
#   scripts/install_ort.sh --gpu                GPU: onnxruntime-gpu==1.31.1 into <repo>/.ort-gpu/,
#                                               NVIDIA's CUDA 13 / cuDNN 9 wheels' libraries into
#                                               <repo>/.ort-gpu/cuda/ (about 1.5 GB of wheels)
#   scripts/install_ort.sh --gpu --download DIR only downloads the GPU wheels into DIR (for a
#                                               machine without network)
#   scripts/install_ort.sh --gpu --wheels DIR   installs from the wheels in DIR, offline
#
# `panoconv --device cuda` with the printed library (--ort-lib or ORT_DYLIB_PATH) loads the
# libraries of the `cuda/` folder beside it before the CUDA provider.
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

gpu=0 wheels="" download=""
while [[ $# -gt 0 ]]; do
    case "$1" in
        --gpu) gpu=1 ;;
        --wheels) wheels="${2:?--wheels needs a folder}"; shift ;;
        --download) download="${2:?--download needs a folder}"; shift ;;
        *) echo "install_ort: unknown option $1 (see the comment at the top of $0)" >&2; exit 2 ;;
    esac
    shift
done
if [[ $gpu -eq 0 && ( -n "$wheels" || -n "$download" ) ]]; then
    echo "install_ort: --wheels and --download are for --gpu" >&2
    exit 2
fi

# onnxruntime-gpu 1.31.1 declares its CUDA needs as extras (`[cuda,cudnn]`: nvrtc, cudart,
# cufft, curand, cudnn-cu13, which pulls cublas, and cufft pulls nvjitlink); pinned to the
# versions pip resolved on 2026-11-27, so every machine gets the same files.
GPU_WHEELS=(
    "onnxruntime-gpu==$ORT_VERSION"
    "nvidia-cuda-runtime==13.5.37"
    "nvidia-cuda-nvrtc==13.5.37"
    "nvidia-cublas==13.10.0.20"
    "nvidia-cufft==12.5.0.14"
    "nvidia-curand==10.4.5.25"
    "nvidia-nvjitlink==13.5.37"
    "nvidia-cudnn-cu13==9.28.1.4"
)

fetch() { # fetch DIR SPEC...: the wheels of SPEC for this platform, without dependencies
    local dir="$1"
    shift
    echo "install_ort: downloading $* from PyPI" >&2
    "$PYTHON" -m pip download --quiet --disable-pip-version-check --no-deps \
        --only-binary=:all: -d "$dir" "$@" >&2
}

unpack() { # unpack WHEEL DIR PREFIX: the members under PREFIX
    "$PYTHON" - "$@" <<'PY'
import sys, zipfile
wheel, dest, prefix = sys.argv[1:]
with zipfile.ZipFile(wheel) as z:
    z.extractall(dest, [n for n in z.namelist() if n.startswith(prefix)])
PY
}

if [[ -n "$download" ]]; then
    mkdir -p "$download"
    fetch "$download" "${GPU_WHEELS[@]}"
    du -sh "$download" >&2
    echo "$download"
    exit 0
fi

if [[ $gpu -eq 1 ]]; then
    DEST="$REPO/.ort-gpu"
    WHEEL_NAME="onnxruntime_gpu"
else
    DEST="$REPO/.ort"
    WHEEL_NAME="onnxruntime"
fi
LIB="$DEST/libonnxruntime.so.$ORT_VERSION"
if [[ -f "$LIB" ]]; then
    echo "$LIB"
    exit 0
fi

mkdir -p "$DEST"
TMP="$(mktemp -d "$DEST/.download.XXXXXX")"
trap 'rm -rf "$TMP"' EXIT

if [[ -n "$wheels" ]]; then
    src="$wheels"
elif [[ $gpu -eq 1 ]]; then
    src="$TMP/wheels"
    fetch "$src" "${GPU_WHEELS[@]}"
else
    src="$TMP/wheels"
    fetch "$src" "onnxruntime==$ORT_VERSION"
fi

shopt -s nullglob
found=("$src"/"$WHEEL_NAME"-"$ORT_VERSION"-*.whl)
WHEEL="${found[0]:-}"
if [[ -z "$WHEEL" ]]; then
    echo "install_ort: no $WHEEL_NAME $ORT_VERSION wheel for this platform in $src" >&2
    exit 1
fi
unpack "$WHEEL" "$TMP/x" onnxruntime/capi/
if [[ ! -f "$TMP/x/onnxruntime/capi/$(basename "$LIB")" ]]; then
    echo "install_ort: $(basename "$LIB") not found in $(basename "$WHEEL")" >&2
    exit 1
fi

if [[ $gpu -eq 1 ]]; then
    # NVIDIA's wheels hold their libraries under nvidia/<part>/lib/; all go into one folder
    # that panoconv loads before the CUDA provider.
    mkdir -p "$TMP/cuda"
    for spec in "${GPU_WHEELS[@]:1}"; do
        name="${spec%%==*}"
        found=("$src"/"${name//-/_}"-"${spec##*==}"-*.whl)
        w="${found[0]:-}"
        if [[ -z "$w" ]]; then
            echo "install_ort: no wheel of $spec in $src" >&2
            exit 1
        fi
        unpack "$w" "$TMP/n" nvidia/
    done
    for f in "$TMP"/n/nvidia/*/lib/*.so*; do
        mv -f "$f" "$TMP/cuda/"
    done
    rm -rf "$DEST/cuda"
    mv "$TMP/cuda" "$DEST/cuda"
fi
# The library last: its presence is what says the installation is complete.
for f in "$TMP"/x/onnxruntime/capi/libonnxruntime*.so*; do
    cp -f "$f" "$DEST/"
done
[[ $gpu -eq 1 ]] && du -sh "$DEST" >&2
# Convenience name for tools that look for the unversioned file.
ln -sf "$(basename "$LIB")" "$DEST/libonnxruntime.so"
echo "$LIB"
