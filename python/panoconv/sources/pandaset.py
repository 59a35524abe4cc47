"""PandaSet as a `panoconv.RigSource`: a sequence folder in PandaSet's layout (camera/,
lidar/, annotations/cuboids/, meta/), its six cameras, one or both LiDARs and its cuboids,
every frame whose files are on disk. Needs pandas (`pip install panoconv[pandaset]`).

PandaSet's conventions (its devkit, `pandaset.geometry`): poses are a position and a heading
quaternion (w, x, y, z) in the world frame, camera axes x right, y down, z forward; a cuboid's
`yaw` turns its local x (its width, `dimensions.x`) about z, its length (`dimensions.y`) runs
along local y towards its front; positions are box centres. Attribution: PandaSet, Hesai and
Scale AI (CC BY 4.0).
"""

from __future__ import annotations

import json
import math
import os
import struct
from typing import Optional

import numpy as np

from ..rig import Box3D, RigCamera, RigFrame, RigSource
from .._native import Camera

# The car's own body as the Pandar64 sees it, in the LiDAR's pose frame (PandaSet's
# `lidar/poses.json`): the roof and the sensor's mount return within 2 m of its origin,
# 1.35-1.6 m up in that frame (about 600 returns a sweep), and would read as the nearest
# surface of every ray through them (depth labels, the depth-guided stitch). As nuScenes'
# devkit and KITTI-360's scripts drop their vehicle's returns, the adapter drops those inside
# this box ((least corner), (greatest corner), metres); `vehicle_box=None` keeps them. The
# nearest other returns of the sequence's frames (a parked car) lie 2 m to the side.
VEHICLE_BOX = ((-1.0, -1.3, 1.0), (1.0, 2.2, 2.0))

# Clockwise from the front camera, as nuScenes orders its rig; the first is the level frame's.
CAMERAS = (
    "front_camera",
    "front_right_camera",
    "right_camera",
    "back_camera",
    "left_camera",
    "front_left_camera",
)

# PandaSet's classes with a KITTI type (the others are not written). A cycle is a Cyclist with
# its rider (`attributes.rider_status`), as nuScenes' classes map it.
KITTI_TYPES = {
    "Car": "Car",
    "Pickup Truck": "Car",
    "Medium-sized Truck": "Truck",
    "Semi-truck": "Truck",
    "Bus": "Truck",
    "Other Vehicle - Construction Vehicle": "Truck",
    "Towed Object": "Van",
    "Emergency Vehicle": "Van",
    "Other Vehicle - Uncommon": "Misc",
    "Other Vehicle - Pedicab": "Misc",
    "Tram / Subway": "Tram",
    "Train": "Tram",
    "Trolley": "Tram",
    "Pedestrian": "Pedestrian",
    "Pedestrian with Object": "Pedestrian",
}
CYCLES = ("Bicycle", "Motorcycle", "Motorized Scooter", "Personal Mobility Device")

# The Pandar64's azimuth step at 10 Hz, degrees.
PANDAR64_AZIMUTH_STEP_DEG = 0.2

# A cuboid's velocity: the centres of the same object (its uuid) in the nearest frames on disk
# before and after, over their LiDAR times (a centred difference, one-sided where only one
# holds it), as nuScenes' devkit gives `box_velocity`; a frame farther than this is not used,
# seconds (the sequence's frames are 0.1 s apart; a copy holding every 20th, 2 s).
MAX_GAP_S = 2.5


def kitti_type(label: str, rider_status) -> Optional[str]:
    """The KITTI type of a PandaSet cuboid, or None (not written)."""
    if label in CYCLES:
        return "Cyclist" if rider_status == "With Rider" else None
    return KITTI_TYPES.get(label)


def pose_matrix(pose: dict) -> np.ndarray:
    """world_from_sensor (4 x 4) of a PandaSet pose: position and heading quaternion."""
    q = pose["heading"]
    w, x, y, z = q["w"], q["x"], q["y"], q["z"]
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    p = pose["position"]
    m[:3, 3] = [p["x"], p["y"], p["z"]]
    return m


def jpeg_size(path: str) -> tuple:
    """(width, height) of a JPEG from its frame header."""
    with open(path, "rb") as f:
        data = f.read(1 << 16)
    at = 2
    while at + 9 < len(data):
        if data[at] != 0xFF:
            break
        marker, length = data[at + 1], struct.unpack(">H", data[at + 2 : at + 4])[0]
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            h, w = struct.unpack(">HH", data[at + 5 : at + 9])
            return w, h
        at += 2 + length
    raise ValueError(f"{path}: no JPEG frame header in its first 64 KiB")


def _json(path: str):
    with open(path) as f:
        return json.load(f)


class PandaSet(RigSource):
    """A PandaSet sequence folder (`.../002`). `lidar`: "both" (default), "pandar64" (the
    360° one, `d` = 0) or "pandargt" (the forward one, `d` = 1); None reads no scan.
    `vehicle_box`: the returns dropped as the car's own body ([`VEHICLE_BOX`], in the LiDAR's
    pose frame), None to keep every return."""

    name = "pandaset"
    lidar_azimuth_step_deg = PANDAR64_AZIMUTH_STEP_DEG

    def __init__(self, sequence, lidar: Optional[str] = "both", vehicle_box=VEHICLE_BOX):
        import pandas  # noqa: F401  (the optional extra: fail here, naming it)

        self.vehicle_box = None
        if vehicle_box is not None:
            least, greatest = (np.asarray(c, dtype=np.float64).reshape(3) for c in vehicle_box)
            if not (np.all(np.isfinite(least)) and np.all(least < greatest)):
                raise ValueError(f"vehicle_box {vehicle_box!r}: a least and a greatest corner")
            self.vehicle_box = (least, greatest)

        self.root = os.path.abspath(os.fspath(sequence))
        if lidar not in ("both", "pandar64", "pandargt", None):
            raise ValueError(f"lidar {lidar!r}: both, pandar64, pandargt or None")
        self.lidar = lidar
        self.sequence = os.path.basename(self.root)
        meta = os.path.join(self.root, "meta", "timestamps.json")
        self.timestamps = _json(meta)
        self.poses = {c: _json(self._camera_file(c, "poses.json")) for c in CAMERAS}
        self.times = {c: _json(self._camera_file(c, "timestamps.json")) for c in CAMERAS}
        self.lidar_poses = _json(os.path.join(self.root, "lidar", "poses.json"))
        self._cameras = []
        frames = self.frames()
        for c in CAMERAS:
            k = _json(self._camera_file(c, "intrinsics.json"))
            # the image size from the first frame's JPEG (PandaSet's are 1920 x 1080)
            w, h = jpeg_size(self._image(c, frames[0])) if frames else (1920, 1080)
            self._cameras.append((c, Camera.perspective(w, h, k["fx"], k["fy"], k["cx"], k["cy"])))

    def _camera_file(self, camera: str, name: str) -> str:
        return os.path.join(self.root, "camera", camera, name)

    def _image(self, camera: str, frame: str) -> str:
        return self._camera_file(camera, f"{frame}.jpg")

    def _files(self, frame: str) -> list:
        files = [self._image(c, frame) for c in CAMERAS]
        files.append(os.path.join(self.root, "annotations", "cuboids", f"{frame}.pkl.gz"))
        if self.lidar is not None:
            files.append(os.path.join(self.root, "lidar", f"{frame}.pkl.gz"))
        return files

    def _listed(self) -> list:
        return [f"{k:02d}" for k in range(len(self.timestamps))]

    def frames(self) -> list:
        return [f for f in self._listed() if all(os.path.isfile(p) for p in self._files(f))]

    def not_frames(self) -> list:
        return [f for f in self._listed() if not all(os.path.isfile(p) for p in self._files(f))]

    def cameras(self) -> list:
        return list(self._cameras)

    def read(self, frame_id: str) -> RigFrame:
        import pandas as pd

        k = int(frame_id)
        # each camera's time from the LiDAR sweep's (the boxes'): PandaSet fires each camera as
        # the sweep passes it, up to 0.1 s before the sweep's time
        cameras = [
            RigCamera(
                name,
                self._image(name, frame_id),
                camera,
                pose_matrix(self.poses[name][k]),
                time=float(self.times[name][k]) - float(self.timestamps[k]),
            )
            for name, camera in self._cameras
        ]
        cuboids_file = os.path.join(self.root, "annotations", "cuboids", f"{frame_id}.pkl.gz")
        cuboids = pd.read_pickle(cuboids_file)
        boxes = self.boxes(cuboids, self.velocities(k, cuboids))
        inputs = [cuboids_file]
        lidar = None
        if self.lidar is not None:
            lidar_file = os.path.join(self.root, "lidar", f"{frame_id}.pkl.gz")
            scan = pd.read_pickle(lidar_file)
            self.time_boxes(boxes, scan, float(self.timestamps[k]))
            if self.lidar != "both":
                scan = scan[scan["d"] == (0 if self.lidar == "pandar64" else 1)]
            lidar = self.without_vehicle(
                scan[["x", "y", "z", "i"]].to_numpy(dtype=np.float64),
                pose_matrix(self.lidar_poses[k]),
            )
            inputs.append(lidar_file)
        record = {
            "sequence": self.sequence,
            "frame": k,
            "timestamp": self.timestamps[k],
            "camera_timestamps": {c: self.times[c][k] for c in CAMERAS},
        }
        return RigFrame(
            cameras,
            boxes,
            lidar=lidar,
            world_from_lidar=pose_matrix(self.lidar_poses[k]),
            record=record,
            inputs=inputs,
        )

    @staticmethod
    def time_boxes(boxes: list, scan, sweep_time: float) -> None:
        """Sets each moving box's `time`: the median time of the Pandar64's returns inside it
        (PandaSet's per-point `t`) after `sweep_time`; the sweep turns in 0.1 s and each camera
        fires as it passes, so the box holds where the camera facing it saw it."""
        ring = scan[scan["d"] == 0] if "d" in scan else scan
        xyz = ring[["x", "y", "z"]].to_numpy(dtype=np.float64)
        t = ring["t"].to_numpy(dtype=np.float64)
        for b in boxes:
            if b.velocity is None or not np.any(np.asarray(b.velocity)):
                continue
            # the box's axes: x along its length (yaw from the world's x), z up
            c, s = math.cos(b.yaw), math.sin(b.yaw)
            d = xyz - np.asarray(b.centre, dtype=np.float64)
            along, across = d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c
            half = np.asarray(b.size, dtype=np.float64) / 2
            inside = (np.abs(along) <= half[0]) & (np.abs(across) <= half[1]) & (np.abs(d[:, 2]) <= half[2])
            if np.any(inside):
                b.time = float(np.median(t[inside])) - sweep_time

    def without_vehicle(self, points: np.ndarray, world_from_lidar: np.ndarray) -> np.ndarray:
        """The world-frame `points` (N x 4) less those inside the vehicle box."""
        if self.vehicle_box is None:
            return points
        least, greatest = self.vehicle_box
        lidar_from_world = np.linalg.inv(world_from_lidar)
        local = points[:, :3] @ lidar_from_world[:3, :3].T + lidar_from_world[:3, 3]
        inside = np.all((local >= least) & (local <= greatest), axis=1)
        return points[~inside]

    def _centres(self, frame: int) -> dict:
        """uuid -> centre (world) of frame `frame`'s cuboids."""
        import pandas as pd

        c = pd.read_pickle(os.path.join(self.root, "annotations", "cuboids", f"{frame:02d}.pkl.gz"))
        xyz = c[["position.x", "position.y", "position.z"]].to_numpy(dtype=np.float64)
        return dict(zip(c["uuid"].to_numpy(), xyz))

    def velocities(self, k: int, cuboids) -> dict:
        """uuid -> world velocity (m/s) of frame `k`'s cuboids, from the nearest frames on disk
        before and after within MAX_GAP_S (see MAX_GAP_S); an object in neither has none."""
        on_disk = [int(f) for f in self.frames()]
        t = float(self.timestamps[k])
        before = [f for f in on_disk if f < k and t - float(self.timestamps[f]) <= MAX_GAP_S]
        after = [f for f in on_disk if f > k and float(self.timestamps[f]) - t <= MAX_GAP_S]
        here = dict(
            zip(
                cuboids["uuid"].to_numpy(),
                cuboids[["position.x", "position.y", "position.z"]].to_numpy(dtype=np.float64),
            )
        )
        ends = [(k, here)]
        prev = (max(before), self._centres(max(before))) if before else None
        nxt = (min(after), self._centres(min(after))) if after else None
        out = {}
        for uuid, p in here.items():
            first = prev if prev is not None and uuid in prev[1] else ends[0]
            last = nxt if nxt is not None and uuid in nxt[1] else ends[0]
            if first[0] == last[0]:
                continue
            dt = float(self.timestamps[last[0]]) - float(self.timestamps[first[0]])
            out[uuid] = tuple((last[1][uuid] - first[1][uuid]) / dt)
        return out

    def boxes(self, cuboids, velocities: Optional[dict] = None) -> list:
        """The cuboids with a KITTI type, an object annotated once per LiDAR (siblings) once:
        the chosen LiDAR's annotation (the Pandar64's for both); `velocities` (uuid -> world
        m/s, [`PandaSet.velocities`]) where known."""
        prefer = 1 if self.lidar == "pandargt" else 0
        sensor = cuboids["cuboids.sensor_id"].to_numpy()
        uuid = cuboids["uuid"].to_numpy()
        sibling = cuboids["cuboids.sibling_id"].to_numpy()
        preferred = set(uuid[sensor == prefer]) | set(sibling[sensor == prefer])
        labels = cuboids["label"].to_numpy()
        riders = cuboids["attributes.rider_status"].to_numpy()
        out = []
        for i in range(len(cuboids)):
            if sensor[i] not in (-1, prefer) and (uuid[i] in preferred or sibling[i] in preferred):
                continue
            label = labels[i]
            kind = kitti_type(label, riders[i])
            if kind is None:
                continue
            c = cuboids.iloc[i]
            out.append(
                Box3D(
                    kind,
                    (c["position.x"], c["position.y"], c["position.z"]),
                    (c["dimensions.y"], c["dimensions.x"], c["dimensions.z"]),
                    # the front along local +y: a quarter turn from PandaSet's yaw
                    yaw=float(c["yaw"]) + math.pi / 2,
                    label=label,
                    instance=str(uuid[i]),
                    velocity=(velocities or {}).get(uuid[i]),
                )
            )
        return out
