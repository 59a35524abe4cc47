#!/usr/bin/env python3
"""Random cameras at training time: samples/s per core of a freshly drawn camera per sample,
panoconv's Python package against what a user writes without it.

Real KITTI frames (image_2, label_2) to a drawn 190° Kannala-Brandt fisheye, an equirect crop
and a cylindrical view at 640x480 (yaw, pitch, roll, principal point and lens drawn per sample):

- panoconv: `Warp(src, drawn)`: the table built for the drawn camera, the image, the mask and
  the exact labels (the defaults: supersample 8 through the source's pyramid; the command's
  antialiasing, a tap per source pixel, `antialias="taps"`; supersample 1: bilinear as
  cv2.remap);
- numpy + cv2: every pixel unprojected with numpy (Newton on the fisheye's polynomial),
  projected into the source, `cv2.remap` (bilinear, float maps), boxes from the 8 corners;
- cached: one table applied again and again (panoconv's `Warp.image`, `cv2.remap` with the
  precomputed float maps, and with the fixed-point maps of `cv2.convertMaps`).

Per core: one process, one thread (OpenCV single-threaded; benches/random_cameras.sh sets
OPENBLAS_NUM_THREADS and RAYON_NUM_THREADS to 1), CPU seconds (`time.process_time`), so other
load on the machine changes the figures less than wall time would (the load average is
printed). Every way runs once a round after an untimed first run, the rounds interleaved
(`--rounds`, 5): the rates are the rounds' medians, each ratio the median of its rounds'
ratios (with their range), since a run of 20 samples lasts a fraction of a second and the
machine's speed drifts between runs.

Then `RandomCameraDataset`: a 4-worker loader against 1 worker (wall time), the same arrays;
and, per core in the same interleaved rounds, the dataset at its defaults (`ds[i]`: the frame
read, its camera drawn, the image warped through the pyramid, the mask, the labels, the LiDAR
depth) against a numpy + cv2 dataset doing per sample what a user writes without panoconv:
the image read with `cv2.imread`, label_2 and calib parsed in Python, the scan read with
`np.fromfile`, the maps and `cv2.remap` above, the mask, the boxes from the 8 corners and a
sparse depth image (the scan in rect, projected into the drawn camera, the nearest point per
pixel with `np.minimum.at`, without panoconv's occlusion filter). The numpy side warps into
the very camera the dataset drew for the same index.

    benches/random_cameras.sh [--kitti DIR] [--samples N] [--rounds R] [--dataset-only]

(`--dataset-only`: the `RandomCameraDataset` part alone.)

builds the module in release, as `pip install .` does, and runs this with numpy and
opencv-python beside it; `PYTHONPATH=python python benches/random_cameras.py` runs it with the
Python tests' dev-profile module (scripts/install_python_package.sh). The first line names the
module that ran.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import statistics
import time
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np

import panoconv
from panoconv.random_cameras import CameraSampler, RandomCameraDataset, camera_of, sample_seed

REPO = Path(__file__).resolve().parents[1]
SIZE = (640, 480)

SAMPLERS = {
    "fisheye 190°": CameraSampler(
        model="kannala_brandt",
        fov_deg=190.0,
        circle=(1.0, 1.3),
        pitch_deg=(-10, 10),
        roll_deg=(-5, 5),
        yaw_deg=(-10, 10),
        principal_px=(-8, 8),
        params={"k": [(-0.03, 0.03), (-0.01, 0.01)]},
    ),
    "equirect crop": CameraSampler(
        model="equirect",
        fov_deg=(100, 140),
        pitch_deg=(-5, 5),
        roll_deg=(-5, 5),
        yaw_deg=(-10, 10),
        principal_px=(-8, 8),
    ),
    "cylindrical": CameraSampler(
        model="cylindrical",
        fov_deg=(90, 120),
        pitch_deg=(-5, 5),
        roll_deg=(-5, 5),
        yaw_deg=(-10, 10),
        principal_px=(-8, 8),
    ),
}


def load_frames(kitti: Path):
    split = kitti / "training"
    frames = []
    for frame in panoconv.Dataset(kitti, "training"):
        objs = [o for o in frame.labels if o.has_box_3d]
        frames.append(
            (frame.camera, panoconv.read_image(frame.image), frame.labels, objs, frame.id)
        )
    assert frames, f"no frames in {split}"
    return frames


# ---- the numpy + cv2 way ----------------------------------------------------------------


def bearings_numpy(cam, drawn):
    """Unit bearings (H, W, 3) in rect of every pixel of the drawn camera, NaN where none."""
    w, h = cam.size
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    fx, fy, cx, cy = drawn["fx"], drawn["fy"], drawn["cx"], drawn["cy"]
    a, b = (u - cx) / fx, (v - cy) / fy
    model = drawn["model"]
    if model == "kannala_brandt":
        k = (list(drawn["k"]) + [0.0] * 4)[:4]
        r = np.hypot(a, b)
        theta = r.copy()
        for _ in range(10):
            t2 = theta * theta
            f = theta * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))) - r
            df = 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])))
            theta -= f / df
        s = np.sin(theta) / np.where(r > 0, r, 1)
        d = np.stack([a * s, b * s, np.cos(theta)], axis=-1)
        d[theta > np.radians(drawn["max_fov_deg"]) / 2] = np.nan
    elif model == "equirect":
        d = np.stack([np.cos(b) * np.sin(a), np.sin(b), np.cos(b) * np.cos(a)], axis=-1)
    else:  # cylindrical
        d = np.stack([np.sin(a), b, np.cos(a)], axis=-1)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d @ cam.R.T


def maps_numpy(src, cam, drawn):
    d = bearings_numpy(cam, drawn)
    K = src.K
    z = d[..., 2]
    ok = z > 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        mx = np.where(ok, K[0, 0] * d[..., 0] / z + K[0, 2], -1e5)
        my = np.where(ok, K[1, 1] * d[..., 1] / z + K[1, 2], -1e5)
    mx[~np.isfinite(mx)] = -1e5
    my[~np.isfinite(my)] = -1e5
    return mx.astype(np.float32), my.astype(np.float32)


def project_numpy(cam, drawn, points):
    """Pixels (N, 2) of rect points in the drawn camera (NaN where none)."""
    p = (points - cam.C) @ cam.R
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    fx, fy, cx, cy = drawn["fx"], drawn["fy"], drawn["cx"], drawn["cy"]
    model = drawn["model"]
    if model == "kannala_brandt":
        k = (list(drawn["k"]) + [0.0] * 4)[:4]
        rho = np.hypot(x, y)
        theta = np.arctan2(rho, z)
        t2 = theta * theta
        r = theta * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
        s = np.where(rho > 0, r / np.where(rho > 0, rho, 1), 0)
        uv = np.stack([fx * x * s + cx, fy * y * s + cy], axis=1)
        uv[theta > np.radians(drawn["max_fov_deg"]) / 2] = np.nan
    elif model == "equirect":
        lon = np.arctan2(x, z)
        lat = np.arctan2(y, np.hypot(x, z))
        uv = np.stack([fx * lon + cx, fy * lat + cy], axis=1)
    else:
        lon = np.arctan2(x, z)
        uv = np.stack([fx * lon + cx, fy * y / np.hypot(x, z) + cy], axis=1)
    return uv


def boxes_numpy(cam, drawn, objs, corners=panoconv.box_corners):
    w, h = cam.size
    boxes = []
    for o in objs:
        uv = project_numpy(cam, drawn, corners(o))
        uv = uv[np.isfinite(uv).all(axis=1)]
        if len(uv) == 0:
            continue
        l, t = uv.min(axis=0)
        r, b = uv.max(axis=0)
        l, r = np.clip([l, r], 0, w - 1)
        t, b = np.clip([t, b], 0, h - 1)
        if r > l and b > t:
            boxes.append((l, t, r, b))
    return boxes


def numpy_sample(src, cam, drawn, image, objs):
    mx, my = maps_numpy(src, cam, drawn)
    out = cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    mask = (mx >= 0) & (mx <= src.width - 1) & (my >= 0) & (my <= src.height - 1)
    return out, mask, boxes_numpy(cam, drawn, objs)


# ---- a dataset the numpy + cv2 way: KITTI's files read and parsed per sample ---------------


def read_calib_numpy(path):
    """P2 (3x4), R0_rect (3x3) and Tr_velo_to_cam (3x4, None where absent) of a KITTI calib."""
    m = {}
    with open(path) as f:
        for line in f:
            key, _, values = line.partition(":")
            if values.strip():
                m[key.strip()] = np.array(values.split(), np.float64)
    tr = m.get("Tr_velo_to_cam")
    tr = None if tr is None else tr.reshape(3, 4)
    return m["P2"].reshape(3, 4), m["R0_rect"].reshape(3, 3), tr


def read_labels_numpy(path):
    """Classes and (N, 7) boxes (h, w, l, x, y, z, ry) of a label_2 file's objects with a 3D box
    (`type trunc occ alpha l t r b h w l x y z ry`; DontCare and placeholder rows left out)."""
    classes, boxes = [], []
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) < 15 or v[0] == "DontCare":
                continue
            box = [float(x) for x in v[8:15]]
            if min(box[:3]) > 0 and box[5] > -999:
                classes.append(v[0])
                boxes.append(box)
    return classes, np.array(boxes, np.float64).reshape(-1, 7)


def corners_numpy(box):
    """The 8 corners (8, 3) in rect of a label_2 box: bottom face first, then top."""
    h, w, l, x, y, z, ry = box
    s, c = np.sin(ry), np.cos(ry)
    xs = np.array([l, l, -l, -l, l, l, -l, -l]) / 2
    zs = np.array([w, -w, -w, w, w, -w, -w, w]) / 2
    ys = np.array([0, 0, 0, 0, -h, -h, -h, -h], np.float64)
    return np.stack([x + c * xs + s * zs, y + ys, z - s * xs + c * zs], axis=1)


def depth_numpy(P2, cam, drawn, rect, src_size):
    """HxW float32 metres (0: none) of rect points in the drawn camera: each pixel the nearest
    of the points landing on it. The distance is the drawn projection's own, as panoconv's
    `Warp.depth` writes it: the range |X - C| for a lens or an equirect, the cylinder's radius
    hypot(x, z) in the camera's axes for a cylindrical view (z along the optical axis for a
    pinhole). Points the source camera does not see in its image are left out, as panoconv
    does; panoconv's occlusion filter is not done here."""
    w, h = cam.size
    uv = project_numpy(cam, drawn, rect)
    p = (rect - cam.C) @ cam.R
    if drawn["model"] == "cylindrical":
        d = np.hypot(p[:, 0], p[:, 2])
    elif drawn["model"] == "perspective":
        d = p[:, 2]
    else:
        d = np.linalg.norm(p, axis=1)
    s = rect @ P2[:, :3].T + P2[:, 3]  # the source's pixels, homogeneous
    with np.errstate(invalid="ignore", divide="ignore"):
        su, sv = s[:, 0] / s[:, 2], s[:, 1] / s[:, 2]
        u, v = np.rint(uv[:, 0]), np.rint(uv[:, 1])
        ok = (
            (s[:, 2] > 0) & (su >= -0.5) & (su < src_size[0] - 0.5)
            & (sv >= -0.5) & (sv < src_size[1] - 0.5)
            & (u >= 0) & (u < w) & (v >= 0) & (v < h) & (d > 0)
        )
    depth = np.full(h * w, np.inf, np.float32)
    np.minimum.at(depth, (v[ok] * w + u[ok]).astype(np.intp), d[ok].astype(np.float32))
    depth[np.isinf(depth)] = 0
    return depth.reshape(h, w)


def numpy_dataset_sample(split, frame_id, cam, drawn):
    """One sample of a KITTI dataset in a drawn camera, numpy + cv2 only: the frame's files read
    and parsed, the image warped, the mask, the objects' 2D boxes and the LiDAR depth."""
    image = cv2.cvtColor(cv2.imread(str(split / "image_2" / f"{frame_id}.png")), cv2.COLOR_BGR2RGB)
    P2, R0, tr = read_calib_numpy(split / "calib" / f"{frame_id}.txt")
    classes, boxes_3d = read_labels_numpy(split / "label_2" / f"{frame_id}.txt")
    K = P2[:, :3]
    src = SimpleNamespace(K=K, width=image.shape[1], height=image.shape[0])
    # the drawn camera turns about the source's optical centre (P2 = K [I | -C])
    dst = SimpleNamespace(R=cam.R, C=-np.linalg.solve(K, P2[:, 3]), size=cam.size)
    mx, my = maps_numpy(src, dst, drawn)
    out = cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    mask = (mx >= 0) & (mx <= src.width - 1) & (my >= 0) & (my <= src.height - 1)
    boxes_2d = np.array(boxes_numpy(dst, drawn, boxes_3d, corners_numpy), np.float64)
    velodyne = split / "velodyne" / f"{frame_id}.bin"
    if tr is not None and velodyne.is_file():
        xyz = np.fromfile(velodyne, np.float32).reshape(-1, 4)[:, :3].astype(np.float64)
        rect_from_velo = R0 @ tr  # R0_rect · Tr_velo_to_cam, 3x4
        rect = xyz @ rect_from_velo[:, :3].T + rect_from_velo[:, 3]
        rect = rect[np.isfinite(rect).all(axis=1)]
        depth = depth_numpy(P2, dst, drawn, rect, (src.width, src.height))
    else:
        depth = np.zeros((cam.size[1], cam.size[0]), np.float32)
    return {
        "image": out,
        "mask": mask,
        "depth": depth,
        "boxes_2d": boxes_2d.reshape(-1, 4),
        "classes": np.array(classes, dtype=str),
        "boxes_3d": boxes_3d[:, [3, 4, 5, 0, 1, 2, 6]],  # x, y, z, h, w, l, ry: the dataset's
    }


# ---- measurements -----------------------------------------------------------------------


def per_core(fn, n):
    """Samples per CPU-second of `fn(i)` over i < n (one process, one thread)."""
    t = time.process_time()
    for i in range(n):
        fn(i)
    return n / (time.process_time() - t)


def bench_family(name, sampler, frames, n, rounds):
    draws = [sampler.draw(sample_seed(7, 0, i)) for i in range(n)]
    cams = [panoconv.random_cameras.camera_of(d) for d in draws]

    def ours(kw):
        # ({}: Warp's defaults, what docs/python.md's examples use)

        def run(i):
            src, image, labels, _, _ = frames[i % len(frames)]
            w = panoconv.Warp(src, cams[i], **kw)
            w.image(image), w.mask, w.labels(labels)

        return run

    def theirs(i):
        src, image, _, objs, _ = frames[i % len(frames)]
        numpy_sample(src, cams[i], draws[i], image, objs)

    ways = {
        "panoconv, defaults (pyramid)": ours({}),
        "panoconv, antialias='taps'": ours({"antialias": "taps"}),
        "panoconv, supersample 1": ours({"supersample": 1}),
        "numpy + cv2.remap": theirs,
    }
    # rounds of every way in turn: a change of the machine's speed between two ways' runs
    # moves one round's ratios, not the median's
    per_round = {k: [] for k in ways}
    # (a first run of each way, untimed: lazily built caches and the allocator's first pages)
    for fn in ways.values():
        per_core(fn, min(n, 3))
    for _ in range(rounds):
        for k, fn in ways.items():
            per_round[k].append(per_core(fn, n))
    rates = {k: statistics.median(v) for k, v in per_round.items()}
    base_rounds = per_round["numpy + cv2.remap"]
    ratios = {
        k: sorted(r / b for r, b in zip(v, base_rounds)) for k, v in per_round.items()
    }
    # one table kept: apply only
    src, image, _, _, _ = frames[0]
    warp = panoconv.Warp(src, cams[0], supersample=1).build()
    mx, my = maps_numpy(src, cams[0], draws[0])
    m1, m2 = cv2.convertMaps(mx, my, cv2.CV_16SC2)
    reps = 10 * n
    rates["cached: Warp.image"] = per_core(lambda i: warp.image(image), reps)
    # the default warp: each image's pyramid is built, then the table applied
    pyr = panoconv.Warp(src, cams[0]).build()
    rates["cached: Warp.image, pyramid"] = per_core(lambda i: pyr.image(image), reps)
    rates["cached: cv2.remap float maps"] = per_core(
        lambda i: cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT),
        reps,
    )
    rates["cached: cv2.remap fixed-point maps"] = per_core(
        lambda i: cv2.remap(image, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT),
        reps,
    )
    # the two ways see the same geometry: compare one sample's pixels where both have them
    ours_img = warp.image(image).astype(int)
    theirs_img, mask, _ = numpy_sample(src, cams[0], draws[0], image, [])
    both = mask & warp.mask
    diff = np.abs(ours_img - theirs_img.astype(int))[both].mean() if both.any() else float("nan")
    print(f"\n{name} ({n} drawn cameras, {warp.coverage:.0%} of the first one covered;"
          f" mean |panoconv - numpy way| {diff:.2f} grey levels where both sample)")
    for k, v in rates.items():
        rel = ""
        if k in ratios:
            r = ratios[k]
            rel = (f"  {statistics.median(r):5.2f}x the numpy way"
                   f" (rounds {r[0]:.2f}-{r[-1]:.2f})")
        print(f"  {k:38s} {v:9.1f} samples/s per core{rel}")
    cached = rates["cached: Warp.image"]
    for k in ("cached: cv2.remap float maps", "cached: cv2.remap fixed-point maps"):
        print(f"  Warp.image / {k[8:]}: {cached / rates[k]:.2f}x")
    return rates


def dataset_per_core(ds, samples, split, rounds):
    """`ds[i]` at its defaults against `numpy_dataset_sample`, per core, in interleaved rounds
    (bench_family's rule) over the indices of `samples` (the dataset's own samples, loaded
    already: they give each index's drawn camera and frame)."""
    n = len(samples)
    # the cameras the dataset drew, taken from its samples (untimed): the numpy side warps
    # into the same cameras, its time spent on the sample, not on the draw (a few
    # microseconds of Python, the same on both sides)
    draws = [x["camera"] for x in samples]
    cams = [camera_of(d) for d in draws]
    ids = [x["id"] for x in samples]
    indices = [x["index"] for x in samples]
    ways = {
        "RandomCameraDataset, defaults": lambda k: ds[indices[k]],
        "numpy + cv2 dataset": lambda k: numpy_dataset_sample(split, ids[k], cams[k], draws[k]),
    }
    base = "numpy + cv2 dataset"
    per_round = {k: [] for k in ways}
    for fn in ways.values():  # untimed first runs
        per_core(fn, min(n, 3))
    for _ in range(rounds):
        for k, fn in ways.items():
            per_round[k].append(per_core(fn, n))
    rates = {k: statistics.median(v) for k, v in per_round.items()}
    ratios = {
        k: sorted(r / b for r, b in zip(v, per_round[base])) for k, v in per_round.items()
    }
    # the same geometry: the first sample's pixels and depths where both have them
    ours, theirs = samples[0], numpy_dataset_sample(split, ids[0], cams[0], draws[0])
    both = ours["mask"] & theirs["mask"]
    grey = (np.abs(ours["image"].astype(int) - theirs["image"].astype(int))[both].mean()
            if both.any() else float("nan"))
    dboth = (ours["depth"] > 0) & (theirs["depth"] > 0)
    ddiff = (np.median(np.abs(ours["depth"] - theirs["depth"])[dboth])
             if dboth.any() else float("nan"))
    print(f"  per core, {n} samples:")
    for k, v in rates.items():
        rel = ""
        if k != base:
            r = ratios[k]
            rel = (f"  {statistics.median(r):5.2f}x the numpy way"
                   f" (rounds {r[0]:.2f}-{r[-1]:.2f})")
        print(f"  {k:38s} {v:9.1f} samples/s per core{rel}")
    print(f"  first sample, panoconv / numpy way: mean |difference| {grey:.2f} grey levels where"
          f" both sample (the pyramid against bilinear); depth at"
          f" {np.count_nonzero(ours['depth'])} / {np.count_nonzero(theirs['depth'])} pixels"
          f" (panoconv's occlusion filter drops points), median |difference| {ddiff:.3f} m"
          f" where both; {len(ours['boxes_2d'])} / {len(theirs['boxes_2d'])} boxes")
    return rates


def load(ds, indices, workers):
    if workers == 1:
        return [ds[i] for i in indices]
    with mp.get_context("fork").Pool(workers) as pool:
        return pool.map(ds.__getitem__, indices, chunksize=1)


def same(a, b):
    for x, y in zip(a, b):
        for k in x:
            if isinstance(x[k], np.ndarray):
                if x[k].shape != y[k].shape or not np.array_equal(x[k], y[k]):
                    return False
            elif x[k] != y[k]:
                return False
    return len(a) == len(b)


def loader(kitti, n, workers, rounds):
    sampler = CameraSampler(
        model=["kannala_brandt", "equirect", "cylindrical"],
        fov_deg=(100, 140),
        yaw_deg=(-10, 10),
        pitch_deg=(-5, 5),
        params={"kannala_brandt": {"k": [(-0.03, 0.03)]}},
    )
    ds = RandomCameraDataset(kitti, sampler, seed=1)  # the defaults: the pyramid
    indices = [i % len(ds) for i in range(n)]
    t = time.perf_counter()
    one = load(ds, indices, 1)
    t1 = time.perf_counter() - t
    t = time.perf_counter()
    many = load(ds, indices, workers)
    t2 = time.perf_counter() - t
    print(f"\nRandomCameraDataset over {len(ds)} real frames, {n} samples (image, mask, depth,"
          f" labels):")
    print(f"  1 worker: {n / t1:.1f} samples/s wall; {workers} workers: {n / t2:.1f} samples/s"
          f" wall; same arrays: {same(one, many)}")
    dataset_per_core(ds, one, kitti / ds.split, rounds)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kitti", type=Path, default=REPO.parent / "shared" / "kitti")
    ap.add_argument("--samples", type=int, default=20, help="drawn cameras per family")
    ap.add_argument("--workers", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=5,
                    help="interleaved rounds of every way; medians are printed")
    ap.add_argument("--dataset-only", action="store_true",
                    help="only RandomCameraDataset against the numpy dataset")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}"
          f" {os.getloadavg()[2]:.2f} on {os.cpu_count()} CPUs; numpy {np.__version__},"
          f" OpenCV {cv2.__version__}, panoconv {panoconv.__version__}"
          f" ({panoconv._native.__file__})")
    frames = load_frames(args.kitti)
    print(f"{len(frames)} real KITTI frames, drawn cameras at {SIZE[0]}x{SIZE[1]}")
    for name, sampler in SAMPLERS.items():
        if not args.dataset_only:
            bench_family(name, sampler, frames, args.samples, args.rounds)
    loader(args.kitti, 2 * args.samples, args.workers, args.rounds)


if __name__ == "__main__":
    main()
