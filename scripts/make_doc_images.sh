#!/usr/bin/env bash
# Makes the pictures in docs/images from the shipped synthetic sample, each a `panoconv preview`
# of a conversion (boxes drawn from the written calib alone), and the two occlusion figures of
# docs/depth.md with the `occlusion_figure` example. A test (tests/first_run.rs) runs this
# script and checks that the committed previews are its output, byte for byte; scripts/test.sh
# checks the occlusion figures.
#
# Usage: scripts/make_doc_images.sh [--previews-only] [PANOCONV_BINARY [OUT_DIR]]
#   default binary: target/release/panoconv, else target/debug/panoconv; default OUT_DIR:
#   docs/images. --previews-only leaves out the occlusion figures (they need a cargo build of
#   the example).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$(pwd)"
previews_only=0
if [[ "${1:-}" == --previews-only ]]; then
    previews_only=1
    shift
fi
bin="${1:-}"
if [[ -z "$bin" ]]; then
    bin="$repo/target/release/panoconv"
    [[ -x "$bin" ]] || bin="$repo/target/debug/panoconv"
fi
out="${2:-docs/images}"
mkdir -p "$out"
out="$(realpath "$out")"
k=fixtures/synthetic_kitti
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
p() { "$bin" "$@" --quiet; }
pv() { "$bin" preview "$@" >/dev/null 2>&1; }

# docs/geometry.md
p kitti --to perspective --px-per-deg 9 --input $k --output "$work/p"
p kitti --to equirect --input $k --output "$work/e"
p kitti --to cylindrical --input $k --output "$work/c"
p kitti --to equirect --full-360 --pano-width 1024 --input $k --output "$work/e360"
pv "$work/p" --frame 000000 --output "$out/geometry_perspective.png"
pv "$work/e" --frame 000000 --output "$out/geometry_equirect.png"
pv "$work/c" --frame 000000 --output "$out/geometry_cylindrical.png"
pv "$work/e360" --frame 000000 --output "$out/geometry_equirect_360.png"
# README: the source frame (plain KITTI, drawn with P2) and its two panoramic conversions
pv $k --frame 000000 --output "$out/source_perspective.png"
pv "$work/e" --frame 000000 --output "$out/equirect.png"
pv "$work/c" --frame 000000 --output "$out/cylindrical.png"
# docs/formats.md
pv "$work/e" --grid 3x1 --tile-width 300 --output "$out/formats_sheet.png"
# docs/fisheye.md: the camera description fixtures/cameras/front.json
p kitti --to fisheye --camera fixtures/cameras/front.json --mask --depth --input $k --output "$work/f"
pv "$work/f" --frame 000000 --no-depth --output "$out/fisheye_target.png"
# docs/kitti360.md: the synthetic KITTI-360 sequence's four cameras stitched, boxes and depth
p kitti360 --to equirect --pano-width 1024 --depth --lidar-azimuth-step 0.8 --frames 250 \
    --input fixtures/kitti360 --sequence 2013_05_28_drive_0000_sync --output "$work/k360"
pv "$work/k360" --frame 000250 --output "$out/kitti360_equirect.png"
# docs/kitti360.md: a seam with a near car, stitched at the fixed 10 m and by depth
for mode in fixed depth; do
    p kitti360 --to equirect --pano-width 1024 --crop 250,220,256,128 --stitch-mode "$mode" \
        --frames 250 --input fixtures/kitti360 --sequence 2013_05_28_drive_0000_sync \
        --output "$work/k360_$mode"
    pv "$work/k360_$mode" --frame 000250 --output "$out/kitti360_seam_$mode.png"
done
# docs/nuscenes.md: the synthetic nuScenes scene's six cameras stitched, boxes and depth
p nuscenes --to equirect --pano-width 1024 --depth --lidar-azimuth-step 0.8 \
    --input fixtures/nuscenes --version v1.0-mini --output "$work/nus"
pv "$work/nus" --frame 000000 --output "$out/nuscenes_equirect.png"
# docs/depth.md
if [[ $previews_only -eq 0 ]]; then
    # the test profile: the build scripts/test.sh already made, and the one it checks the figures with
    cargo run --locked --quiet --profile test --example occlusion_figure -- "$out"
fi
echo "make_doc_images: pictures in $out" >&2
