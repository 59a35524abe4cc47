"""Rig sources written in Python (`panoconv.RigSource`, `convert_rig`): bad adapters fail as
the command would, naming the frame and the field; PandaSet (../shared/pandaset) converts with
its cuboids on the cars and its scan in the depth maps."""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

import panoconv
from conftest import REPO, command

SIZE = (64, 48)


def write_png(path: Path, rgb: tuple) -> None:
    """A flat 8-bit RGB PNG."""
    w, h = SIZE
    raw = b"".join(b"\x00" + bytes(rgb) * w for _ in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def camera_pose(yaw: float) -> np.ndarray:
    """world_from_camera of a level camera 1.6 m up, looking along world heading `yaw`."""
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    down = np.array([0.0, 0.0, -1.0])
    right = np.cross(down, forward)
    m = np.eye(4)
    m[:3, :3] = np.column_stack([right, down, forward])
    m[:3, 3] = [0.0, 0.0, 1.6]
    return m


class Toy(panoconv.RigSource):
    """Two cameras back to back, one car; `break_frame` spoils frame 1 as `spoil` says."""

    name = "toy"

    def __init__(self, root: Path, spoil=None, lens=None):
        self.root = root
        self.spoil = spoil
        self.lens = lens or panoconv.Camera.perspective(*SIZE, 30.0, 30.0, 31.5, 23.5)
        root.mkdir(exist_ok=True)
        for frame in ("0", "1"):
            for name, colour in (("front", (200, 40, 40)), ("back", (40, 40, 200))):
                write_png(root / f"{frame}_{name}.png", colour)

    def frames(self):
        return ["0", "1"]

    def read(self, frame_id):
        cameras = [
            panoconv.RigCamera(name, self.root / f"{frame_id}_{name}.png", self.lens, camera_pose(yaw))
            for name, yaw in (("front", 0.0), ("back", math.pi))
        ]
        car = panoconv.Box3D("Car", (8.0, 0.5, 0.75), (4.0, 1.8, 1.5), yaw=0.2, points=30)
        frame = panoconv.RigFrame(cameras, [car], lidar=np.zeros((0, 3)))
        if frame_id == "1" and self.spoil:
            self.spoil(frame)
        return frame


def convert(tmp_path: Path, source, *extra) -> tuple[int, Path]:
    out = tmp_path / "out"
    code = panoconv.convert_rig(source, out, ["--to", "equirect", "--pano-width", "256", "--quiet", *extra])
    return code, out


def test_a_python_source_converts_and_verifies(tmp_path):
    code, out = convert(tmp_path, Toy(tmp_path / "in"))
    assert code == 0
    assert panoconv.verify(out).ok
    labels = panoconv.read_labels(out / "training" / "label_2" / "0.txt")
    assert [l.type for l in labels] == ["Car"]
    # 8 m ahead of the front camera (the level frame's origin, z its heading), 0.5 m left
    x, y, z = labels[0].location
    assert abs(z - 8.0) < 1e-6 and abs(x + 0.5) < 1e-6 and abs(y - 1.6) < 1e-6
    assert panoconv.read_manifest(out)["command"] == "toy"


def test_shards_merge_resume_and_the_tools_work_on_a_python_source_s_output(tmp_path):
    from conftest import run

    source = Toy(tmp_path / "in")
    out = tmp_path / "out"
    for shard in ("0/2", "1/2"):
        args = ["--to", "equirect", "--pano-width", "256", "--quiet", "--shard", shard]
        assert panoconv.convert_rig(source, out, args) == 0
    r = run("merge", out)
    assert r.returncode == 0, r.stderr
    assert panoconv.verify(out).ok
    whole = tmp_path / "whole"
    assert panoconv.convert_rig(source, whole, ["--to", "equirect", "--pano-width", "256", "--quiet"]) == 0
    for sub in ("image_2", "label_2", "calib", "objects"):
        for f in (whole / "training" / sub).iterdir():
            assert f.read_bytes() == (out / "training" / sub / f.name).read_bytes(), f
    code = panoconv.convert_rig(source, whole, ["--to", "equirect", "--pano-width", "256", "--resume"])
    assert code == 0
    for tool in (["inspect", whole], ["preview", whole, "--frame", "0", "--output", tmp_path / "p.png"]):
        r = run(*tool)
        assert r.returncode == 0, (tool, r.stderr)
    exported = tmp_path / "exported"
    assert panoconv.convert_rig(source, exported, ["--to", "equirect", "--pano-width", "256", "--quiet", "--export", "coco"]) == 0
    assert list((exported / "annotations").glob("*.json")), sorted(p.name for p in exported.iterdir())


def test_mask_2_of_a_python_source_is_its_trusted_pixels_and_the_dataset_s_coverage(tmp_path):
    # --mask through convert_rig: mask_2 is source_2 below 64 (here, with no scan, a fixed
    # stitch: every covered pixel), and RandomCameraDataset takes it as the frame's coverage
    from panoconv.random_cameras import CameraSampler, RandomCameraDataset, source_coverage

    code, out = convert(tmp_path, Toy(tmp_path / "in"), "--mask")
    assert code == 0
    assert panoconv.verify(out).ok
    assert panoconv.read_manifest(out)["parameters"]["mask"] is True
    frames = panoconv.Dataset(out)
    assert len(frames) == 2
    for frame in frames:
        source = panoconv.read_image(frame.source_map)[..., 0]
        mask = panoconv.read_image(frame.mask)[..., 0] > 0
        assert np.array_equal(mask, source < 64)
        assert 0.05 < mask.mean() < 0.95  # two 60 deg cameras: a covered band, black elsewhere
        assert np.array_equal(source_coverage(frame), mask)
    sampler = CameraSampler(model=["perspective"], width=(64, 64), height=(48, 48),
                            fov_deg=(60, 60), yaw_deg=(-180, 180))
    x = RandomCameraDataset(out, sampler, seed=0)[0]
    assert not (x["mask"] & (x["image"] == 0).all(axis=2)).any()
    # without --mask there is none, and source_2 is the coverage
    (tmp_path / "plain").mkdir()
    code, plain = convert(tmp_path / "plain", Toy(tmp_path / "in"))
    assert code == 0 and panoconv.Dataset(plain)[0].mask is None


def test_fisheye_cameras_serve_and_a_turned_one_is_refused(tmp_path, capfd):
    fisheye = panoconv.Camera.kannala_brandt(*SIZE, 20.0, 20.0, 31.5, 23.5, [0.01, 0.0, 0.0, 0.0], max_fov_deg=190.0)
    code, out = convert(tmp_path, Toy(tmp_path / "in", lens=fisheye))
    assert code == 0, capfd.readouterr().err
    assert panoconv.verify(out).ok
    assert [l.type for l in panoconv.read_labels(out / "training" / "label_2" / "0.txt")] == ["Car"]
    turned = panoconv.Camera.perspective(*SIZE, 30.0, 30.0, 31.5, 23.5, yaw_deg=10.0)
    code, out = convert(tmp_path / "t", Toy(tmp_path / "in", lens=turned))
    err = capfd.readouterr().err
    assert code == 2 and "cameras[0].camera: a rig camera is in its own axes" in err, err
    assert not out.exists()


def boom(frame):
    raise ValueError("boom")


@pytest.mark.parametrize(
    "spoil, field",
    [
        (lambda f: setattr(f.boxes[0], "centre", (8.0, float("nan"), 0.75)), "boxes[0].centre[1]: \"nan\" is not a finite number"),
        (lambda f: setattr(f.boxes[0], "rotation", np.diag([1.0, 2.0, 1.0])), "boxes[0]: give either yaw or rotation"),
        (lambda f: (setattr(f.boxes[0], "yaw", None), setattr(f.boxes[0], "rotation", np.diag([1.0, 2.0, 1.0]))), "boxes[0].rotation: not a rotation"),
        (lambda f: setattr(f.cameras[1], "world_from_camera", np.eye(3)), "cameras[1].world_from_camera: an array of shape (3, 3)"),
        (lambda f: setattr(f, "lidar", np.zeros((5, 2))), "lidar: an array of shape [5,2]"),
        (lambda f: setattr(f.cameras[0], "image", "/nonexistent/front.png"), "cameras[0].image: /nonexistent/front.png is not a file"),
        (lambda f: setattr(f.boxes[0], "size", "big"), "boxes[0].size: not an array of numbers"),
        (lambda f: setattr(f, "record", {"when": object()}), "record: not JSON values"),
        (lambda f: boom(f), "read: read raised ValueError: boom (at test_rig_source.py:"),
    ],
)
def test_a_bad_frame_fails_alone_naming_the_frame_and_the_field(tmp_path, capfd, spoil, field):
    code, out = convert(tmp_path, Toy(tmp_path / "in", spoil))
    err = capfd.readouterr().err
    assert code == 1, err
    assert f"frame 1: {field}" in err, err
    written = {p.name for p in (out / "training" / "image_2").iterdir()}
    assert written == {"0.png"}
    assert not list(out.glob("training/*/1.*"))


def test_a_source_without_read_or_frames_is_a_set_up_error(tmp_path, capfd):
    class NoRead(panoconv.RigSource):
        def frames(self):
            return ["0"]

    class NoFrames:
        def read(self, frame_id):
            return None

    for source, method in ((NoRead(), "read(frame_id)"), (NoFrames(), "frames()")):
        code, out = convert(tmp_path, source)
        err = capfd.readouterr().err
        assert code == 2, err
        assert f"has no {method} method" in err, err
        assert not out.exists()


def test_options_help_and_usage_errors_are_the_command_s(tmp_path, capfd):
    code, out = convert(tmp_path, Toy(tmp_path / "in"), "--blend-width", "0")
    assert code == 2 and "--blend-width must be positive" in capfd.readouterr().err
    assert not out.exists()
    assert panoconv.convert_rig(Toy(tmp_path / "in"), tmp_path / "o", ["--to", "sideways"]) == 2
    r = subprocess.run([sys.executable, "-m", "panoconv", "pandaset", "--help"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for option in ("--input", "--lidar", "--pano-width", "--depth", "--shard", "--resume"):
        assert option in r.stdout, option
    r = subprocess.run([sys.executable, "-m", "panoconv", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "python -m panoconv pandaset --help" in r.stdout, r.stdout


# ------------------------------------------------------------------------------------------
# PandaSet (../shared/pandaset)


def pandaset_dir() -> Path:
    shared = os.environ.get("PANOCONV_SHARED", "../shared")
    d = REPO / shared / "pandaset" / "002"
    if not (d / "camera").is_dir():
        required = os.environ.get("CI") == "true" or os.environ.get("PANOCONV_REQUIRE_SHARED") == "1"
        message = f"no PandaSet sequence at {d}"
        assert not required, message
        pytest.skip(message)
    return d


@pytest.fixture(scope="module")
def pandaset(tmp_path_factory):
    pytest.importorskip("pandas")
    seq = pandaset_dir()
    out = tmp_path_factory.mktemp("pandaset") / "out"
    r = subprocess.run(
        [sys.executable, "-m", "panoconv", "pandaset", "--input", str(seq), "--to", "equirect",
         "--pano-width", "2048", "--depth", "--output", str(out)],
        capture_output=True, text=True, timeout=1200,
    )
    assert r.returncode == 0, r.stderr
    return seq, out, r.stderr


def test_pandaset_drops_the_car_s_own_returns(capfd):
    """The roof and the sensor's mount (the Pandar64's returns within a metre or two of it,
    1.35-1.6 m up in its pose frame) are not depth: the adapter drops them, `vehicle_box=None`
    keeps them, and nothing else goes."""
    pytest.importorskip("pandas")
    from panoconv.sources.pandaset import VEHICLE_BOX, PandaSet, pose_matrix

    seq = pandaset_dir()
    kept = PandaSet(seq, lidar="pandar64")
    every = PandaSet(seq, lidar="pandar64", vehicle_box=None)
    for frame in kept.frames():
        world_from_lidar = pose_matrix(kept.lidar_poses[int(frame)])
        a = kept.read(frame).lidar
        b = every.read(frame).lidar
        lidar_from_world = np.linalg.inv(world_from_lidar)

        def local(points):
            return points[:, :3] @ lidar_from_world[:3, :3].T + lidar_from_world[:3, 3]

        least, greatest = (np.array(c) for c in VEHICLE_BOX)
        inside = np.all((local(b) >= least) & (local(b) <= greatest), axis=1)
        # the car's body: several hundred returns a sweep, all within 2.5 m of the sensor
        assert inside.sum() > 400, (frame, inside.sum())
        assert np.linalg.norm(local(b)[inside], axis=1).max() < 2.5
        # exactly those go, the others stay in their order
        assert np.array_equal(a, b[~inside])
        assert not np.any(np.all((local(a) >= least) & (local(a) <= greatest), axis=1))
    # a bad box is refused by the command, before anything is written
    r = subprocess.run(
        [sys.executable, "-m", "panoconv", "pandaset", "--input", str(seq), "--to", "equirect",
         "--vehicle-box", "1,2,3", "--output", "/nonexistent/out"],
        capture_output=True, text=True, timeout=60,
    )
    assert r.returncode == 2 and "--vehicle-box '1,2,3'" in r.stderr, r.stderr


def rect_to_world(calib_path: Path) -> np.ndarray:
    for line in calib_path.read_text().splitlines():
        if line.startswith("Tr_rect_to_world:"):
            m = np.eye(4)
            m[:3, :] = np.array(line.split()[1:], dtype=float).reshape(3, 4)
            return m
    raise AssertionError(f"{calib_path}: no Tr_rect_to_world")


def pandaset_corners(row) -> np.ndarray:
    """PandaSet's own `geometry.center_box_to_corners` (its devkit, Apache-2.0)."""
    x, y, z = row["position.x"], row["position.y"], row["position.z"]
    dx, dy, dz, yaw = row["dimensions.x"] / 2, row["dimensions.y"] / 2, row["dimensions.z"] / 2, row["yaw"]
    corners = np.array([[dx, dy, -dz], [dx, -dy, -dz], [-dx, -dy, -dz], [-dx, dy, -dz],
                        [dx, dy, dz], [dx, -dy, dz], [-dx, -dy, dz], [-dx, dy, dz]])
    r = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    return corners @ r.T + [x, y, z]


def iou(a, b) -> float:
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    area = lambda r: (r[2] - r[0]) * (r[3] - r[1])  # noqa: E731
    return inter / (area(a) + area(b) - inter)


def record_corners(o: dict) -> np.ndarray:
    """The 8 corners (rect) of an object of objects/ID.json (centre, size: length, height,
    width; rotation: rect from box, row-major)."""
    r = np.array(o["rotation"]).reshape(3, 3)
    half = np.array(o["size"]) / 2
    signs = np.array([[i >> 0 & 1, i >> 1 & 1, i >> 2 & 1] for i in range(8)]) * 2 - 1
    return (signs * half) @ r.T + o["centre"]


def edge_box(corners: np.ndarray, camera) -> tuple | None:
    """The 2D box of a 3D box's 12 edges sampled every 1/400 of their length in `camera`
    (curved in a panorama); None for a box across the panorama's seam."""
    edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
    t = np.linspace(0.0, 1.0, 401)[:, None]
    points = np.concatenate([corners[a] + t * (corners[b] - corners[a]) for a, b in edges])
    uv, valid = camera.project(points)
    uv = uv[valid]
    if uv[:, 0].max() - uv[:, 0].min() > camera.width / 2:
        return None
    w, h = camera.size
    u0, v0 = np.clip(uv.min(axis=0), 0, None)
    u1, v1 = np.minimum(uv.max(axis=0), [w - 1, h - 1])
    return (u0, v0, u1, v1)


def one_to_one(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Each corner of `a`'s distance to its nearest of `b`, the nearest all distinct."""
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    assert len(set(d.argmin(axis=1))) == 8, d
    return d.min(axis=1)


def test_pandaset_writes_every_near_cuboid_once_on_its_car(pandaset):
    import json

    import pandas as pd

    from panoconv.rig import _count
    from panoconv.sources.pandaset import PandaSet

    seq, out, log = pandaset
    assert panoconv.verify(out).ok
    adapter = PandaSet(seq)
    assert adapter.frames() == ["00", "20", "40", "60"]
    assert "76 poses without an image of every chosen camera" in log, log  # the frames cut from the sequence, named
    checked = 0
    for frame in adapter.frames():
        split = out / "training"
        calib = panoconv.read_calib(split / "calib" / f"{frame}.txt")
        camera = calib.camera
        world = rect_to_world(split / "calib" / f"{frame}.txt")
        c2_world = world[:3, :3] @ camera.C + world[:3, 3]
        cuboids = pd.read_pickle(seq / "annotations" / "cuboids" / f"{frame}.pkl.gz")
        rows = {_count(str(u), ""): r for u, (_, r) in zip(cuboids["uuid"], cuboids.iterrows())}
        near = [b for b in adapter.boxes(cuboids) if np.linalg.norm(np.asarray(b.centre) - c2_world) <= 80.0]
        written = [o for o in json.loads((split / "objects" / f"{frame}.json").read_text())["objects"] if o["dropped"] is None]
        # every cuboid within 80 m written once (a 360° panorama sees them all)
        assert sorted(o["instance"] for o in written) == sorted(_count(b.instance, "") for b in near), frame
        labels = [l for l in panoconv.read_labels(split / "label_2" / f"{frame}.txt") if l.type != "DontCare"]
        assert len(labels) == len(written), frame
        for o in written:
            corners = record_corners(o) @ world[:3, :3].T + world[:3, 3]
            theirs = pandaset_corners(rows[o["instance"]])
            # PandaSet's own corners through the written Tr_rect_to_world: within 15 mm
            assert one_to_one(corners, theirs).max() < 0.015, (frame, o)
            # its label: label_2's two decimals (5 mm, 0.005 rad) from the exact box, and its 2D
            # box the exact projection of its 3D box
            label = min(labels, key=lambda l: np.linalg.norm(panoconv.box_corners(l).mean(axis=0) - record_corners(o).mean(axis=0)))
            half_diagonal = np.linalg.norm(o["size"]) / 2
            rounding = 0.005 * math.sqrt(3) + 0.0025 * math.sqrt(3) + 0.005 * half_diagonal
            assert one_to_one(panoconv.box_corners(label), record_corners(o)).max() < rounding + 1e-6, (frame, o)
            exact = edge_box(record_corners(o), camera)
            if exact is not None:  # (None: across the seam)
                assert iou(label.bbox, exact) >= 0.99, (frame, label.bbox, exact)
            checked += 1
    assert checked >= 100, checked


def test_pandaset_depth_holds_the_scan(pandaset):
    import pandas as pd

    seq, out, _ = pandaset
    frame = "20"
    calib = panoconv.read_calib(out / "training" / "calib" / f"{frame}.txt")
    camera = calib.camera
    world = rect_to_world(out / "training" / "calib" / f"{frame}.txt")
    scan = pd.read_pickle(seq / "lidar" / f"{frame}.pkl.gz")[["x", "y", "z"]].to_numpy()
    rect = (scan - world[:3, 3]) @ world[:3, :3]  # world → rect: Rᵀ(p − t)
    uv, valid = camera.project(rect)
    ranges = camera.distance(rect)
    ok = valid & camera.contains(uv)
    depth = panoconv.read_depth(out / "training" / "depth_2" / f"{frame}.png")
    px = np.rint(uv[ok]).astype(int)  # pixel centres at integers
    inside = (px[:, 0] < depth.shape[1]) & (px[:, 1] < depth.shape[0])
    nearest = np.full(depth.shape, np.inf)
    np.minimum.at(nearest, (px[inside, 1], px[inside, 0]), ranges[ok][inside])
    have = depth > 0
    assert have.sum() > 20000, have.sum()
    # each depth pixel is a return of the scan at that pixel, within 5 %
    rel = np.abs(depth[have] - nearest[have]) / nearest[have]
    assert np.isfinite(rel).mean() > 0.99
    assert np.mean(rel[np.isfinite(rel)] < 0.05) > 0.99, np.percentile(rel[np.isfinite(rel)], [50, 99])


# ------------------------------------------------------------------------------------------
# The adapter of docs/python.md, on a rig of its made-up format


def docs_adapter():
    """The class `AcmeRig` of docs/python.md's complete adapter, run as written there."""
    text = (REPO / "docs" / "python.md").read_text()
    code = text.split("### A complete adapter", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    namespace = {"__name__": "acme"}
    exec(compile(code, "docs/python.md", "exec"), namespace)
    return namespace["AcmeRig"]


def write_acme(root: Path, heading: float) -> dict:
    """Two frames of the made-up format: a vehicle at heading `heading` (world), a front and a
    rear camera 1.5 m up, one car 9 m ahead and 1 m to the left turned 0.3 rad in the vehicle
    frame, a flat ground scan."""
    import json

    turn = lambda yaw: np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]]) if yaw == 0 else np.array([[0, 0, -1], [1, 0, 0], [0, -1, 0]])  # noqa: E731
    cameras = {}
    for name, yaw, x in (("front", 0, 1.5), ("rear", 1, -0.5)):
        m = np.eye(4)
        m[:3, :3] = turn(yaw)
        m[:3, 3] = [x, 0.0, 1.5]
        cameras[name] = {"K": [30.0, 30.0, 31.5, 23.5], "size": list(SIZE), "vehicle_from_camera": m.tolist()}
    (root / "frames").mkdir(parents=True)
    (root / "calibration.json").write_text(json.dumps({"cameras": cameras}))
    ground = np.array([[x, y, 0.0, 0.5] for x in np.arange(-20, 20, 0.5) for y in np.arange(-20, 20, 0.5) if abs(x) + abs(y) > 3])
    for k in range(2):
        folder = root / "frames" / f"{k:04d}"
        folder.mkdir()
        world_from_vehicle = np.eye(4)
        c, s = math.cos(heading), math.sin(heading)
        world_from_vehicle[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        world_from_vehicle[:3, 3] = [100.0 + 2 * k * c, 50.0 + 2 * k * s, 3.0]
        np.savetxt(folder / "pose.txt", world_from_vehicle)
        for name, colour in (("front", (180, 60, 60)), ("rear", (60, 60, 180))):
            write_png(folder / f"{name}.png", colour)
        (folder / "objects.csv").write_text("car,9.0,1.0,0.75,4.0,1.8,1.5,0.3,7\ntree,5,5,3,1,1,6,0,8\n")
        np.save(folder / "points.npy", ground)
    return cameras


def test_the_adapter_of_the_docs_converts_and_verifies(tmp_path):
    AcmeRig = docs_adapter()
    root = tmp_path / "acme"
    write_acme(root, heading=0.7)
    out = tmp_path / "out"
    code = panoconv.convert_rig(AcmeRig(str(root)), out, ["--to", "equirect", "--pano-width", "256", "--depth", "--quiet"])
    assert code == 0
    assert panoconv.verify(out).ok
    manifest = panoconv.read_manifest(out)
    assert manifest["command"] == "acme"
    for frame in ("0000", "0001"):
        labels = panoconv.read_labels(out / "training" / "label_2" / f"{frame}.txt")
        assert [l.type for l in labels] == ["Car"]
        # the level frame is the front camera's: 1.5 m ahead of the vehicle's origin, 1.5 m up;
        # the car 7.5 m ahead of it, 1 m left, its heading 0.3 rad left of the camera's
        x, y, z = labels[0].location
        # (label_2's two decimals)
        assert abs(z - 7.5) < 0.005 and abs(x + 1.0) < 0.005 and abs(y - 1.5) < 0.005, labels[0].location
        # KITTI's rotation_y: −π/2 faces the camera's forward, less is turned to its left
        assert abs(labels[0].rotation_y - (-math.pi / 2 - 0.3)) < 0.005, labels[0].rotation_y
        world = rect_to_world(out / "training" / "calib" / f"{frame}.txt")
        # the label's bottom centre in the world: the format's car, 1.5 m up less its half height
        bottom = world[:3, :3] @ np.array([x, y, z]) + world[:3, 3]
        c, s = math.cos(0.7), math.sin(0.7)
        want = np.array([100.0 + 2 * int(frame) * c, 50.0 + 2 * int(frame) * s, 3.0]) + [9 * c - s, 9 * s + c, 0.0]
        assert np.linalg.norm(bottom - want) < 0.01, (bottom, want)
