#!/usr/bin/env python3
"""The OpenCV-Python baseline of issue 8: KITTI image_2 -> equirect, as a user would write it.

cv2.imread, cv2.remap with fixed-point maps (cv2.convertMaps to CV_16SC2, bilinear, black
outside), cv2.imwrite with OpenCV's default PNG settings, a multiprocessing Pool over frames.

Geometry is panoconv's (spec.md): fu = fv = fx of P2, tight canvas. The output K2 and size are
taken from a reference panoconv run over the distinct calibrations (--ref: its calib/K2 line and
its image_2 PNG header), so both converters write the same pixels' geometry; the map itself is
computed here: pixel (u, v) -> lambda = (u - cu)/fu, phi = (v - cv)/fv -> bearing
(cos phi sin lambda, sin phi, cos phi cos lambda) -> source pixel K (x/z, y/z).

    opencv_convert.py --input KITTI --output OUT --ref PANOCONV_OUT [--jobs N]
"""
import argparse
import os
import struct
import sys
from multiprocessing import Pool

import cv2
import numpy as np


def read_calib(path):
    rows = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                k, v = line.split(":", 1)
                rows[k.strip()] = v.split()
    return rows


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    return struct.unpack(">II", head[16:24])


def reference_cameras(ref):
    """P2 text -> (K2 3x3, width, height), from a panoconv output."""
    cams = {}
    for split in sorted(os.listdir(ref)):
        cdir = os.path.join(ref, split, "calib")
        if not os.path.isdir(cdir):
            continue
        for name in sorted(os.listdir(cdir)):
            c = read_calib(os.path.join(cdir, name))
            k2 = np.array([float(x) for x in c["K2"]]).reshape(3, 3)
            w, h = png_size(os.path.join(ref, split, "image_2", name[:-4] + ".png"))
            cams[" ".join(c["P2"])] = (k2, w, h)
    return cams


def equirect_maps(p2, k2, w, h):
    k = np.array([float(x) for x in p2]).reshape(3, 4)[:, :3]
    fu, cu, fv, cv = k2[0, 0], k2[0, 2], k2[1, 1], k2[1, 2]
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    lam, phi = (u - cu) / fu, (v - cv) / fv
    x, y, z = np.cos(phi) * np.sin(lam), np.sin(phi), np.cos(phi) * np.cos(lam)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = k[0, 0] * x / z + k[0, 1] * y / z + k[0, 2]
        ys = k[1, 1] * y / z + k[1, 2]
    bad = z <= 1e-9
    xs[bad] = -1e4
    ys[bad] = -1e4
    return cv2.convertMaps(xs.astype(np.float32), ys.astype(np.float32), cv2.CV_16SC2)


MAPS = {}


def init(maps):
    global MAPS
    MAPS = maps
    cv2.setNumThreads(1)  # one process per core does the parallelism


def convert(task):
    src, dst, key = task
    m1, m2 = MAPS[key]
    img = cv2.imread(src, cv2.IMREAD_COLOR)
    out = cv2.remap(img, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if not cv2.imwrite(dst, out):
        raise RuntimeError(f"cannot write {dst}")
    return os.path.getsize(dst)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--input", required=True)
    ap.add_argument("--output", required=True)
    ap.add_argument("--ref", required=True, help="a panoconv output of the same calibrations")
    ap.add_argument("--jobs", type=int, default=os.cpu_count())
    a = ap.parse_args()

    cams = reference_cameras(a.ref)
    maps, tasks = {}, []
    for split in sorted(os.listdir(a.input)):
        idir = os.path.join(a.input, split, "image_2")
        if not os.path.isdir(idir):
            continue
        odir = os.path.join(a.output, split, "image_2")
        os.makedirs(odir, exist_ok=True)
        for name in sorted(os.listdir(idir)):
            p2 = read_calib(os.path.join(a.input, split, "calib", name[:-4] + ".txt"))["P2"]
            key = " ".join(p2)
            if key not in maps:
                k2, w, h = cams[key]
                maps[key] = equirect_maps(p2, k2, w, h)
            tasks.append((os.path.join(idir, name), os.path.join(odir, name), key))
    with Pool(a.jobs, initializer=init, initargs=(maps,)) as pool:
        total = sum(pool.imap_unordered(convert, tasks, chunksize=4))
    print(f"{len(tasks)} frames, {total} bytes", file=sys.stderr)


if __name__ == "__main__":
    main()
