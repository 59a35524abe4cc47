#!/usr/bin/env python3
"""The nuScenes stitch of `panoconv nuscenes --to equirect --stitch-mode fixed` in numpy +
OpenCV, for the throughput comparison of `benches/stitch.sh --nuscenes`.

It reads a nuScenes-format version's tables (VERSION/scene.json, sample.json, sample_data.json,
calibrated_sensor.json, ego_pose.json, sensor.json; quaternions [w, x, y, z]) and places every
sample's cameras as panoconv does (docs/nuscenes.md): each camera by its own keyframe reading's
ego pose and calibration (global_from_camera = ego_pose . calibrated_sensor), in the level frame
of CAM_FRONT at the LIDAR_TOP keyframe's ego pose; the cameras in nuScenes' order (clockwise
from CAM_FRONT, then others by name), each the pinhole of its camera_intrinsic. The stitch
itself is benches/opencv_stitch.py's (the same model, shared). Frame ids: the scene's place in
scene.json times 1000 plus the sample's place in its scene. Writes OUT/image_2/NNNNNN.png and
OUT/source_2/NNNNNN.png.

    opencv_stitch_nuscenes.py --input DATAROOT --version v1.0-mini --output OUT [--jobs 2]
        [--width 2048]
    opencv_stitch_nuscenes.py --compare A.png B.png      # PSNR of two images, dB
"""
import argparse
import json
import os

import numpy as np

from opencv_stitch import Pinhole, common_arguments, compare, level_from_world, run, stitch_rig

CAMERA_ORDER = ["CAM_FRONT", "CAM_FRONT_RIGHT", "CAM_BACK_RIGHT", "CAM_BACK", "CAM_BACK_LEFT",
                "CAM_FRONT_LEFT"]
REFERENCE_CAMERA = "CAM_FRONT"
REFERENCE_LIDAR = "LIDAR_TOP"


def table(root, version, name):
    with open(os.path.join(root, version, name + ".json")) as f:
        return json.load(f)


def pose(record):
    """The 4x4 of a record's translation and [w, x, y, z] rotation (normalised, as
    pyquaternion does)."""
    w, x, y, z = np.asarray(record["rotation"], dtype=np.float64) / np.linalg.norm(
        record["rotation"])
    t = np.eye(4)
    t[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    t[:3, 3] = record["translation"]
    return t


def read_samples(root, version, width, out):
    """One stitch job per sample, in scene order then sample order."""
    sensors = {s["token"]: s for s in table(root, version, "sensor")}
    calibrated = {c["token"]: c for c in table(root, version, "calibrated_sensor")}
    ego = {e["token"]: e for e in table(root, version, "ego_pose")}
    samples = {s["token"]: s for s in table(root, version, "sample")}
    keyframes = {}  # (sample, channel) -> sample_data record
    for d in table(root, version, "sample_data"):
        if d.get("is_key_frame") and d.get("sample_token"):
            channel = sensors[calibrated[d["calibrated_sensor_token"]]["sensor_token"]]["channel"]
            keyframes[(d["sample_token"], channel)] = d
    cameras = sorted({s["channel"] for s in sensors.values() if s["modality"] == "camera"},
                     key=lambda c: (CAMERA_ORDER.index(c) if c in CAMERA_ORDER else 99, c))
    reference = REFERENCE_CAMERA if REFERENCE_CAMERA in cameras else cameras[0]

    def world_from(data):
        return pose(ego[data["ego_pose_token"]]) @ pose(calibrated[data["calibrated_sensor_token"]])

    jobs = []
    for position, scene in enumerate(table(root, version, "scene")):
        token, k = scene["first_sample_token"], 0
        while token:
            lidar = keyframes[(token, REFERENCE_LIDAR)]
            front = keyframes[(token, reference)]
            level = level_from_world(
                pose(ego[lidar["ego_pose_token"]])
                @ pose(calibrated[front["calibrated_sensor_token"]]))
            rig = []
            for channel in cameras:
                data = keyframes[(token, channel)]
                kk = calibrated[data["calibrated_sensor_token"]]["camera_intrinsic"]
                model = Pinhole(kk[0][0], kk[1][1], kk[0][2], kk[1][2],
                                (data["width"], data["height"]))
                rig.append((model, level @ world_from(data), os.path.join(root, data["filename"])))
            jobs.append((rig, width, out, f"{position * 1000 + k:06d}.png"))
            token, k = samples[token].get("next"), k + 1
    return jobs


def stitch_sample(job):
    stitch_rig(*job)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--input")
    p.add_argument("--version", default="v1.0-mini")
    common_arguments(p)
    a = p.parse_args()
    if compare(a):
        return
    run(stitch_sample, read_samples(a.input, a.version, a.width, a.output), a.jobs, a.output)


if __name__ == "__main__":
    main()
