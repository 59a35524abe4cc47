"""kitti360scripts (PyPI, the dataset's own devkit) as the independent reader of a KITTI-360
sequence: its calibration loaders, fisheye YAML reader, 3D box parser and camera projections.

Usage: kitti360_scripts.py ROOT SEQUENCE FRAME OUT.json

The devkit predates numpy 2 and PyYAML 6 and imports matplotlib and scikit-image for helpers
that these loaders never call; the shims below restore `np.int`, give `yaml.load` its former
default loader, and stand in for the two plotting/imaging packages (not installed).
"""
import json
import os
import sys
import types

import numpy as np
import yaml
import cv2

np.int = int
_yaml_load = yaml.load
yaml.load = lambda stream, Loader=yaml.SafeLoader: _yaml_load(stream, Loader=Loader)
for name in ["skimage", "skimage.io", "skimage.filters", "matplotlib", "matplotlib.cm"]:
    sys.modules[name] = types.ModuleType(name)
sys.modules["skimage"].io = sys.modules["skimage.io"]
sys.modules["skimage"].filters = sys.modules["skimage.filters"]
sys.modules["matplotlib"].cm = sys.modules["matplotlib.cm"]
sys.modules["matplotlib.cm"].get_cmap = lambda name: (lambda i: (0.0, 0.0, 0.0, 1.0))

from kitti360scripts.devkits.commons.loadCalibration import (  # noqa: E402
    loadCalibrationCameraToPose,
    loadCalibrationRigid,
    loadPerspectiveIntrinsic,
)
from kitti360scripts.helpers.annotation import Annotation3D  # noqa: E402
from kitti360scripts.helpers.project import (  # noqa: E402
    CameraFisheye,
    CameraPerspective,
    readYAMLFile,
)

root, seq, frame, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
calib = os.path.join(root, "calibration")
res = {
    "cam_to_pose": {
        k: v.tolist()
        for k, v in loadCalibrationCameraToPose(
            os.path.join(calib, "calib_cam_to_pose.txt")
        ).items()
    },
    "cam_to_velo": loadCalibrationRigid(os.path.join(calib, "calib_cam_to_velo.txt")).tolist(),
    "perspective": {
        k: v.tolist()
        for k, v in loadPerspectiveIntrinsic(os.path.join(calib, "perspective.txt")).items()
    },
    "fisheye": [readYAMLFile(os.path.join(calib, "image_0%d.yaml" % k)) for k in (2, 3)],
}
cams = [CameraPerspective(root, seq, 0), CameraPerspective(root, seq, 1)]
cams += [CameraFisheye(root, seq, 2), CameraFisheye(root, seq, 3)]
res["cam2world"] = [c.cam2world[frame].tolist() for c in cams]
res["sizes"] = [[c.width, c.height] for c in cams]

annotation = Annotation3D(os.path.join(root, "data_3d_bboxes"), seq)
boxes = []
for by_time in annotation.objects.values():
    for timestamp, obj in by_time.items():
        box = {
            "name": obj.name,
            "instance": obj.instanceId,
            "timestamp": timestamp,
            "start": obj.start_frame,
            "end": obj.end_frame,
            "vertices": obj.vertices.tolist(),
        }
        present = (timestamp == -1 and obj.start_frame <= frame <= obj.end_frame) or (
            timestamp == frame
        )
        if present:
            box["projections"] = []
            for k, cam in enumerate(cams):
                (u, v), depth = cam.project_vertices(obj.vertices, frame)
                p = {"u": np.asarray(u, float).tolist(), "v": np.asarray(v, float).tolist()}
                p["depth"] = np.asarray(depth, float).tolist()
                if k >= 2:
                    # cv2.omnidir with the full distortion (k1, k2, p1, p2)
                    fi = cam.fi
                    pose = cam.cam2world[frame]
                    local = (obj.vertices - pose[:3, 3]) @ np.linalg.inv(pose[:3, :3]).T
                    K = np.array(
                        [
                            [fi["projection_parameters"]["gamma1"], 0, fi["projection_parameters"]["u0"]],
                            [0, fi["projection_parameters"]["gamma2"], fi["projection_parameters"]["v0"]],
                            [0, 0, 1],
                        ],
                        dtype=np.float64,
                    )
                    dp = fi["distortion_parameters"]
                    D = np.array([[dp["k1"], dp["k2"], dp["p1"], dp["p2"]]], dtype=np.float64)
                    xi = float(fi["mirror_parameters"]["xi"])
                    zero = np.zeros((1, 3), dtype=np.float64)
                    img, _ = cv2.omnidir.projectPoints(
                        local.reshape(1, -1, 3).astype(np.float64), zero, zero, K, xi, D
                    )
                    p["omnidir"] = img.reshape(-1, 2).tolist()
                    p["local"] = local.tolist()
                box["projections"].append(p)
        boxes.append(box)
res["boxes"] = boxes
with open(out, "w") as f:
    json.dump(res, f)
