#!/usr/bin/env python3
"""The real nuScenes sample that mmdetection3d ships in demo/data/nuscenes/ (one v1.0-mini
keyframe of scene log n015-2018-07-24-11-22-45+0800: six 1600x900 JPEG cameras, the HDL-32E
sweep, 69 boxes with velocities; nuScenes, Motional, CC BY-NC-SA 4.0) rebuilt as a
nuScenes-format data root, so that `panoconv nuscenes` converts a real nuScenes frame.

Usage: mmdet3d_nuscenes.py DEMO_DIR OUT_DATAROOT
  DEMO_DIR: mmdetection3d's demo/data/nuscenes (the .pkl, the six .jpg and the .pcd.bin)

What the tables hold (mmdetection3d's info format 1.1, read with pickle and numpy only):
- the sensors' calibrations from the info's `cam2ego` and `lidar2ego`, the intrinsics from
  `cam2img`, each camera's own timestamp;
- one ego pose, the info's `ego2global` at the LiDAR's time, for every reading: the info has no
  ego pose at each camera's time, so the cameras are placed where the car was when the sweep
  was taken (the cameras fire up to 43 ms earlier);
- the boxes: `bbox_3d` in the LiDAR frame (gravity centre, x/y/z sizes = length/width/height,
  yaw from the LiDAR's x axis: its point counts match `num_lidar_pts`), turned into the global
  frame; categories from the info's class list (boxes of other classes, label -1, are left
  out); one instance per box.
"""
import json
import os
import pickle
import shutil
import sys
import uuid

import numpy as np

CATEGORIES = {
    "car": "vehicle.car",
    "truck": "vehicle.truck",
    "trailer": "vehicle.trailer",
    "bus": "vehicle.bus.rigid",
    "construction_vehicle": "vehicle.construction",
    "bicycle": "vehicle.bicycle",
    "motorcycle": "vehicle.motorcycle",
    "pedestrian": "human.pedestrian.adult",
    "traffic_cone": "movable_object.trafficcone",
    "barrier": "movable_object.barrier",
}
VERSION = "v1.0-mini"


def token(*parts):
    return uuid.uuid5(uuid.NAMESPACE_URL, "/".join(str(p) for p in parts)).hex


def matrix_quat(m):
    w = np.sqrt(max(0.0, 1 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    q = np.array([w, x, y, z])
    return (q / np.linalg.norm(q)).tolist()


def orthonormal(m):
    """The nearest rotation to a float32-rounded one (the info's matrices)."""
    u, _, vt = np.linalg.svd(m)
    return u @ vt


def rigid(matrix):
    m = np.array(matrix, dtype=np.float64)
    m[:3, :3] = orthonormal(m[:3, :3])
    return m


def rot_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def micros(seconds):
    return int(round(seconds * 1e6))


class Tables:
    def __init__(self):
        self.t = {n: [] for n in (
            "sensor", "calibrated_sensor", "ego_pose", "sample", "sample_data", "scene", "log",
            "map", "category", "attribute", "visibility", "instance", "sample_annotation")}

    def add(self, name, record):
        self.t[name].append(record)
        return record

    def write(self, version_dir):
        os.makedirs(version_dir, exist_ok=True)
        for name, records in self.t.items():
            with open(os.path.join(version_dir, name + ".json"), "w") as f:
                json.dump(records, f, indent=1)


def reading(tables, sample, channel, ego_from_sensor, intrinsic, world_from_ego, t, name, size):
    sensor = tables.add("sensor", {"token": token("sensor", channel), "channel": channel,
                                   "modality": "camera" if intrinsic else "lidar"})
    calib = tables.add("calibrated_sensor", {
        "token": token("calibrated_sensor", channel), "sensor_token": sensor["token"],
        "translation": ego_from_sensor[:3, 3].tolist(),
        "rotation": matrix_quat(ego_from_sensor[:3, :3]), "camera_intrinsic": intrinsic})
    ego = tables.add("ego_pose", {
        "token": token("ego_pose", channel, t), "timestamp": micros(t),
        "rotation": matrix_quat(world_from_ego[:3, :3]),
        "translation": world_from_ego[:3, 3].tolist()})
    tables.add("sample_data", {
        "token": token("sample_data", channel, t), "sample_token": sample,
        "ego_pose_token": ego["token"], "calibrated_sensor_token": calib["token"],
        "timestamp": micros(t), "fileformat": "jpg" if intrinsic else "pcd",
        "is_key_frame": True, "height": size[1], "width": size[0], "filename": name,
        "prev": "", "next": ""})


def boxes(tables, info, sample, world_from_lidar, classes):
    names = set()
    for k, box in enumerate(info["instances"]):
        if box["bbox_label_3d"] < 0:
            continue  # a class outside the info's ten (mmdetection3d's -1)
        category = CATEGORIES[classes[box["bbox_label_3d"]]]
        names.add(category)
        x, y, z, length, width, height, yaw = (float(v) for v in box["bbox_3d"])
        centre = world_from_lidar[:3, :3] @ [x, y, z] + world_from_lidar[:3, 3]
        rotation = world_from_lidar[:3, :3] @ rot_z(yaw)
        instance = token("instance", k)
        annotation = tables.add("sample_annotation", {
            "token": token("annotation", k), "sample_token": sample,
            "instance_token": instance, "visibility_token": "4", "attribute_tokens": [],
            "translation": centre.tolist(), "size": [width, length, height],
            "rotation": matrix_quat(rotation), "num_lidar_pts": int(box["num_lidar_pts"]),
            "num_radar_pts": int(box["num_radar_pts"]), "prev": "", "next": ""})
        tables.add("instance", {"token": instance, "category_token": token("category", category),
                                "nbr_annotations": 1,
                                "first_annotation_token": annotation["token"],
                                "last_annotation_token": annotation["token"]})
    for n in sorted(names):
        tables.add("category", {"token": token("category", n), "name": n, "description": ""})


def main():
    demo, out = sys.argv[1], sys.argv[2]
    pickles = [f for f in os.listdir(demo) if f.endswith(".pkl") and "__" not in f]
    if len(pickles) != 1:
        sys.exit(f"{demo}: expected one scene .pkl (mmdetection3d's demo/data/nuscenes)")
    with open(os.path.join(demo, pickles[0]), "rb") as f:
        data = pickle.load(f)
    classes = {v: k for k, v in data["metainfo"]["categories"].items()}
    info = data["data_list"][0]
    log = pickles[0][: -len(".pkl")]
    tables = Tables()
    sample = token("sample", info["token"])
    world_from_ego = rigid(info["ego2global"])
    lidar = info["lidar_points"]
    ego_from_lidar = rigid(lidar["lidar2ego"])
    lidar_t = float(info["timestamp"])
    name = f"samples/LIDAR_TOP/{lidar['lidar_path']}"
    os.makedirs(os.path.join(out, "samples", "LIDAR_TOP"), exist_ok=True)
    shutil.copyfile(os.path.join(demo, lidar["lidar_path"]), os.path.join(out, name))
    reading(tables, sample, "LIDAR_TOP", ego_from_lidar, [], world_from_ego, lidar_t, name, (0, 0))
    for channel, cam in info["images"].items():
        name = f"samples/{channel}/{cam['img_path']}"
        os.makedirs(os.path.join(out, "samples", channel), exist_ok=True)
        shutil.copyfile(os.path.join(demo, cam["img_path"]), os.path.join(out, name))
        intrinsic = [[float(v) for v in row] for row in cam["cam2img"]]
        reading(tables, sample, channel, rigid(cam["cam2ego"]), intrinsic, world_from_ego,
                float(cam["timestamp"]), name, (1600, 900))
    boxes(tables, info, sample, world_from_ego @ ego_from_lidar, classes)
    tables.add("sample", {"token": sample, "timestamp": micros(lidar_t), "prev": "", "next": "",
                          "scene_token": token("scene", log)})
    for i, level in enumerate(("v0-40", "v40-60", "v60-80", "v80-100")):
        tables.add("visibility", {"token": str(i + 1), "level": level, "description": ""})
    log_record = tables.add("log", {"token": token("log", log), "logfile": log,
                                    "vehicle": "n015", "date_captured": "2018-07-24",
                                    "location": "singapore-onenorth"})
    tables.add("map", {"category": "semantic_prior", "token": token("map"), "filename": "",
                       "log_tokens": [log_record["token"]]})
    tables.add("scene", {"token": token("scene", log), "log_token": log_record["token"],
                         "nbr_samples": 1, "first_sample_token": sample,
                         "last_sample_token": sample, "name": "demo-" + log[:4],
                         "description": "nuScenes v1.0-mini, via mmdetection3d's demo"})
    tables.write(os.path.join(out, VERSION))


if __name__ == "__main__":
    main()
