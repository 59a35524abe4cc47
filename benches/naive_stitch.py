#!/usr/bin/env python3
"""The stitch a user writes in numpy + OpenCV in about 40 lines, for the cost comparison of
`benches/stitch.sh --nuscenes`: the cameras placed as benches/opencv_stitch_nuscenes.py places
them (panoconv's placement: each camera by its own keyframe's ego pose and calibration, in the
level frame of CAM_FRONT at the LIDAR_TOP keyframe), each output pixel's ray through the 10 m
proxy sphere around the mean of the camera centres, then per camera one `cv2.remap` of its image
with bilinear float32 maps at the output pixel centres (no prefilter where the output is
coarser than the source), and a feathered blend: a camera's weight is the smoothstep of the
angle from the pixel's ray to the camera's image border (pixels to the nearest edge over the
focal length) over 5 degrees. No exposure gains. Writes OUT/image_2/NNNNNN.png (the panorama)
and OUT/source_2/NNNNNN.png (each pixel's camera of largest weight, 255 none), as panoconv
writes them; nothing else (panoconv also writes labels, calib and objects records).

    naive_stitch.py --input DATAROOT --version v1.0-mini --output OUT [--jobs 1] [--width 2048]
"""
import argparse
import math
import os

import cv2
import numpy as np

from opencv_stitch import common_arguments, run
from opencv_stitch_nuscenes import read_samples

DISTANCE = 10.0  # proxy distance, metres
BLEND = math.radians(5.0)  # feather width, radians


def naive_stitch(job):
    rig, width, out, name = job
    height = width // 2
    f = width / (2 * math.pi)
    lon = (np.arange(width) - (width / 2 - 0.5)) / f
    lat = (np.arange(height) - (height / 2 - 0.5)) / f
    lon, lat = np.meshgrid(lon, lat)
    ray = np.stack([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)], -1)
    centre = np.mean([t[:3, 3] for _, t, _ in rig], axis=0)
    point = centre + DISTANCE * ray  # the proxy sphere, level frame
    num = np.zeros((height, width, 3), np.float32)
    den = np.zeros((height, width), np.float32)
    best = np.zeros((height, width), np.float32)
    source = np.full((height, width), 255, np.uint8)
    for k, (cam, level_from_cam, path) in enumerate(rig):
        img = cv2.imread(path, cv2.IMREAD_COLOR)
        cam_from_level = np.linalg.inv(level_from_cam)
        q = point @ cam_from_level[:3, :3].T + cam_from_level[:3, 3]
        front = q[..., 2] > 1e-6
        z = np.where(front, q[..., 2], 1.0)
        u = cam.fu * q[..., 0] / z + cam.cu
        v = cam.fv * q[..., 1] / z + cam.cv
        w_img, h_img = cam.size
        edge = np.minimum.reduce([u + 0.5, w_img - 0.5 - u, v + 0.5, h_img - 0.5 - v]) / cam.fu
        t = np.clip(edge / BLEND, 0.0, 1.0)
        weight = np.where(front, t * t * (3 - 2 * t), 0.0).astype(np.float32)
        remapped = cv2.remap(img, u.astype(np.float32), v.astype(np.float32), cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_CONSTANT)
        num += weight[..., None] * remapped
        den += weight
        source[weight > best] = k
        best = np.maximum(best, weight)
    pano = np.where(den[..., None] > 0, num / np.maximum(den, 1e-12)[..., None], 0)
    cv2.imwrite(os.path.join(out, "image_2", name), np.clip(np.rint(pano), 0, 255).astype(np.uint8))
    cv2.imwrite(os.path.join(out, "source_2", name), source)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--input")
    p.add_argument("--version", default="v1.0-mini")
    common_arguments(p)
    a = p.parse_args()
    run(naive_stitch, read_samples(a.input, a.version, a.width, a.output), a.jobs, a.output)


if __name__ == "__main__":
    main()
