#!/usr/bin/env bash
# Stitch throughput: `panoconv kitti360 --to equirect` against benches/opencv_stitch.py (the
# same stitch model in numpy + cv2.remap) on the same frames of a synthetic sequence; with
# --nuscenes, `panoconv nuscenes --to equirect` against benches/opencv_stitch_nuscenes.py on a
# synthetic nuScenes scene (six 1600x900 cameras at scale 1).
#   benches/stitch.sh [--nuscenes [--naive] [--still] [--pandaset SEQ]] [--data DIR] [--rounds R]
#                     [--jobs J] [--width W] [--scale S] [--frames N] [--bin BIN] [--python PY]
# --data: where the synthetic sequence lives (written by `panoconv synth --kitti360|--nuscenes
# --scale S --frames N` on first use, minutes at scale 1; default /tmp/panoconv-stitch-bench or
# /tmp/panoconv-stitch-bench-nuscenes). Each round runs panoconv (--jobs J) then Python (J
# worker processes) over every frame (nuScenes: sample) of the sequence; the figures are
# frames/s over all rounds, with the 1-minute load average before each run.
# panoconv runs twice a round: at the fixed proxy distance (`--stitch-mode fixed`, the model the
# Python implements) and depth-guided (the default: each pixel at its distance from the scan and
# boxes). Checks that every Python panorama agrees with panoconv's fixed one (PSNR >= 40 dB),
# else exit 1. Also prints each run's CPU time (GNU time's user + sys, /usr/bin/time), which a
# shared machine's load disturbs less than the wall time.
# --naive (with --nuscenes): the Python is benches/naive_stitch.py instead, the stitch a user
# writes in numpy + cv2.remap (bilinear maps at pixel centres, a feathered blend, no prefilter,
# no gains): its panoramas differ from panoconv's by design, so no PSNR check.
# --pandaset SEQ: the data is PandaSet sequence folder SEQ (../shared/pandaset/002) rebuilt as a
# nuScenes root by tests/pandaset_nuscenes.py (with --python's interpreter: numpy, pandas) into
# --data (default /tmp/panoconv-stitch-bench-pandaset); panoconv drops the car's own returns with
# PandaSet's vehicle box (tests/pandaset.rs), as the real-frame tests do.
# --still: every sample takes the first sample's ego poses (benches/still_rig.py, into
# DATA-still): a rig whose geometry repeats, so panoconv's fixed stitch is built once a run.
# --python PY: the interpreter of the Python side (default benches/.venv's).
# Sets up benches/.venv (opencv-python-headless, numpy) on first use, as benches/run.sh does.
#
# The figures of docs/performance.md ("Rig stitch against the naive numpy stitch"):
#   benches/stitch.sh --nuscenes --naive --jobs 1 --rounds 2 --data DIR
#   benches/stitch.sh --nuscenes --naive --jobs 1 --rounds 2 --pandaset ../shared/pandaset/002
#   (each also with --still)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
venv="$here/.venv"
data=""
nuscenes=0
rounds=3
jobs=2
width=2048
scale=1
frames=3
bin=""
naive=0
still=0
pandaset=""
python=""
while [ $# -gt 0 ]; do
    case "$1" in
        --nuscenes) nuscenes=1; shift ;;
        --data) data="$2"; shift 2 ;;
        --rounds) rounds="$2"; shift 2 ;;
        --jobs) jobs="$2"; shift 2 ;;
        --width) width="$2"; shift 2 ;;
        --scale) scale="$2"; shift 2 ;;
        --frames) frames="$2"; shift 2 ;;
        --bin) bin="$2"; shift 2 ;;
        --naive) naive=1; shift ;;
        --still) still=1; shift ;;
        --pandaset) pandaset="$2"; nuscenes=1; shift 2 ;;
        --python) python="$2"; shift 2 ;;
        *) echo "unknown argument: $1" >&2; exit 2 ;;
    esac
done
if [ -z "$python" ]; then
    if ! "$venv/bin/python" -c 'import cv2, numpy' 2>/dev/null; then
        python3 -m venv "$venv"
        "$venv/bin/pip" install --quiet opencv-python-headless==5.0.0.93 numpy==2.4.6
    fi
    python="$venv/bin/python"
fi
# one thread a Python process: numpy's BLAS would otherwise spin on every core
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
if [ -z "$bin" ]; then
    (cd "$root" && cargo build --release --quiet --bin panoconv)
    bin="${CARGO_TARGET_DIR:-$root/target}/release/panoconv"
fi
# the dataset's command and its Python stitch, both reading "$data"
if [ -n "$pandaset" ]; then
    data="${data:-/tmp/panoconv-stitch-bench-pandaset}"
    if [ ! -f "$data/v1.0-mini/sample.json" ]; then
        echo "rebuilding PandaSet $pandaset as a nuScenes root in $data"
        "$python" "$root/tests/pandaset_nuscenes.py" "$pandaset" "$data" >/dev/null
    fi
fi
if [ "$nuscenes" = 1 ]; then
    data="${data:-/tmp/panoconv-stitch-bench-nuscenes}"
    version=v1.0-mini
    if [ ! -f "$data/$version/sample.json" ]; then
        echo "writing the synthetic scene (scale $scale, $frames samples) into $data"
        "$bin" synth --nuscenes --scale "$scale" --frames "$frames" --output "$data" >/dev/null
    fi
    if [ "$still" = 1 ]; then
        "$python" "$here/still_rig.py" "$data" "$version" "$data-still"
        data="$data-still"
    fi
    n=$("$python" -c 'import json, sys; print(len(json.load(open(sys.argv[1]))))' \
        "$data/$version/sample.json")
    cameras=$("$python" -c 'import json, sys
print(sum(s["modality"] == "camera" for s in json.load(open(sys.argv[1]))))' \
        "$data/$version/sensor.json")
    convert=(nuscenes --input "$data" --version "$version")
    # the roof and the sensor's mount in PandaSet's LiDAR frame (tests/pandaset.rs)
    [ -n "$pandaset" ] && convert+=(--vehicle-box=-1.0,-1.3,1.0,1.0,2.2,2.0)
    script="$here/opencv_stitch_nuscenes.py"
    [ "$naive" = 1 ] && script="$here/naive_stitch.py"
    python_args=("$script" --input "$data" --version "$version")
else
    data="${data:-/tmp/panoconv-stitch-bench}"
    seq=2013_05_28_drive_0000_sync
    if [ ! -f "$data/data_poses/$seq/poses.txt" ]; then
        echo "writing the synthetic sequence (scale $scale, $frames frames) into $data"
        "$bin" synth --kitti360 --scale "$scale" --frames "$frames" --output "$data" >/dev/null
    fi
    n=$(wc -l <"$data/data_poses/$seq/poses.txt")
    cameras=4
    convert=(kitti360 --input "$data" --sequence "$seq")
    python_args=("$here/opencv_stitch.py" --input "$data" --sequence "$seq")
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
load() { cut -d' ' -f1 /proc/loadavg; }
now() { date +%s.%N; }
rust_s=0 rust_cpu=0
depth_s=0 depth_cpu=0
py_s=0 py_cpu=0
# timed ROUND NAME NOTE TOTAL COMMAND...: runs COMMAND, adds its wall seconds to $TOTAL and its
# CPU seconds (user + sys, its child processes included) to ${TOTAL%_s}_cpu, and prints both
# with its rate and the load average before it
timed() {
    local round="$1" name="$2" note="$3" total="$4" l t0 dt cpu
    shift 4
    l=$(load); t0=$(now)
    /usr/bin/time -f '%U + %S' -o "$work/cpu" "$@"
    dt=$(echo "$(now) - $t0" | bc -l)
    cpu=$(echo "$(tail -n 1 "$work/cpu")" | bc -l)
    printf -v "$total" '%s' "$(echo "${!total} + $dt" | bc -l)"
    local cpu_total="${total%_s}_cpu"
    printf -v "$cpu_total" '%s' "$(echo "${!cpu_total} + $cpu" | bc -l)"
    printf 'round %d %-8s %6.2f s  %5.2f frames/s  CPU %6.2f s  load %s%s\n' "$round" "$name" \
        "$dt" "$(echo "$n / $dt" | bc -l)" "$cpu" "$l" "$note"
}
echo "frames $n a round, $rounds rounds, ${width}x$((width / 2)), $cameras cameras, --jobs $jobs"
for r in $(seq 1 "$rounds"); do
    timed "$r" panoconv " (fixed)" rust_s "$bin" "${convert[@]}" --to equirect \
        --pano-width "$width" --output "$work/rust" --overwrite --quiet --jobs "$jobs" \
        --stitch-mode fixed
    timed "$r" panoconv " (depth-guided)" depth_s "$bin" "${convert[@]}" --to equirect \
        --pano-width "$width" --output "$work/depth" --overwrite --quiet --jobs "$jobs"
    timed "$r" python "" py_s "$python" "${python_args[@]}" --output "$work/python" \
        --width "$width" --jobs "$jobs" 2>/dev/null
done
total=$((n * rounds))
rf=$(echo "$total / $rust_s" | bc -l)
df=$(echo "$total / $depth_s" | bc -l)
pf=$(echo "$total / $py_s" | bc -l)
printf 'panoconv %.3f frames/s, python+opencv %.3f frames/s, ratio %.2f (load now %s)\n' \
    "$rf" "$pf" "$(echo "$rf / $pf" | bc -l)" "$(load)"
printf 'panoconv depth-guided %.3f frames/s: %.2fx the fixed distance time, %.2f times python+opencv\n' \
    "$df" "$(echo "$rf / $df" | bc -l)" "$(echo "$df / $pf" | bc -l)"
printf 'CPU s a frame: panoconv %.2f, depth-guided %.2f, python+opencv %.2f (python / panoconv %.2f)\n' \
    "$(echo "$rust_cpu / $total" | bc -l)" "$(echo "$depth_cpu / $total" | bc -l)" \
    "$(echo "$py_cpu / $total" | bc -l)" "$(echo "$py_cpu / $rust_cpu" | bc -l)"
if [ "$naive" = 1 ]; then
    exit 0  # the naive stitch differs from panoconv's by design (no prefilter, no gains)
fi
worst=999
for f in "$work"/python/image_2/*.png; do
    name=$(basename "$f")
    p=$("$python" "$here/opencv_stitch.py" --compare "$f" "$work/rust/training/image_2/$name")
    echo "PSNR $name: $p dB"
    worst=$(echo "if ($p < $worst) $p else $worst" | bc -l)
done
if [ "$(echo "$worst < 40" | bc -l)" = 1 ]; then
    echo "the panoramas disagree (PSNR $worst dB < 40): not the same work" >&2
    exit 1
fi
