#!/usr/bin/env bash
# Makes the stitch pictures of README.md and docs/nuscenes.md from a REAL frame: frame 00 of the
# PandaSet sequence in ../shared/pandaset/002 (PandaSet, Hesai and Scale AI, CC BY 4.0),
# rebuilt as nuScenes tables by tests/pandaset_nuscenes.py (the test venv's pandas), converted
# by `panoconv nuscenes` in both stitch modes and drawn with its boxes by `panoconv preview`.
#
# Usage: scripts/make_real_images.sh [PANOCONV_BINARY [OUT_DIR]]
#   default binary: target/release/panoconv, else target/debug/panoconv; default OUT_DIR:
#   docs/images. Environment: PANOCONV_SHARED (default ../shared).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$(pwd)"
bin="${1:-}"
if [[ -z "$bin" ]]; then
    bin="$repo/target/release/panoconv"
    [[ -x "$bin" ]] || bin="$repo/target/debug/panoconv"
fi
out="${2:-docs/images}"
mkdir -p "$out"
out="$(realpath "$out")"
sequence="${PANOCONV_SHARED:-../shared}/pandaset/002"
[[ -d "$sequence" ]] || { echo "make_real_images: no PandaSet frames at $sequence" >&2; exit 1; }
python="$(scripts/install_test_python.sh)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$python" tests/pandaset_nuscenes.py "$sequence" "$work/root" 00
# the car's own returns in PandaSet's LiDAR frame (tests/pandaset.rs)
box=-1.0,-1.3,1.0,1.0,2.2,2.0
for mode in fixed depth; do
    # the whole panorama's camera band, then a seam with parked cars 1-3 m from the cameras
    "$bin" nuscenes --to equirect --pano-width 2048 --crop 0,380,2048,400 --resize 1024x200 \
        --stitch-mode "$mode" --vehicle-box "$box" --input "$work/root" --version v1.0-mini \
        --output "$work/pano_$mode" --quiet
    "$bin" preview "$work/pano_$mode" --frame 000000 --no-depth \
        --output "$out/pandaset_pano_$mode.png" >/dev/null
    "$bin" nuscenes --to equirect --pano-width 2048 --crop 1150,430,560,280 \
        --stitch-mode "$mode" --vehicle-box "$box" --input "$work/root" --version v1.0-mini \
        --output "$work/seam_$mode" --quiet
    "$bin" preview "$work/seam_$mode" --frame 000000 --no-depth \
        --output "$out/pandaset_seam_$mode.png" >/dev/null
done
echo "make_real_images: pictures in $out" >&2
