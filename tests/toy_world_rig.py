"""The toy world-frame rig of tests/rig_stream.rs read by a Python adapter and converted with
`panoconv.convert_rig`: python tests/toy_world_rig.py ROOT OUTPUT ARGS... (exits with the
command's code)."""

import json
import os
import sys

import numpy as np

import panoconv


class ToyWorld(panoconv.RigSource):
    name = "toyworld"

    def __init__(self, root):
        self.root = root
        with open(os.path.join(root, "rig.json")) as f:
            self.rig = json.load(f)

    def frames(self):
        with open(os.path.join(self.root, "frames.txt")) as f:
            return f.read().split()

    def read(self, frame_id):
        d = os.path.join(self.root, frame_id)
        poses = np.loadtxt(os.path.join(d, "poses.txt")).reshape(-1, 4, 4)
        cameras = [
            panoconv.RigCamera(
                c["name"],
                os.path.join(d, c["name"] + ".png"),
                panoconv.Camera.perspective(
                    c["width"], c["height"], c["fx"], c["fy"], c["cx"], c["cy"]
                ),
                poses[k],
            )
            for k, c in enumerate(self.rig["cameras"])
        ]
        boxes = []
        with open(os.path.join(d, "boxes.txt")) as f:
            for line in f:
                t = line.split()
                v = [float(x) for x in t[2:9]]
                boxes.append(
                    panoconv.Box3D(t[0], v[0:3], v[3:6], yaw=v[6], label=t[1], points=int(t[9]))
                )
        lidar = np.fromfile(os.path.join(d, "lidar.bin"), "<f8").reshape(-1, 4)
        inputs = [os.path.join(d, f) for f in ("boxes.txt", "poses.txt", "lidar.bin")]
        return panoconv.RigFrame(
            cameras, boxes, lidar=lidar, record={"toy_frame": frame_id}, inputs=inputs
        )


if __name__ == "__main__":
    sys.exit(panoconv.convert_rig(ToyWorld(sys.argv[1]), sys.argv[2], sys.argv[3:]))
