#!/usr/bin/env python3
"""A nuScenes-format data root whose rig stands still: every reading of a sensor takes the ego
pose of that sensor's reading in the scene's first sample, so each sample places its cameras
exactly as the first one does (the geometry a rig without odometry, or a parked vehicle, gives).
The images, scans and boxes stay the samples' own (their content no longer fits the poses: the
root measures the cost of a repeated geometry, not a picture). For `benches/stitch.sh --still`.

    still_rig.py DATAROOT VERSION OUT     # writes OUT/VERSION/*.json, links OUT/samples etc.
"""
import json
import os
import sys


def main():
    root, version, out = sys.argv[1:4]
    tables = os.path.join(root, version)
    os.makedirs(os.path.join(out, version), exist_ok=True)
    for name in os.listdir(root):
        if name != version and not os.path.exists(os.path.join(out, name)):
            os.symlink(os.path.abspath(os.path.join(root, name)), os.path.join(out, name))
    for name in os.listdir(tables):
        if name != "sample_data.json":
            src, dst = os.path.join(tables, name), os.path.join(out, version, name)
            if not os.path.exists(dst):
                os.symlink(os.path.abspath(src), dst)
    with open(os.path.join(tables, "sample_data.json")) as f:
        data = json.load(f)
    with open(os.path.join(tables, "sample.json")) as f:
        samples = json.load(f)
    with open(os.path.join(tables, "scene.json")) as f:
        first = {s["first_sample_token"] for s in json.load(f)}
    scene_of = {s["token"]: s["scene_token"] for s in samples}
    # the first sample's pose of each (scene, calibrated sensor)
    pose = {}
    for d in data:
        if d.get("is_key_frame") and d.get("sample_token") in first:
            pose[(scene_of[d["sample_token"]], d["calibrated_sensor_token"])] = d["ego_pose_token"]
    for d in data:
        key = (scene_of.get(d.get("sample_token")), d["calibrated_sensor_token"])
        d["ego_pose_token"] = pose.get(key, d["ego_pose_token"])
    with open(os.path.join(out, version, "sample_data.json"), "w") as f:
        json.dump(data, f)


if __name__ == "__main__":
    main()
