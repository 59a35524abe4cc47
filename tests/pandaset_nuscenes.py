"""PandaSet frames (../shared/pandaset/002: PandaSet, Hesai and Scale AI, CC BY 4.0) rebuilt as a
nuScenes-format data root, so that `panoconv nuscenes` converts real frames of a six-camera rig
with a 360 deg LiDAR. Conventions from PandaSet's devkit (`pandaset.geometry`): poses are
sensor-to-world (heading quaternion w x y z, position), cameras look along +z (x right, y down),
the LiDAR points are in the world frame, a cuboid's corners are (+-dims.x/2, +-dims.y/2,
+-dims.z/2) turned by `yaw` about the world's z.

Usage: pandaset_nuscenes.py SEQUENCE_DIR OUT_DATAROOT [FRAME ...]   (frames default 00 20 40 60)

What the tables hold:
- the ego frame is the Pandar64's frame turned +90 deg about z (PandaSet's LiDAR looks along +y;
  nuScenes' ego along +x); LIDAR_TOP's records are the Pandar64's (d = 0) points in its own
  frame at the sweep's time; the forward PandarGT (d = 1) is left out;
- each camera's calibration is fixed (from the first frame) and its ego pose at the camera's
  own time is its PandaSet pose times the inverse calibration, so every camera pose is exact;
- the cuboids of the 360 deg LiDAR (sensor_id -1 or 0, and 1 where no sibling exists), as
  nuScenes boxes: size (dims.x, dims.y, dims.z) = (width, length, height), heading yaw + 90 deg
  (the length along the box's x); `num_lidar_pts` counts the Pandar64's points inside.
"""
import json
import os
import shutil
import sys
import uuid

import numpy as np
import pandas as pd

CHANNELS = {
    "front_camera": "CAM_FRONT",
    "front_right_camera": "CAM_FRONT_RIGHT",
    "right_camera": "CAM_BACK_RIGHT",
    "back_camera": "CAM_BACK",
    "left_camera": "CAM_BACK_LEFT",
    "front_left_camera": "CAM_FRONT_LEFT",
}
CATEGORIES = {
    "Car": "vehicle.car",
    "Pickup Truck": "vehicle.truck",
    "Medium-sized Truck": "vehicle.truck",
    "Semi-truck": "vehicle.truck",
    "Bus": "vehicle.bus.rigid",
    "Other Vehicle - Construction Vehicle": "vehicle.construction",
    "Towed Object": "vehicle.trailer",
    "Pedestrian": "human.pedestrian.adult",
    "Pedestrian with Object": "human.pedestrian.adult",
    "Bicycle": "vehicle.bicycle",
    "Motorcycle": "vehicle.motorcycle",
    "Cones": "movable_object.trafficcone",
    "Pylons": "movable_object.trafficcone",
    "Temporary Construction Barriers": "movable_object.barrier",
    "Road Barriers": "movable_object.barrier",
}
LOG = "pandaset-002"


def token(*parts):
    return uuid.uuid5(uuid.NAMESPACE_URL, "/".join(str(p) for p in parts)).hex


def quat_matrix(q):
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_quat(m):
    w = np.sqrt(max(0.0, 1 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    q = np.array([w, x, y, z])
    return (q / np.linalg.norm(q)).tolist()


def pose_matrix(pose):
    h, p = pose["heading"], pose["position"]
    m = np.eye(4)
    m[:3, :3] = quat_matrix([h["w"], h["x"], h["y"], h["z"]])
    m[:3, 3] = [p["x"], p["y"], p["z"]]
    return m


def rot_z(angle):
    m = np.eye(4)
    c, s = np.cos(angle), np.sin(angle)
    m[:2, :2] = [[c, -s], [s, c]]
    return m


def interpolate(times, poses, t):
    """world_from_sensor at time t between the two nearest poses (linear, normalised quaternion)."""
    k = int(np.clip(np.searchsorted(times, t) - 1, 0, len(times) - 2))
    a = (t - times[k]) / (times[k + 1] - times[k])
    pa, pb = poses[k], poses[k + 1]
    qa = np.array([pa["heading"][c] for c in "wxyz"])
    qb = np.array([pb["heading"][c] for c in "wxyz"])
    qb = qb if qa @ qb >= 0 else -qb
    q = (1 - a) * qa + a * qb
    q /= np.linalg.norm(q)
    pos = [(1 - a) * pa["position"][c] + a * pb["position"][c] for c in "xyz"]
    m = np.eye(4)
    m[:3, :3] = quat_matrix(q)
    m[:3, 3] = pos
    return m


def micros(seconds):
    return int(round(seconds * 1e6))


def load(path):
    with open(path) as f:
        return json.load(f)


class Tables:
    def __init__(self):
        self.t = {n: [] for n in (
            "sensor", "calibrated_sensor", "ego_pose", "sample", "sample_data", "scene", "log",
            "map", "category", "attribute", "visibility", "instance", "sample_annotation")}

    def add(self, name, record):
        self.t[name].append(record)
        return record

    def link(self, name, key):
        """prev/next along records of the same `key`, in order."""
        last = {}
        for r in self.t[name]:
            k = key(r)
            r["prev"] = last[k]["token"] if k in last else ""
            r["next"] = ""
            if k in last:
                last[k]["next"] = r["token"]
            last[k] = r

    def write(self, version_dir):
        os.makedirs(version_dir, exist_ok=True)
        for name, records in self.t.items():
            with open(os.path.join(version_dir, name + ".json"), "w") as f:
                json.dump(records, f, indent=1)


def sensors(tables, seq, first):
    """Sensor and calibration records; returns (ego_from_camera per channel, calibration tokens)."""
    lidar_times = np.array(load(os.path.join(seq, "lidar", "timestamps.json")))
    lidar_poses = load(os.path.join(seq, "lidar", "poses.json"))
    calib, tokens = {}, {}
    for folder, channel in list(CHANNELS.items()) + [("lidar", "LIDAR_TOP")]:
        s = tables.add("sensor", {"token": token("sensor", channel), "channel": channel,
                                  "modality": "lidar" if folder == "lidar" else "camera"})
        if folder == "lidar":
            ego_from = rot_z(-np.pi / 2)
            intrinsic = []
        else:
            cam = os.path.join(seq, "camera", folder)
            t = load(os.path.join(cam, "timestamps.json"))[first]
            world_from_ego = interpolate(lidar_times, lidar_poses, t) @ rot_z(np.pi / 2)
            world_from_cam = pose_matrix(load(os.path.join(cam, "poses.json"))[first])
            ego_from = np.linalg.inv(world_from_ego) @ world_from_cam
            k = load(os.path.join(cam, "intrinsics.json"))
            intrinsic = [[k["fx"], 0.0, k["cx"]], [0.0, k["fy"], k["cy"]], [0.0, 0.0, 1.0]]
        calib[channel] = ego_from
        c = tables.add("calibrated_sensor", {
            "token": token("calibrated_sensor", channel), "sensor_token": s["token"],
            "translation": ego_from[:3, 3].tolist(), "rotation": matrix_quat(ego_from[:3, :3]),
            "camera_intrinsic": intrinsic})
        tokens[channel] = c["token"]
    return calib, tokens


def sample_data(tables, sample, channel, calib_token, world_from_ego, t, filename, size):
    ego = tables.add("ego_pose", {
        "token": token("ego_pose", channel, t), "timestamp": micros(t),
        "rotation": matrix_quat(world_from_ego[:3, :3]),
        "translation": world_from_ego[:3, 3].tolist()})
    tables.add("sample_data", {
        "token": token("sample_data", channel, t), "sample_token": sample,
        "ego_pose_token": ego["token"], "calibrated_sensor_token": calib_token,
        "timestamp": micros(t), "fileformat": "pcd" if channel == "LIDAR_TOP" else "jpg",
        "is_key_frame": True, "height": size[1], "width": size[0], "filename": filename,
        "_channel": channel})


def frame(tables, seq, out, frame_name, calib, tokens, scene):
    index = int(frame_name)
    lidar_t = load(os.path.join(seq, "lidar", "timestamps.json"))[index]
    world_from_lidar = pose_matrix(load(os.path.join(seq, "lidar", "poses.json"))[index])
    sample = tables.add("sample", {"token": token("sample", frame_name), "timestamp": micros(lidar_t),
                                   "scene_token": scene})["token"]
    points = pd.read_pickle(os.path.join(seq, "lidar", frame_name + ".pkl.gz"))
    points = points[points["d"] == 0]
    world = points[["x", "y", "z"]].to_numpy(np.float64)
    lidar_from_world = np.linalg.inv(world_from_lidar)
    local = world @ lidar_from_world[:3, :3].T + lidar_from_world[:3, 3]
    record = np.zeros((len(local), 5), np.float32)
    record[:, :3] = local
    record[:, 3] = points["i"].to_numpy(np.float32)
    name = f"samples/LIDAR_TOP/{LOG}__LIDAR_TOP__{micros(lidar_t)}.pcd.bin"
    os.makedirs(os.path.join(out, "samples", "LIDAR_TOP"), exist_ok=True)
    record.tofile(os.path.join(out, name))
    world_from_ego = world_from_lidar @ np.linalg.inv(calib["LIDAR_TOP"])
    sample_data(tables, sample, "LIDAR_TOP", tokens["LIDAR_TOP"], world_from_ego, lidar_t, name, (0, 0))
    for folder, channel in CHANNELS.items():
        cam = os.path.join(seq, "camera", folder)
        t = load(os.path.join(cam, "timestamps.json"))[index]
        world_from_cam = pose_matrix(load(os.path.join(cam, "poses.json"))[index])
        name = f"samples/{channel}/{LOG}__{channel}__{micros(t)}.jpg"
        os.makedirs(os.path.join(out, "samples", channel), exist_ok=True)
        shutil.copyfile(os.path.join(cam, frame_name + ".jpg"), os.path.join(out, name))
        sample_data(tables, sample, channel, tokens[channel],
                    world_from_cam @ np.linalg.inv(calib[channel]), t, name, (1920, 1080))
    cuboids(tables, seq, frame_name, sample, world)


def attributes(row, category):
    if category.startswith("vehicle.") and category not in ("vehicle.bicycle", "vehicle.motorcycle"):
        return ["vehicle.parked" if row["stationary"] else "vehicle.moving"]
    if category.startswith("human."):
        return ["pedestrian.standing" if row["stationary"] else "pedestrian.moving"]
    if category in ("vehicle.bicycle", "vehicle.motorcycle"):
        return ["cycle.with_rider" if row.get("attributes.rider_status") == "With Rider"
                else "cycle.without_rider"]
    return []


def inside(world, centre, yaw, dims):
    c, s = np.cos(yaw), np.sin(yaw)
    d = world - centre
    lx, ly = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    return int(np.sum((np.abs(lx) <= dims[0] / 2) & (np.abs(ly) <= dims[1] / 2)
                      & (np.abs(d[:, 2]) <= dims[2] / 2)))


def cuboids(tables, seq, frame_name, sample, world):
    boxes = pd.read_pickle(os.path.join(seq, "annotations", "cuboids", frame_name + ".pkl.gz"))
    for _, row in boxes.iterrows():
        category = CATEGORIES.get(row["label"])
        sensor, sibling = int(row["cuboids.sensor_id"]), row["cuboids.sibling_id"]
        if category is None or (sensor == 1 and sibling not in ("-", "", None)):
            continue
        centre = np.array([row["position.x"], row["position.y"], row["position.z"]])
        dims = np.array([row["dimensions.x"], row["dimensions.y"], row["dimensions.z"]])
        heading = row["yaw"] + np.pi / 2
        instance = token("instance", row["uuid"])
        tables.add("sample_annotation", {
            "token": token("annotation", frame_name, row["uuid"], sensor),
            "sample_token": sample, "instance_token": instance, "visibility_token": "4",
            "attribute_tokens": [token("attribute", a) for a in attributes(row, category)],
            "translation": centre.tolist(), "size": dims.tolist(),
            "rotation": [np.cos(heading / 2), 0.0, 0.0, np.sin(heading / 2)],
            "num_lidar_pts": inside(world, centre, row["yaw"], dims), "num_radar_pts": 0,
            "_category": category})


def finish(tables, scene):
    names = sorted({a.pop("_category") for a in tables.t["sample_annotation"]} | {"vehicle.car"})
    for n in names:
        tables.add("category", {"token": token("category", n), "name": n, "description": ""})
    for n in ("vehicle.moving", "vehicle.parked", "pedestrian.moving", "pedestrian.standing",
              "cycle.with_rider", "cycle.without_rider"):
        tables.add("attribute", {"token": token("attribute", n), "name": n, "description": ""})
    for i, level in enumerate(("v0-40", "v40-60", "v60-80", "v80-100")):
        tables.add("visibility", {"token": str(i + 1), "level": level, "description": ""})
    tables.link("sample_annotation", lambda r: r["instance_token"])
    tables.link("sample", lambda r: 0)
    tables.link("sample_data", lambda r: r["_channel"])
    for r in tables.t["sample_data"]:
        r.pop("_channel")
    log = tables.add("log", {"token": token("log", LOG), "logfile": LOG, "vehicle": "pandaset",
                             "date_captured": "2019-05-11", "location": "san-francisco"})
    tables.add("map", {"category": "semantic_prior", "token": token("map"), "filename": "",
                       "log_tokens": [log["token"]]})
    samples = tables.t["sample"]
    tables.add("scene", {"token": scene, "log_token": log["token"], "nbr_samples": len(samples),
                         "first_sample_token": samples[0]["token"],
                         "last_sample_token": samples[-1]["token"], "name": "pandaset-002",
                         "description": "PandaSet, Hesai and Scale AI (CC BY 4.0)"})


def main():
    seq, out = sys.argv[1], sys.argv[2]
    frames = sys.argv[3:] or ["00", "20", "40", "60"]
    tables = Tables()
    calib, tokens = sensors(tables, seq, int(frames[0]))
    scene = token("scene", LOG)
    for f in frames:
        frame(tables, seq, out, f, calib, tokens, scene)
    labels = {}
    for a in tables.t["sample_annotation"]:
        labels[a["instance_token"]] = a["_category"]
    finish(tables, scene)
    for inst, category in labels.items():
        group = [a for a in tables.t["sample_annotation"] if a["instance_token"] == inst]
        tables.add("instance", {"token": inst, "category_token": token("category", category),
                                "nbr_annotations": len(group),
                                "first_annotation_token": group[0]["token"],
                                "last_annotation_token": group[-1]["token"]})
    tables.write(os.path.join(out, "v1.0-mini"))


if __name__ == "__main__":
    main()
