"""PandaSet's moving objects (../shared/pandaset, skipped without it): each camera's time from
the LiDAR sweep's, each cuboid's velocity from the same object (uuid) in the nearest frames on
disk (the parked cars' exactly 0, a moving car's along its displacement), and each moving
cuboid's time from its returns' times."""

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def pandaset_dir() -> Path:
    shared = os.environ.get("PANOCONV_SHARED", "../shared")
    d = REPO / shared / "pandaset" / "002"
    if not (d / "camera").is_dir():
        required = os.environ.get("CI") == "true" or os.environ.get("PANOCONV_REQUIRE_SHARED") == "1"
        message = f"no PandaSet sequence at {d}"
        assert not required, message
        pytest.skip(message)
    return d


def test_pandaset_cameras_fire_before_the_sweep_s_time_and_cuboids_move_with_their_objects():
    pd = pytest.importorskip("pandas")
    from panoconv.sources.pandaset import PandaSet

    seq = pandaset_dir()
    source = PandaSet(seq)
    frame = source.read("20")
    # the cameras fire as the sweep passes them: up to 0.1 s before its time
    times = [c.time for c in frame.cameras]
    assert all(-0.11 < t <= 0.0 for t in times), times
    assert max(times) - min(times) > 0.03, times

    def centres(f):
        c = pd.read_pickle(seq / "annotations" / "cuboids" / f"{f}.pkl.gz")
        return c.set_index("uuid"), float(source.timestamps[int(f)])

    (before, t0), (here, t1), (after, t2) = centres("00"), centres("20"), centres("40")
    xyz = ["position.x", "position.y", "position.z"]
    parked = moving = 0
    for b in frame.boxes:
        row = here.loc[b.instance]
        if bool(row["stationary"]):
            # a parked car's annotation does not move between frames
            assert b.velocity is not None and np.linalg.norm(b.velocity) == 0.0, b.velocity
            parked += 1
        elif b.velocity is not None and b.instance in before.index and b.instance in after.index:
            # the centred difference over frames 00 and 40; a fast car's points along its
            # displacement from 00 to 20 (within 15 degrees) at a speed within 40 % of it (the cars accelerate)
            want = (after.loc[b.instance, xyz].to_numpy(float) - before.loc[b.instance, xyz].to_numpy(float)) / (t2 - t0)
            assert np.allclose(b.velocity, want, rtol=0, atol=1e-9), (b.velocity, want)
            v = np.asarray(b.velocity)
            if np.linalg.norm(v) > 5.0:
                step = (here.loc[b.instance, xyz].to_numpy(float) - before.loc[b.instance, xyz].to_numpy(float)) / (t1 - t0)
                cos = v @ step / (np.linalg.norm(v) * np.linalg.norm(step))
                assert cos > np.cos(np.radians(15)), (v, step)
                assert abs(np.linalg.norm(v) / np.linalg.norm(step) - 1) < 0.4, (v, step)
                moving += 1
    assert parked >= 20 and moving >= 5, (parked, moving)
    # a moving box holds when the sweep passed it (its returns' median time): within the
    # sweep, and mostly near the time of the camera facing it (which fires as the sweep passes)
    timed = [b for b in frame.boxes if b.time is not None]
    assert len(timed) >= 5 and all(-0.11 <= b.time <= 0.01 for b in timed), [b.time for b in timed]
    assert all(b.velocity is not None and np.any(b.velocity) for b in timed)
    lidar = np.asarray(frame.world_from_lidar)[:2, 3]

    def azimuth(v):
        return np.arctan2(v[1], v[0])

    axes = [(azimuth(np.asarray(c.world_from_camera)[:2, 2]), c.time) for c in frame.cameras]
    apart = []
    for b in timed:
        a = azimuth(np.asarray(b.centre, float)[:2] - lidar)
        gap, t = min((abs((a - x + np.pi) % (2 * np.pi) - np.pi), t) for x, t in axes)
        apart.append(abs(b.time - t))
    assert np.median(apart) < 0.02, apart
