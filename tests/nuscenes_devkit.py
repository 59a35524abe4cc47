"""nuscenes-devkit (PyPI, the dataset's own devkit) as the independent reader of a
nuScenes-format data root: its table loader, poses and calibrations, each camera's boxes
through `get_sample_data` and `view_points`, and each annotation's `box_velocity` (null where
the devkit gives NaN).

Usage: nuscenes_devkit.py DATAROOT VERSION OUT.json

The devkit imports matplotlib, scikit-learn, Pillow, tqdm and cachetools for its renderers
and map helpers, which these calls never reach; stand-ins take their place (not installed).
"""
import importlib.abc
import importlib.util
import json
import sys
import types

import numpy as np

STUBBED = ("matplotlib", "sklearn", "PIL", "tqdm", "cachetools", "descartes", "shapely")


class _Stub(types.ModuleType):
    """A module whose every attribute is a permissive stand-in (a decorator factory too)."""

    __path__ = []

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return _anything


def _anything(*args, **kwargs):
    return (lambda f: f) if not args or not callable(args[0]) else args[0]


class _StubFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, fullname, path, target=None):
        if fullname.split(".")[0] in STUBBED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        return _Stub(spec.name)

    def exec_module(self, module):
        pass


sys.meta_path.insert(0, _StubFinder())

from nuscenes.nuscenes import NuScenes  # noqa: E402
from nuscenes.utils.geometry_utils import BoxVisibility, transform_matrix, view_points  # noqa: E402
from pyquaternion import Quaternion  # noqa: E402

dataroot, version, out = sys.argv[1], sys.argv[2], sys.argv[3]
nusc = NuScenes(version=version, dataroot=dataroot, verbose=False)


def matrix(record, inverse=False):
    return transform_matrix(record["translation"], Quaternion(record["rotation"]), inverse=inverse)


res = {"scenes": []}
for scene in nusc.scene:
    samples = []
    token = scene["first_sample_token"]
    while token:
        sample = nusc.get("sample", token)
        entry = {"token": token, "sensors": {}, "velocities": {}}
        for ann in sample["anns"]:
            v = nusc.box_velocity(ann)
            entry["velocities"][ann] = None if np.any(np.isnan(v)) else v.tolist()
        for channel, sd_token in sample["data"].items():
            sd = nusc.get("sample_data", sd_token)
            cs = nusc.get("calibrated_sensor", sd["calibrated_sensor_token"])
            pose = nusc.get("ego_pose", sd["ego_pose_token"])
            sensor = {
                "timestamp": sd["timestamp"],
                "filename": sd["filename"],
                "global_from_ego": matrix(pose).tolist(),
                "ego_from_sensor": matrix(cs).tolist(),
            }
            if sd["sensor_modality"] == "camera":
                path, boxes, k = nusc.get_sample_data(sd_token, box_vis_level=BoxVisibility.NONE)
                sensor["intrinsic"] = k.tolist()
                sensor["boxes"] = []
                for box in boxes:
                    corners = box.corners()
                    if np.all(corners[2, :] > 0.1):
                        pixels = view_points(corners, k, normalize=True)[:2, :]
                        sensor["boxes"].append({"annotation": box.token, "corners": pixels.T.tolist()})
            entry["sensors"][channel] = sensor
        samples.append(entry)
        token = sample["next"]
    res["scenes"].append({"name": scene["name"], "samples": samples})
with open(out, "w") as f:
    json.dump(res, f)
