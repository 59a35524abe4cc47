#!/usr/bin/env bash
# KITTI-360 stitch throughput: `panoconv kitti360 --to equirect` against benches/opencv_stitch.py
# (the same stitch model in numpy + cv2.remap) on the same frames of a synthetic sequence.
#   benches/stitch.sh [--data DIR] [--rounds R] [--jobs J] [--width W] [--scale S] [--frames N]
#                     [--bin BIN]
# --data: where the synthetic sequence lives (written by `panoconv synth --kitti360 --scale S
# --frames N` on first use, minutes at scale 1; default /tmp/panoconv-stitch-bench). Each round
# runs panoconv (--jobs J) then Python (J worker processes) over every frame of the sequence;
# the figures are frames/s over all rounds, with the 1-minute load average before each run.
# panoconv runs twice a round: at the fixed proxy distance (`--stitch-mode fixed`, the model the
# Python implements) and depth-guided (the default: each pixel at its distance from the scan and
# boxes). Checks that every Python panorama agrees with panoconv's fixed one (PSNR >= 40 dB),
# else exit 1.
# Sets up benches/.venv (opencv-python-headless, numpy) on first use, as benches/run.sh does.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
venv="$here/.venv"
data=/tmp/panoconv-stitch-bench
rounds=3
jobs=2
width=2048
scale=1
frames=3
bin=""
while [ $# -gt 0 ]; do
    case "$1" in
        --data) data="$2"; shift 2 ;;
        --rounds) rounds="$2"; shift 2 ;;
        --jobs) jobs="$2"; shift 2 ;;
        --width) width="$2"; shift 2 ;;
        --scale) scale="$2"; shift 2 ;;
        --frames) frames="$2"; shift 2 ;;
        --bin) bin="$2"; shift 2 ;;
        *) echo "unknown argument: $1" >&2; exit 2 ;;
    esac
done
if ! "$venv/bin/python" -c 'import cv2, numpy' 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet opencv-python-headless numpy
fi
if [ -z "$bin" ]; then
    (cd "$root" && cargo build --release --quiet --bin panoconv)
    bin="${CARGO_TARGET_DIR:-$root/target}/release/panoconv"
fi
seq=2013_05_28_drive_0000_sync
if [ ! -f "$data/data_poses/$seq/poses.txt" ]; then
    echo "writing the synthetic sequence (scale $scale, $frames frames) into $data"
    "$bin" synth --kitti360 --scale "$scale" --frames "$frames" --output "$data" >/dev/null
fi
n=$(wc -l <"$data/data_poses/$seq/poses.txt")
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
load() { cut -d' ' -f1 /proc/loadavg; }
now() { date +%s.%N; }
rust_s=0
depth_s=0
py_s=0
echo "frames $n a round, $rounds rounds, ${width}x$((width / 2)), 4 cameras, --jobs $jobs"
for r in $(seq 1 "$rounds"); do
    l=$(load); t0=$(now)
    "$bin" kitti360 --to equirect --pano-width "$width" --input "$data" --sequence "$seq" \
        --output "$work/rust" --overwrite --quiet --jobs "$jobs" --stitch-mode fixed
    t1=$(now)
    dt=$(echo "$t1 - $t0" | bc -l)
    rust_s=$(echo "$rust_s + $dt" | bc -l)
    printf 'round %d panoconv %6.2f s  %5.2f frames/s  load %s (fixed)\n' "$r" "$dt" "$(echo "$n / $dt" | bc -l)" "$l"
    l=$(load); t0=$(now)
    "$bin" kitti360 --to equirect --pano-width "$width" --input "$data" --sequence "$seq" \
        --output "$work/depth" --overwrite --quiet --jobs "$jobs"
    t1=$(now)
    dt=$(echo "$t1 - $t0" | bc -l)
    depth_s=$(echo "$depth_s + $dt" | bc -l)
    printf 'round %d panoconv %6.2f s  %5.2f frames/s  load %s (depth-guided)\n' "$r" "$dt" "$(echo "$n / $dt" | bc -l)" "$l"
    l=$(load); t0=$(now)
    "$venv/bin/python" "$here/opencv_stitch.py" --input "$data" --sequence "$seq" \
        --output "$work/python" --width "$width" --jobs "$jobs" 2>/dev/null
    t1=$(now)
    dt=$(echo "$t1 - $t0" | bc -l)
    py_s=$(echo "$py_s + $dt" | bc -l)
    printf 'round %d python   %6.2f s  %5.2f frames/s  load %s\n' "$r" "$dt" "$(echo "$n / $dt" | bc -l)" "$l"
done
total=$((n * rounds))
rf=$(echo "$total / $rust_s" | bc -l)
df=$(echo "$total / $depth_s" | bc -l)
pf=$(echo "$total / $py_s" | bc -l)
printf 'panoconv %.3f frames/s, python+opencv %.3f frames/s, ratio %.2f (load now %s)\n' \
    "$rf" "$pf" "$(echo "$rf / $pf" | bc -l)" "$(load)"
printf 'panoconv depth-guided %.3f frames/s: %.2fx the fixed distance time, %.2f times python+opencv\n' \
    "$df" "$(echo "$rf / $df" | bc -l)" "$(echo "$df / $pf" | bc -l)"
worst=999
for f in "$work"/python/image_2/*.png; do
    name=$(basename "$f")
    p=$("$venv/bin/python" "$here/opencv_stitch.py" --compare "$f" "$work/rust/training/image_2/$name")
    echo "PSNR $name: $p dB"
    worst=$(echo "if ($p < $worst) $p else $worst" | bc -l)
done
if [ "$(echo "$worst < 40" | bc -l)" = 1 ]; then
    echo "the panoramas disagree (PSNR $worst dB < 40): not the same work" >&2
    exit 1
fi
