#!/usr/bin/env bash
# The main job on the data the repository ships: the synthetic KITTI sample converted to
# equirect, checked against its manifest, then a preview of frame 000000 with its boxes drawn
# from the written calib. Usage: scripts/demo.sh [OUT] (default target/demo).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out="${1:-target/demo}"
# Only a folder this script made before (or an empty one) is replaced.
if [[ -e "$out" ]]; then
    if [[ -f "$out/equirect/panoconv.json" || -z "$(ls -A "$out" 2>/dev/null)" ]]; then
        rm -rf -- "$out"
    else
        echo "demo: $out exists and is not an earlier demo output (no $out/equirect/panoconv.json): give another folder" >&2
        exit 2
    fi
fi
echo "demo: building panoconv (release; the first build takes a few minutes)" >&2
cargo build --release --locked
./target/release/panoconv kitti --to equirect --input fixtures/synthetic_kitti --output "$out/equirect"
./target/release/panoconv verify "$out/equirect"
./target/release/panoconv preview "$out/equirect" --frame 000000 --output "$out/preview_000000.png"
echo "wrote $out/equirect and $out/preview_000000.png"
