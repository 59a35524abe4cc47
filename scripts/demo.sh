#!/usr/bin/env bash
# The main job on the data the repository ships: the synthetic KITTI sample converted to
# equirect, then a preview of frame 000000 with its boxes drawn from the written calib.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out="${1:-target/demo}"
cargo build --release --locked --quiet
rm -rf "$out"
./target/release/panoconv kitti --to equirect --input data/synthetic_kitti --output "$out/equirect"
./target/release/panoconv preview "$out/equirect" --frame 000000 --output "$out/preview_000000.png"
echo "wrote $out/equirect and $out/preview_000000.png"
