#!/usr/bin/env python3
"""The KITTI-360 stitch of `panoconv kitti360 --to equirect` in numpy + OpenCV, for the
throughput comparison of benches/stitch.sh.

It reads the same KITTI-360 layout (calibration/, data_poses/, data_2d_raw/), builds the same
model per frame (docs/kitti360.md, "Stitching"): the level frame, the output centre C2 (the mean
of the four camera centres), the proxy point at the stitch distance, the pinholes and the MEI
fisheyes with p1/p2 and their 185 deg field of view, the blend weights (field-of-view and
image-border margin over the local scale, smoothstep), the box prefilter where the output is
coarser than a source (nu x nv taps, as panoconv's remap tables), the exposure gains and the
weighted blend; cv2.remap does the resampling (float32 maps; within half a pixel of an image's
border its edge pixel, as panoconv's tables), cv2.imread / cv2.imwrite the files. Writes
OUT/image_2/NNNNNN.png and OUT/source_2/NNNNNN.png. The stitch of a placed rig
(`stitch_rig`) and the runner are shared with benches/opencv_stitch_nuscenes.py.

    opencv_stitch.py --input ROOT --sequence SEQ --output OUT [--frames 250,251] [--jobs 2]
        [--width 2048]
    opencv_stitch.py --compare A.png B.png      # PSNR of two images, dB

--jobs N runs N worker processes over the frames (multiprocessing, each cv2 single-threaded):
how a Python user spreads a per-frame job over N cores.
"""
import argparse
import math
import os
import re
import sys
import time
from multiprocessing import Pool

import cv2
import numpy as np

DISTANCE = 10.0  # --stitch-distance default, metres
BLEND = math.radians(5.0)  # --blend-width default
FISHEYE_FOV = math.radians(185.0)  # kitti360 default field of view of each fisheye
PROBE = 1e-4  # the turn that measures a camera's local scale, radians
MAX_SUPERSAMPLE = 8


def numbers(path, key):
    with open(path) as f:
        for line in f:
            if line.startswith(key + ":"):
                return np.array([float(x) for x in line.split(":", 1)[1].split()])
    raise SystemExit(f"{path}: no {key}")


def yaml_number(text, key):
    m = re.search(r"^\s*" + key + r":\s*([-+0-9.eE]+)", text, re.M)
    return float(m.group(1))


def homogeneous(m34):
    t = np.eye(4)
    t[:3, :4] = m34.reshape(3, 4)
    return t


class Pinhole:
    def __init__(self, fu, fv, cu, cv, size):
        self.fu, self.fv, self.cu, self.cv = fu, fv, cu, cv
        self.size = size
        self.max_theta = None

    def project(self, x, y, z):
        ok = z > 1e-12 * np.sqrt(x * x + y * y + z * z)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = self.fu * x / z + self.cu
            v = self.fv * y / z + self.cv
        return np.where(ok, u, np.nan), np.where(ok, v, np.nan)


class Mei:
    def __init__(self, path):
        text = open(path).read()
        self.xi = yaml_number(text, "xi")
        self.k1, self.k2 = yaml_number(text, "k1"), yaml_number(text, "k2")
        self.p1, self.p2 = yaml_number(text, "p1"), yaml_number(text, "p2")
        self.g1, self.g2 = yaml_number(text, "gamma1"), yaml_number(text, "gamma2")
        self.u0, self.v0 = yaml_number(text, "u0"), yaml_number(text, "v0")
        self.size = (int(yaml_number(text, "image_width")), int(yaml_number(text, "image_height")))
        self.max_theta = FISHEYE_FOV / 2

    def project(self, x, y, z):
        n = np.sqrt(x * x + y * y + z * z)
        sx, sy, sz = x / n, y / n, z / n
        den = sz + self.xi
        ok = (np.arctan2(np.hypot(sx, sy), sz) <= self.max_theta) & (den > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = sx / den, sy / den
        r2 = a * a + b * b
        radial = 1.0 + r2 * (self.k1 + self.k2 * r2)
        xd = a * radial + 2.0 * self.p1 * a * b + self.p2 * (r2 + 2.0 * a * a)
        yd = b * radial + self.p1 * (r2 + 2.0 * b * b) + 2.0 * self.p2 * a * b
        u = self.g1 * xd + self.u0
        v = self.g2 * yd + self.v0
        return np.where(ok, u, np.nan), np.where(ok, v, np.nan)


def read_rig(root, seq):
    cal = os.path.join(root, "calibration")
    persp = os.path.join(cal, "perspective.txt")
    c2p = os.path.join(cal, "calib_cam_to_pose.txt")
    cams = []
    for k in range(4):
        mount = homogeneous(numbers(c2p, f"image_0{k}"))
        if k < 2:
            size = tuple(int(s) for s in numbers(persp, f"S_rect_0{k}"))
            p = numbers(persp, f"P_rect_0{k}")
            model = Pinhole(p[0], p[5], p[2], p[6], size)
            r_rect = np.eye(4)
            r_rect[:3, :3] = numbers(persp, f"R_rect_0{k}").reshape(3, 3)
            mount = mount @ np.linalg.inv(r_rect)
            folder = os.path.join(root, "data_2d_raw", seq, f"image_0{k}", "data_rect")
        else:
            model = Mei(os.path.join(cal, f"image_0{k}.yaml"))
            folder = os.path.join(root, "data_2d_raw", seq, f"image_0{k}", "data_rgb")
        cams.append((model, mount, folder))
    poses = {}
    with open(os.path.join(root, "data_poses", seq, "poses.txt")) as f:
        for line in f:
            v = line.split()
            if len(v) == 13:
                poses[int(v[0])] = homogeneous(np.array([float(x) for x in v[1:]]))
    return cams, poses


def level_from_world(world_from_cam0):
    """The level frame: origin at image_00's centre, y = world -z, z = image_00's optical axis
    on the horizontal plane, x = y x z."""
    y = np.array([0.0, 0.0, -1.0])
    axis = world_from_cam0[:3, 2]
    z = axis - axis.dot(y) * y
    z /= np.linalg.norm(z)
    x = np.cross(y, z)
    t = np.eye(4)
    t[:3, :3] = np.stack([x, y, z], axis=1)
    t[:3, 3] = world_from_cam0[:3, 3]
    return np.linalg.inv(t)


def smoothstep(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def samples(model, rot, trans, centre, d):
    """Camera point q and pixel of the proxy points of bearings d (3 x N)."""
    x = centre[:, None] + d * DISTANCE
    q = rot @ x + trans[:, None]
    if model.max_theta is not None:
        outside = np.arctan2(np.hypot(q[0], q[1]), q[2]) > model.max_theta
        q[:, outside] = np.nan
    u, v = model.project(q[0], q[1], q[2])
    return q, u, v


def weights(model, q, u, v):
    """w = S(min(1, m / b)), m the smaller of the field-of-view margin and the border's
    distance over the local scale (the larger displacement of q turned by PROBE about two
    perpendicular axes)."""
    w_img, h_img = model.size
    n = q / np.linalg.norm(q, axis=0)
    helper = np.where(np.abs(n[0]) < 0.9, 0, 1)
    e = np.zeros_like(n)
    e[helper, np.arange(n.shape[1])] = 1.0
    a = np.cross(n.T, e.T).T
    a /= np.linalg.norm(a, axis=0)
    b = np.cross(n.T, a.T).T
    scale = np.zeros(n.shape[1])
    c, s = math.cos(PROBE), math.sin(PROBE)
    for axis in (a, b):
        turned = n * c + np.cross(axis.T, n.T).T * s  # axis is perpendicular to n
        tu, tv = model.project(turned[0], turned[1], turned[2])
        step = np.hypot(tu - u, tv - v) / PROBE
        scale = np.fmax(scale, step)
    border = np.minimum.reduce([u + 0.5, w_img - 0.5 - u, v + 0.5, h_img - 0.5 - v])
    with np.errstate(divide="ignore", invalid="ignore"):
        m = border / scale
    if model.max_theta is not None:
        m = np.minimum(m, model.max_theta - np.arctan2(np.hypot(q[0], q[1]), q[2]))
    w = smoothstep(m / BLEND)
    return np.where(np.isfinite(w) & (scale > 0) & (m > 0), w, 0.0)


def taps(u, v):
    """Supersampling counts (nu, nv) per pixel: the source pixels one output step spans (a
    central difference of the maps, one-sided where a neighbour has no image), rounded, 1
    below 1.5."""

    def count(s2):
        s2 = np.where(np.isfinite(s2), s2, 0.0)
        n = np.where(s2 >= 2.25, np.round(np.sqrt(s2)), 1)
        return np.clip(n, 1, MAX_SUPERSAMPLE).astype(np.int32)

    def across(u, v, ax):
        up = np.pad(u, 1, constant_values=np.nan)
        vp = np.pad(v, 1, constant_values=np.nan)
        sl = (slice(1, -1), slice(1, -1))
        if ax == 1:
            a, b = (slice(1, -1), slice(0, -2)), (slice(1, -1), slice(2, None))
        else:
            a, b = (slice(0, -2), slice(1, -1)), (slice(2, None), slice(1, -1))
        ua, va, ub, vb, uc, vc = up[a], vp[a], up[b], vp[b], up[sl], vp[sl]
        both = ((ub - ua) ** 2 + (vb - va) ** 2) / 4
        only_a = (uc - ua) ** 2 + (vc - va) ** 2
        only_b = (ub - uc) ** 2 + (vb - vc) ** 2
        fa, fb = np.isfinite(ua), np.isfinite(ub)
        s2 = np.where(fa & fb, both, np.where(fa, only_a, np.where(fb, only_b, 0.0)))
        return count(s2)

    return across(u, v, 1), across(u, v, 0)


def source_map(img, u, v):
    """cv2.remap's map of source points (u, v) as panoconv's tables sample them: within half a
    pixel of the border the edge pixel is repeated, beyond it (or without a point) black."""
    h, w = img.shape[:2]
    inside = (u >= -0.5) & (u < w - 0.5) & (v >= -0.5) & (v <= h - 0.5)
    mx = np.where(inside, np.clip(u, 0, w - 1), -1e4).astype(np.float32)
    my = np.where(inside, np.clip(v, 0, h - 1), -1e4).astype(np.float32)
    return mx, my


def gather(img, su, sv):
    """Bilinear samples of img at the points (su, sv) (cv2.remap of a map 1024 wide: its maps
    must be under 32767 a side)."""
    n = su.size
    rows = -(-n // 1024)
    mx = np.full(rows * 1024, -1e4, np.float32)
    my = np.full(rows * 1024, -1e4, np.float32)
    mx[:n], my[:n] = source_map(img, su, sv)
    out = cv2.remap(img, mx.reshape(rows, 1024), my.reshape(rows, 1024), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT)
    return out.reshape(-1, 3)[:n].astype(np.float64)


def stitch_frame(job):
    """One KITTI-360 frame: the rig at the frame's pose, in the level frame of image_00."""
    out, frame, width, cams, pose = job
    world_from = [pose @ mount for _, mount, _ in cams]
    level = level_from_world(world_from[0])
    rig = [(model, level @ w, os.path.join(folder, f"{frame:010d}.png"))
           for (model, _, folder), w in zip(cams, world_from)]
    stitch_rig(rig, width, out, f"{frame:06d}.png")
    return frame


def stitch_rig(rig, width, out, name):
    """Stitches the cameras of `rig`, (model, level_from_camera 4x4, image file) each, into a
    width x width/2 equirect around the mean of their centres; writes OUT/image_2/NAME (the
    panorama) and OUT/source_2/NAME (each pixel's camera by its place in `rig`, 255 none)."""
    height = width // 2
    f = width / (2 * math.pi)
    cx, cy = width / 2 - 0.5, height / 2 - 0.5
    level_from = [t for _, t, _ in rig]
    centre = np.mean([t[:3, 3] for t in level_from], axis=0)
    cam_from = [np.linalg.inv(t) for t in level_from]
    uu, vv = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))

    def bearings(pu, pv):
        lon, lat = (pu - cx) / f, (pv - cy) / f
        cl = np.cos(lat)
        return np.stack([cl * np.sin(lon), np.sin(lat), cl * np.cos(lon)])

    d = bearings(uu.ravel(), vv.ravel())
    remapped, ws = [], []
    for (model, _, path), t in zip(rig, cam_from):
        img = cv2.imread(path, cv2.IMREAD_COLOR)
        if img is None:
            raise SystemExit(f"{path}: not an image")
        rot, trans = t[:3, :3], t[:3, 3]
        q, u, v = samples(model, rot, trans, centre, d)
        w = weights(model, q, u, v).reshape(height, width)
        u, v = u.reshape(height, width), v.reshape(height, width)
        nu, nv = taps(u, v)
        # one bilinear tap a pixel: a plain cv2.remap of the whole map
        mx, my = source_map(img, u, v)
        acc = cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        acc = acc.astype(np.float64)
        seen = w > 0
        for a in np.unique(nu[seen]):
            for b in np.unique(nv[seen & (nu == a)]):
                sel = seen & (nu == a) & (nv == b)
                if (a, b) == (1, 1):
                    continue
                pu, pv = uu[sel], vv[sel]
                total = np.zeros((pu.size, 3))
                whole = np.ones(pu.size, bool)
                for j in range(b):
                    for i in range(a):
                        du, dv = (i + 0.5) / a - 0.5, (j + 0.5) / b - 0.5
                        _, su, sv = samples(model, rot, trans, centre, bearings(pu + du, pv + dv))
                        total += gather(img, su, sv)
                        whole &= source_map(img, su, sv)[0] > -1e3
                acc[sel] = total / (a * b)
                # a pixel the image covers only in part gives nothing (its taps beyond are black)
                w[sel] = np.where(whole, w[sel], 0.0)
        remapped.append(np.clip(np.rint(acc), 0, 255).astype(np.uint8))
        ws.append(w)
    gains = exposure_gains(remapped, ws)
    num = np.zeros((height, width, 3))
    den = np.zeros((height, width))
    for img, w, g in zip(remapped, ws, gains):
        num += (w * g)[..., None] * img
        den += w
    with np.errstate(divide="ignore", invalid="ignore"):
        pano = np.where(den[..., None] > 0, num / den[..., None], 0)
    pano = np.clip(np.floor(pano + 0.5), 0, 255).astype(np.uint8)
    stack = np.stack(ws)
    source = np.where(stack.max(axis=0) > 0, stack.argmax(axis=0), 255).astype(np.uint8)
    cv2.imwrite(os.path.join(out, "image_2", name), pano)
    cv2.imwrite(os.path.join(out, "source_2", name), source)


def exposure_gains(remapped, ws):
    n = len(remapped)
    seen = [w > 0 for w in ws]
    levels = [img.astype(np.int64).sum(axis=2) for img in remapped]
    count = np.zeros((n, n))
    mean = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            if i != j:
                both = seen[i] & seen[j]
                count[i, j] = both.sum()
                if count[i, j]:
                    mean[i, j] = levels[i][both].sum() / (3.0 * count[i, j])
    total = sum(count[i, j] for i in range(n) for j in range(i + 1, n))
    mu = 1e-6 * max(total, 1)
    a = np.eye(n) * mu
    for i in range(n):
        for j in range(n):
            if i != j and count[i, j] > 0:
                a[i, i] += count[i, j] * mean[i, j] ** 2
                a[i, j] -= count[i, j] * mean[i, j] * mean[j, i]
    try:
        g = np.linalg.solve(a, np.full(n, mu))
    except np.linalg.LinAlgError:
        return np.ones(n)
    g = g / g[0]
    return g if np.all(np.isfinite(g) & (g > 0)) else np.ones(n)


def psnr(a, b):
    x, y = cv2.imread(a), cv2.imread(b)
    mse = np.mean((x.astype(np.float64) - y.astype(np.float64)) ** 2)
    return 999.0 if mse == 0 else 10 * math.log10(255.0**2 / mse)  # 999: identical


def init_worker():
    cv2.setNumThreads(1)


def run(worker, jobs, processes, out):
    """Runs worker over jobs on `processes` worker processes (each cv2 single-threaded), into
    OUT/image_2 and OUT/source_2; reports the time on stderr."""
    for sub in ("image_2", "source_2"):
        os.makedirs(os.path.join(out, sub), exist_ok=True)
    start = time.perf_counter()
    if processes > 1:
        with Pool(processes, initializer=init_worker) as pool:
            list(pool.imap_unordered(worker, jobs))
    else:
        cv2.setNumThreads(1)
        for j in jobs:
            worker(j)
    print(f"{len(jobs)} frames in {time.perf_counter() - start:.2f} s", file=sys.stderr)


def common_arguments(p):
    """The options every stitch script takes: output, worker count, width, --compare."""
    p.add_argument("--output")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--width", type=int, default=2048)
    p.add_argument("--compare", nargs=2)


def compare(a):
    """Prints the PSNR of --compare's two images and says whether that was asked."""
    if a.compare:
        print(f"{psnr(*a.compare):.2f}")
    return bool(a.compare)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--input")
    p.add_argument("--sequence")
    p.add_argument("--frames")
    common_arguments(p)
    a = p.parse_args()
    if compare(a):
        return
    cams, poses = read_rig(a.input, a.sequence)
    frames = [int(x) for x in a.frames.split(",")] if a.frames else sorted(poses)
    jobs = [(a.output, fr, a.width, cams, poses[fr]) for fr in frames]
    run(stitch_frame, jobs, a.jobs, a.output)


if __name__ == "__main__":
    main()
