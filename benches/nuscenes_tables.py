"""Writes v1.0-trainval-sized nuScenes tables around the synthetic scene, for the reader's
first-frame time and peak memory (benches/nuscenes_first_frame.sh).

Usage: nuscenes_tables.py FIXTURE OUT [SCENES]

OUT/v1.0-trainval/ holds the fixture's scene (with its files, linked) first, then SCENES - 1
(default 849) more scenes of 40 samples each, as v1.0-trainval has 850 scenes and 34 149
samples: per sample 12 keyframe readings (6 cameras, the LiDAR, 5 radars) and 65 sweeps
(LiDAR at 20 Hz, radars at 13 Hz, cameras at 12 Hz), each with its ego pose, and 34
annotations; records written as the official tables are (indented JSON), so that
sample_data.json is about 1.3 GB and ego_pose.json about 0.8 GB, as in the real version.
The generated scenes' files do not exist: only the first scene converts.
"""
import json
import os
import sys

fixture, out = sys.argv[1], sys.argv[2]
scenes = int(sys.argv[3]) if len(sys.argv) > 3 else 850
SAMPLES, SWEEPS, ANNOTATIONS = 40, 65, 34
version = os.path.join(out, "v1.0-trainval")
os.makedirs(version, exist_ok=True)
if not os.path.exists(os.path.join(out, "samples")):
    os.symlink(os.path.abspath(os.path.join(fixture, "samples")), os.path.join(out, "samples"))


def load(name):
    with open(os.path.join(fixture, "v1.0-mini", name + ".json")) as f:
        return json.load(f)


def tok(*parts):
    return "%032x" % (hash(parts) & ((1 << 128) - 1))


class Table:
    """Streams records into NAME.json as the official tables are indented."""

    def __init__(self, name):
        self.f = open(os.path.join(version, name + ".json"), "w")
        self.f.write("[\n")
        self.first = True

    def add(self, record):
        if not self.first:
            self.f.write(",\n")
        self.first = False
        self.f.write(json.dumps(record, indent=4))

    def close(self):
        self.f.write("\n]\n")
        self.f.close()


tables = {n: Table(n) for n in ["scene", "sample", "sample_data", "ego_pose", "sample_annotation", "instance"]}
for name in ["scene", "sample", "sample_data", "ego_pose", "sample_annotation", "instance"]:
    for r in load(name):
        tables[name].add(r)
channels = ["CAM_FRONT", "CAM_FRONT_RIGHT", "CAM_BACK_RIGHT", "CAM_BACK", "CAM_BACK_LEFT",
            "CAM_FRONT_LEFT", "LIDAR_TOP", "RADAR_FRONT", "RADAR_FRONT_LEFT", "RADAR_FRONT_RIGHT",
            "RADAR_BACK_LEFT", "RADAR_BACK_RIGHT"]
sensor, calibrated = load("sensor"), load("calibrated_sensor")
for channel in channels[7:]:
    sensor.append({"token": tok("sensor", channel), "channel": channel, "modality": "radar"})
    calibrated.append({"token": tok("calibrated", channel), "sensor_token": tok("sensor", channel),
                       "translation": [3.4, 0.0, 0.5], "rotation": [1.0, 0.0, 0.0, 0.0],
                       "camera_intrinsic": []})
by_sensor = {c["sensor_token"]: c["token"] for c in calibrated}
calibration_of = {r["channel"]: by_sensor[r["token"]] for r in sensor}
for name, records in [("sensor", sensor), ("calibrated_sensor", calibrated)]:
    with open(os.path.join(version, name + ".json"), "w") as f:
        json.dump(records, f, indent=4)
for name in ["category", "attribute", "visibility", "log", "map"]:
    with open(os.path.join(version, name + ".json"), "w") as f:
        json.dump(load(name), f, indent=4)
template_sd = next(r for r in load("sample_data") if "CAM_FRONT__" in r["filename"])
template_pose = load("ego_pose")[0]
template_ann = load("sample_annotation")[0]
template_inst = load("instance")[0]
for s in range(1, scenes):
    samples = [tok("sample", s, k) for k in range(SAMPLES)]
    tables["scene"].add({"token": tok("scene", s), "log_token": "", "nbr_samples": SAMPLES,
                         "first_sample_token": samples[0], "last_sample_token": samples[-1],
                         "name": "scene-%04d" % (s + 1), "description": "generated"})
    instances = [tok("instance", s, i) for i in range(ANNOTATIONS)]
    for i, t in enumerate(instances):
        tables["instance"].add(dict(template_inst, token=t, first_annotation_token="",
                                    last_annotation_token="", nbr_annotations=SAMPLES))
    for k, sample in enumerate(samples):
        time = 1_600_000_000_000_000 + s * 100_000_000 + k * 500_000
        tables["sample"].add({"token": sample, "timestamp": time,
                              "prev": samples[k - 1] if k else "",
                              "next": samples[k + 1] if k + 1 < SAMPLES else "",
                              "scene_token": tok("scene", s)})
        for j in range(len(channels) + SWEEPS):
            key = j < len(channels)
            channel = channels[j % len(channels)]
            pose = tok("pose", s, k, j)
            tables["ego_pose"].add(dict(template_pose, token=pose, timestamp=time + j))
            tables["sample_data"].add(dict(
                template_sd, token=tok("sd", s, k, j), sample_token=sample, ego_pose_token=pose,
                calibrated_sensor_token=calibration_of[channel],
                timestamp=time + j, is_key_frame=key, prev="", next="",
                filename="%s/%s/%s__%s__%d.jpg" % ("samples" if key else "sweeps", channel,
                                                   "n008-generated", channel, time + j)))
        for i, t in enumerate(instances):
            tables["sample_annotation"].add(dict(template_ann, token=tok("ann", s, k, i),
                                                 sample_token=sample, instance_token=t,
                                                 prev="", next=""))
for t in tables.values():
    t.close()
for name in sorted(os.listdir(version)):
    print("%-24s %8.1f MB" % (name, os.path.getsize(os.path.join(version, name)) / 1e6))
