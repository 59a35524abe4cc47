#!/usr/bin/env bash
# Time to the first frame and peak memory on v1.0-trainval-sized nuScenes tables generated
# around the shipped synthetic scene (benches/nuscenes_tables.py, about 2.8 GB of JSON).
# Usage: benches/nuscenes_first_frame.sh [WORKDIR]   (default /tmp/nuscenes-trainval)
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORK="${1:-/tmp/nuscenes-trainval}"
[[ -f "$WORK/v1.0-trainval/sample_data.json" ]] ||
    python3 "$REPO/benches/nuscenes_tables.py" "$REPO/fixtures/nuscenes" "$WORK"
cargo build --locked --release --example nuscenes_first_frame
"$REPO/target/release/examples/nuscenes_first_frame" "$WORK" v1.0-trainval scene-0001
"$REPO/target/release/examples/nuscenes_first_frame" "$WORK" v1.0-trainval
