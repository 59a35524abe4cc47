#!/usr/bin/env bash
# Runs two panoconv binaries on the same inputs and options and compares the whole output trees
# byte for byte (diff -r): the check that a refactoring or a new feature left every existing
# output as it was. Inputs: the real frames in $PANOCONV_KITTI (default ../shared/kitti), the
# synthetic sample and the panoramas in ../shared/pano.
#
# Usage: scripts/compare_outputs.sh OLD_BINARY NEW_BINARY
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
old="$(realpath "$1")" new="$(realpath "$2")"
kitti="${PANOCONV_KITTI:-../shared/kitti}"
kitti="$(realpath "$kitti")" synth="$(realpath fixtures/synthetic_kitti)" pano="$(realpath ../shared/pano)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
differ=0
# compare NAME ARGS...: ARGS with --output appended, once per binary.
compare() {
    local name="$1"
    shift
    "$old" "$@" --output "$work/old-$name" --quiet 2>"$work/old-$name.err"
    local a=$?
    "$new" "$@" --output "$work/new-$name" --quiet 2>"$work/new-$name.err"
    local b=$?
    if [[ $a != "$b" ]]; then
        echo "DIFFERENT EXIT ($a vs $b): $*"
        differ=$((differ + 1))
    elif diff -r "$work/old-$name" "$work/new-$name" >"$work/$name.diff" 2>&1; then
        echo "identical ($(find "$work/new-$name" -type f | wc -l) files): $*"
    else
        echo "DIFFERENT: $*"
        head -n 5 "$work/$name.diff"
        differ=$((differ + 1))
    fi
}
for to in equirect cylindrical perspective; do
    compare "k-$to" kitti --to "$to" --depth --input "$kitti"
done
compare stereo kitti --to equirect --cameras 2,3 --pano-width 2048 --input "$synth"
compare augment kitti --to cylindrical --augment 3 --seed 5 --scale-range 0.8,1.3 --crop-size 300x120 --input "$synth"
compare crop kitti --to perspective --crop 10,20,600,200 --resize 300x100 --input "$synth"
compare full kitti --to equirect --full-360 --png-compression best --input "$synth"
compare pano pano --to perspective --yaw 0,90 --input "$pano"
# KITTI-360's stitched rig: its fisheyes, world boxes and LiDAR, in augmented views
compare k360 kitti360 --to cylindrical --pano-width 1024 --cameras 2,3 --depth --augment 2 --crop-size 300x150 --seed 3 --input fixtures/kitti360 --sequence 2013_05_28_drive_0000_sync
# Every command of the README's Use block (kitti, kitti-raw, fisheye target, labels-to-pixels,
# unproject, eval-depth, resume, shards and merge, export, camera convert, fisheye and pano
# folders, preview, inspect, completions, man, synth, verify), each binary in turn in the same
# folder (manifests record absolute paths): the whole trees and every step's standard output.
examples() {
    PANOCONV_EXAMPLES_DIR="$work/examples" scripts/readme_examples.sh "$1" >"$work/examples-$2.log" 2>&1
    local code=$?
    mv "$work/examples" "$work/examples-$2"
    return $code
}
examples "$old" old
a=$?
examples "$new" new
b=$?
if [[ $a != "$b" ]]; then
    echo "DIFFERENT EXIT ($a vs $b): scripts/readme_examples.sh"
    differ=$((differ + 1))
elif diff -r -x step.err "$work/examples-old" "$work/examples-new" >"$work/examples.diff" 2>&1; then
    echo "identical ($(find "$work/examples-new" -type f | wc -l) files, $(grep -c '^\$ ' "$work/examples-new/stdout.log") commands' standard output): scripts/readme_examples.sh"
else
    echo "DIFFERENT: scripts/readme_examples.sh ($(find "$work/examples-new" -type f | wc -l) files):"
    diff -rq -x step.err "$work/examples-old" "$work/examples-new" | sed "s#$work/##g"
    grep '^[<>]' "$work/examples.diff" | head -n 20
    differ=$((differ + 1))
fi
echo "$differ differences"
[[ $differ -eq 0 ]]
