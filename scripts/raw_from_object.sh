#!/usr/bin/env bash
# Makes a KITTI raw date folder from a KITTI object root, for trying `panoconv kitti-raw` on the
# shipped sample: OUT/2011_09_26/{calib_cam_to_cam.txt, calib_velo_to_cam.txt} from the first
# training frame's calib, and one drive, 2011_09_26_drive_0001_sync, holding that frame and every
# other training frame with the same P2 (a raw drive has one calibration) as image_02/data and
# velodyne_points/data. Usage: scripts/raw_from_object.sh KITTI_ROOT OUT (OUT must not exist).
set -euo pipefail
[[ $# -eq 2 ]] || { echo "usage: $0 KITTI_ROOT OUT" >&2; exit 2; }
k="$1/training"
out="$2"
[[ ! -e "$out" ]] || { echo "$out exists" >&2; exit 2; }
first="$(ls "$k/calib" | head -n 1)"
first="${first%.txt}"
drive="$out/2011_09_26/2011_09_26_drive_0001_sync"
mkdir -p "$drive/image_02/data" "$drive/velodyne_points/data"
n=0
for calib in "$k"/calib/*.txt; do
    id="$(basename "$calib" .txt)"
    if cmp -s <(grep '^P2' "$calib") <(grep '^P2' "$k/calib/$first.txt") \
        && [[ -f "$k/image_2/$id.png" && -f "$k/velodyne/$id.bin" ]]; then
        name="$(printf %010d $n)"
        cp "$k/image_2/$id.png" "$drive/image_02/data/$name.png"
        cp "$k/velodyne/$id.bin" "$drive/velodyne_points/data/$name.bin"
        n=$((n + 1))
    fi
done
python3 - "$k/calib/$first.txt" "$out/2011_09_26" <<'EOF'
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
echo "raw_from_object: $n frames in $drive" >&2
