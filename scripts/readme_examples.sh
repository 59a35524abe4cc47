#!/usr/bin/env bash
# Runs the README's "Use" examples top to bottom on a copy of the real KITTI frames in
# $PANOCONV_KITTI, default ../shared/kitti (and the panoramas in ../shared/pano), printing each command with its exit
# code, then `panoconv verify` on every output folder the examples create. A transcript for
# people; the test suite checks the same behaviours one by one.
#
# Usage: scripts/readme_examples.sh [PANOCONV_BINARY]   (default: target/release/panoconv,
# else target/debug/panoconv). With PANOCONV_EXAMPLES_DIR=DIR (a new folder), everything is
# made there and kept, every step's standard output appended to DIR/stdout.log
# (scripts/compare_outputs.sh compares two binaries' folders).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$(pwd)"
bin="${1:-}"
[[ -z "$bin" || "$bin" = /* ]] || bin="$repo/$bin"
if [[ -z "$bin" ]]; then
    bin="$repo/target/release/panoconv"
    [[ -x "$bin" ]] || bin="$repo/target/debug/panoconv"
fi
[[ -x "$bin" ]] || { echo "no panoconv binary: cargo build first" >&2; exit 2; }
shared="$repo/../shared"
kitti="${PANOCONV_KITTI:-../shared/kitti}"
kitti="$(realpath "$kitti")"
if [[ -n "${PANOCONV_EXAMPLES_DIR:-}" ]]; then
    work="$PANOCONV_EXAMPLES_DIR"
    mkdir "$work" || exit 2
else
    work="$(mktemp -d)"
    trap 'rm -rf "$work"' EXIT
fi
cd "$work"
cp -r "$kitti" K
mkdir -p panos frames home
cp "$shared"/pano/*.jpg "$shared"/pano/*.png panos/

panoconv() { "$bin" "$@"; }
failures=0
# step EXPECTED COMMAND...: runs the command (through a shell, for redirections) and prints
# its exit code; a code other than EXPECTED (a regex: 137|0) counts as a failure.
step() {
    local want="$1"
    shift
    echo "\$ $*"
    bash -c "$*" >step.out 2>step.err
    local code=$?
    local cmd="$*"
    { echo "\$ ${cmd//"$bin"/panoconv}"; cat step.out; } >>stdout.log
    sed 's/^/    /' step.err | tail -n 4
    echo "    -> exit $code"
    if [[ ! "$code" =~ ^($want)$ ]]; then
        echo "    !! expected exit $want"
        failures=$((failures + 1))
    fi
}
export -f panoconv
export bin

# A KITTI raw date folder made of the sample's frames that share frame 000001's camera.
mkdir -p R_in/2011_09_26/2011_09_26_drive_0001_sync/{image_02,velodyne_points}/data
n=0
for id in 000001 000002 000003 000004 000005; do
    if cmp -s <(grep '^P2' K/training/calib/$id.txt) <(grep '^P2' K/training/calib/000001.txt); then
        cp K/training/image_2/$id.png "R_in/2011_09_26/2011_09_26_drive_0001_sync/image_02/data/$(printf %010d $n).png"
        cp K/training/velodyne/$id.bin "R_in/2011_09_26/2011_09_26_drive_0001_sync/velodyne_points/data/$(printf %010d $n).bin"
        n=$((n + 1))
    fi
done
python3 - K/training/calib/000001.txt R_in/2011_09_26 <<'EOF'
import sys
lines = dict(l.split(":", 1) for l in open(sys.argv[1]) if ":" in l)
v = lambda k: lines[k].split()
with open(sys.argv[2] + "/calib_cam_to_cam.txt", "w") as f:
    f.write("calib_time: 09-Jan-2012 13:57:47\n")
    f.write("R_rect_00: " + " ".join(v("R0_rect")) + "\n")
    for n in range(4):
        f.write(f"P_rect_0{n}: " + " ".join(v(f"P{n}")) + "\n")
t = v("Tr_velo_to_cam")
with open(sys.argv[2] + "/calib_velo_to_cam.txt", "w") as f:
    f.write("calib_time: 15-Mar-2012 11:37:16\n")
    f.write("R: " + " ".join(t[0:3] + t[4:7] + t[8:11]) + "\n")
    f.write("T: " + " ".join([t[3], t[7], t[11]]) + "\n")
EOF
# A fisheye camera description of the size of a sample image (the pixels are a panorama's:
# the command does not care what the lens saw).
cp panos/synthetic_axes_1024x512.png frames/frame_000.png
cat >front.json <<'EOF'
{"version": 1, "model": "equidistant", "width": 1024, "height": 512,
 "fx": 160.0, "cx": 511.5, "cy": 255.5, "max_fov_deg": 190}
EOF

echo "# panoconv README examples on $(ls K/training/image_2 | wc -l) training and $(ls K/testing/image_2 | wc -l) testing frames"
step 0 panoconv kitti --to equirect    --input K --output kitti_equi
step 0 panoconv kitti --to cylindrical --input K --output kitti_cyl --jobs 8
step 0 panoconv kitti --to equirect --pano-width 2048 --input K --output O_2048
step 0 panoconv kitti --to perspective --frames 000001,000004 --input K --output O_persp
step 0 panoconv kitti --to cylindrical --resize 620x200 --input K --output O
step 0 panoconv labels-to-pixels --input O --output O/training/pixels
step 0 panoconv unproject --calib O/training/calib --input O/training/pixels --output preds_kitti/
step 2 panoconv kitti --to cylindrical --depth --cameras 2,3 --input K --output O_stereo
step 0 panoconv kitti --to cylindrical --depth --input K --output O_depth
step 0 panoconv kitti-raw --to equirect --depth --input R_in/2011_09_26 --output R
mkdir -p preds && cp O_depth/training/depth_2/*.png preds/
step 0 panoconv eval-depth --pred preds/ --gt O_depth/training/depth_2
# killed mid-run (unless a fast build finished first), then resumed
step "137|0" timeout -s KILL 2 "$bin" kitti --to equirect --input K --output O_resume --jobs 1
step 0 panoconv kitti --to equirect --input K --output O_resume --resume
step 0 "for k in \$(seq 0 15); do panoconv kitti --to equirect --input K --output O_shards --shard \$k/16 --quiet || exit; done && panoconv merge O_shards"
step 0 panoconv export O --format coco --output O/annotations
step 0 panoconv export O --format yolo --output O_yolo
step 0 panoconv export O --format omni3d --output O/annotations
step 0 panoconv kitti --to equirect --input K --output O_export --export coco,yolo
step 0 panoconv kitti --to fisheye --camera front.json --mask --depth --input K --output O_fish
step 0 panoconv camera convert front.json --to kannala_brandt --output kb.json
step 0 panoconv fisheye --camera front.json --to cylindrical --input frames/ --output cyl/
step 0 panoconv pano --to perspective --yaw 0,90,180,270 --fov 90 --input panos/ --output views/
step 0 panoconv preview O --frame 000004 --output O/preview.png
step 0 panoconv preview O --grid 4x3 --output sheet.png
step 0 panoconv inspect K
step 0 "mkdir -p home/.local/share/bash-completion/completions && panoconv completions bash > home/.local/share/bash-completion/completions/panoconv"
step 0 panoconv man --output man1
step 0 panoconv synth --output synthetic_kitti

echo "# verify every output folder"
for out in kitti_equi kitti_cyl O_2048 O_persp O O_depth R O_resume O_shards O_export O_fish cyl views; do
    step 0 panoconv verify "$out"
    tail -n 1 step.out | sed 's/^/    /'
done
echo "# $failures unexpected exit codes"
[[ $failures -eq 0 ]]
