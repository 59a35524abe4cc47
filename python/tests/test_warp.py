"""`Warp` against the command: for the same source and target cameras, the in-memory image,
mask, labels and depth equal the files `panoconv kitti` writes (one test per projection family
and two lens models, on a real KITTI frame); other pixel formats through the same taps; the
constructors against description files; the depth-map reader."""

from __future__ import annotations

import json

import numpy as np
import pytest

import panoconv

from conftest import FISHEYE, kitti_dir, run

FRAME = "000001"

MEI = {
    "version": 1,
    "model": "mei",
    "width": 800,
    "height": 600,
    "max_fov_deg": 185,
    "fx": 510.3,
    "fy": 509.7,
    "cx": 401.2,
    "cy": 298.9,
    "xi": 1.21,
    "k": [-0.09, 0.02],
    "p": [0.0004, -0.0003],
    "rotation": {"yaw_deg": 4, "pitch_deg": -6, "roll_deg": 1},
}


def convert(tmp_path, *args):
    out = tmp_path / "out"
    r = run(
        "kitti", "--input", kitti_dir(), "--output", out, "--quiet", "--split", "training",
        "--frames", FRAME, "--mask", "--depth", *args,
    )
    assert r.returncode == 0, r.stderr
    return out / "training"


def source():
    split = kitti_dir() / "training"
    calib = panoconv.read_calib(split / "calib" / f"{FRAME}.txt")
    return split, calib, calib.camera


def assert_same_as_the_command(out, dst):
    split, calib, src = source()
    warp = panoconv.Warp(src, dst, antialias="command")  # the command's antialiasing
    written = panoconv.read_calib(out / "calib" / f"{FRAME}.txt").camera
    assert (dst.size, dst.projection, dst.model) == (written.size, written.projection, written.model)
    image = warp.image(panoconv.read_image(split / "image_2" / f"{FRAME}.png"))
    want = panoconv.read_image(out / "image_2" / f"{FRAME}.png")
    assert image.shape == want.shape and image.dtype == np.uint8
    assert np.array_equal(image, want), f"{(image != want).any(axis=2).sum()} pixels differ"
    mask = panoconv.read_image(out / "mask_2" / f"{FRAME}.png")[:, :, 0] > 0
    assert np.array_equal(warp.mask, mask)
    assert mask.mean() > 0.02
    labels = warp.labels(panoconv.read_labels(split / "label_2" / f"{FRAME}.txt"))
    lines = [l.split() for l in (out / "label_2" / f"{FRAME}.txt").read_text().splitlines()]
    assert [l.tokens for l in labels] == lines
    assert len(lines) >= 2
    scan = split / "velodyne" / f"{FRAME}.bin"
    points = panoconv.read_velodyne(scan, calib)
    depth = warp.depth(points)
    # the scan's points taken as the file is read: the same map, filter on and off
    assert np.array_equal(warp.depth_velodyne(scan, calib), depth)
    assert np.array_equal(
        warp.depth_velodyne(scan, calib, occlusion=False), warp.depth(points, occlusion=False)
    )
    written_depth = panoconv.read_depth(out / "depth_2" / f"{FRAME}.png")
    want16 = np.round(written_depth * 256)
    assert np.array_equal(np.clip(np.round(depth * 256), 0, 65535), want16)
    assert (want16 > 0).sum() > 1000
    return warp


def test_perspective(tmp_path):
    out = convert(tmp_path, "--to", "perspective", "--px-per-deg", "9")
    dst = panoconv.read_calib(out / "calib" / f"{FRAME}.txt").camera
    assert_same_as_the_command(out, dst)


def test_equirect(tmp_path):
    out = convert(tmp_path, "--to", "equirect")
    dst = panoconv.read_calib(out / "calib" / f"{FRAME}.txt").camera
    assert_same_as_the_command(out, dst)


def test_cylindrical(tmp_path):
    out = convert(tmp_path, "--to", "cylindrical", "--crop", "100,20,900,300", "--resize", "640x240")
    dst = panoconv.read_calib(out / "calib" / f"{FRAME}.txt").camera
    assert_same_as_the_command(out, dst)


def test_kannala_brandt_fisheye(tmp_path):
    path = tmp_path / "kb.json"
    path.write_text(json.dumps(FISHEYE))
    out = convert(tmp_path, "--to", "fisheye", "--camera", path)
    f = FISHEYE
    rot = f["rotation"]
    dst = panoconv.Camera.kannala_brandt(
        f["width"], f["height"], f["fx"], f["fy"], f["cx"], f["cy"], f["k"],
        yaw_deg=rot["yaw_deg"], pitch_deg=rot["pitch_deg"], roll_deg=rot["roll_deg"],
        max_fov_deg=f["max_fov_deg"],
    )
    assert np.array_equal(dst.R, panoconv.read_camera(path).R)
    assert np.array_equal(dst.K, panoconv.read_camera(path).K)
    assert_same_as_the_command(out, dst)


def test_mei_fisheye(tmp_path):
    path = tmp_path / "mei.json"
    path.write_text(json.dumps(MEI))
    out = convert(tmp_path, "--to", "fisheye", "--camera", path)
    m, rot = MEI, MEI["rotation"]
    dst = panoconv.Camera.mei(
        m["width"], m["height"], m["fx"], m["fy"], m["cx"], m["cy"], m["xi"], k=m["k"],
        p=m["p"], max_fov_deg=m["max_fov_deg"], **rot,
    )
    assert dst.model == "mei" and dict(dst.parameters)["xi"] == m["xi"]
    # read_camera with a centre: the camera file's axes, that optical centre
    _, calib, src = source()
    placed = panoconv.read_camera(path, centre=tuple(src.C))
    assert np.array_equal(placed.C, src.C) and np.array_equal(placed.R, dst.R)
    warp = assert_same_as_the_command(out, placed)
    assert np.array_equal(warp.dst.C, src.C)


def test_other_pixel_formats_take_the_same_taps():
    split, _, src = source()
    rgb = panoconv.read_image(split / "image_2" / f"{FRAME}.png")
    dst = panoconv.Camera.equidistant if False else panoconv.Camera.radial(
        "equidistant", 320, 240, 90.0, 90.0, 159.5, 119.5, pitch_deg=-4, max_fov_deg=190
    )
    warp = panoconv.Warp(src, dst)
    want = warp.image(rgb)
    # one channel, four channels, a strided view: the 8-bit RGB kernel's bytes per channel
    assert np.array_equal(warp.image(np.ascontiguousarray(rgb[:, :, 1])), want[:, :, 1])
    rgba = np.dstack([rgb, rgb[:, :, :1]])
    assert np.array_equal(warp.image(rgba), np.dstack([want, want[:, :, :1]]))
    assert np.array_equal(warp.image(rgb[:, :, ::-1]), want[:, :, ::-1])
    # 16-bit: the same weights in integers (x257 is exact; each of the 8-bit pyramid's levels
    # and the result are rounded to 8 bits: within 0.5 + 0.5 grey level, 257 x 16-bit units)
    wide = warp.image(rgb.astype(np.uint16) * 257)
    assert wide.dtype == np.uint16 and np.abs(wide.astype(int) - want.astype(int) * 257).max() <= 258
    # float: the exact weighted mean of exact pyramid means, which the 8-bit kernel rounds
    # (its pyramid's levels rounded too: within 0.5 + 0.5)
    flt = warp.image(rgb.astype(np.float32))
    assert flt.dtype == np.float32 and np.abs(flt - want).max() <= 1.0 + 1e-4
    assert np.abs(np.round(flt) - want).max() <= 1
    # with a tap per source pixel (no pyramid) the float result is within the kernel's rounding
    taps = panoconv.Warp(src, dst, antialias="taps")
    flt = taps.image(rgb.astype(np.float32))
    assert np.abs(flt - taps.image(rgb)).max() <= 0.5 + 1e-4
    # outside the source: black, and not in the mask
    assert (want[~warp.mask] == 0).mean() > 0.99
    with pytest.raises(ValueError, match="1242x375"):
        warp.image(rgb[:100])
    with pytest.raises(TypeError, match="uint8, uint16 or float32"):
        warp.image(rgb.astype(np.int64))


def test_the_table_is_built_once_and_kept():
    _, _, src = source()
    dst = panoconv.Camera.equirect(320, 200, 120.0, 120.0, 159.5, 99.5, yaw_deg=10)
    warp = panoconv.Warp(src, dst)
    assert not warp.built
    labels = warp.labels([])  # labels need no table
    assert labels == [] and not warp.built
    assert warp.build() is warp and warp.built
    # a turned camera is the unturned one with its bearings turned
    straight = panoconv.Camera.equirect(320, 200, 120.0, 120.0, 159.5, 99.5)
    rays = straight.unproject(np.array([[10.0, 20.0], [300.0, 150.0]]))
    assert np.abs(dst.unproject(np.array([[10.0, 20.0], [300.0, 150.0]])) - rays @ dst.R.T).max() < 1e-12
    with pytest.raises(ValueError):
        panoconv.Warp(src, dst, supersample=0)


def test_the_depth_reader_reads_the_command_s_16_bit_values(tmp_path):
    out = convert(tmp_path, "--to", "equirect")
    path = out / "depth_2" / f"{FRAME}.png"
    depth = panoconv.read_depth(path)
    assert depth.dtype == np.float64 and depth.ndim == 2
    # metres = value / 256 exactly; 0 where there is no point
    assert np.array_equal(depth * 256, np.round(depth * 256))
    valid = depth > 0
    assert 0.01 < valid.mean() < 0.5 and 1.0 < depth[valid].min() and depth.max() < 256
    with pytest.raises(panoconv.PanoconvError, match="16-bit"):
        panoconv.read_depth(out / "image_2" / f"{FRAME}.png")


def test_a_panorama_or_a_lens_as_the_source():
    # A full 360° panorama wraps: a view straight back (across its seam) is wholly covered,
    # and each of its pixels is the panorama's at the same bearing.
    w, h = 720, 360
    f = w / (2 * np.pi)
    pano = panoconv.Camera.equirect(w, h, f, f, (w - 1) / 2, (h - 1) / 2)
    lon = (np.arange(w) - pano.K[0, 2]) / f
    image = np.broadcast_to(np.stack([np.cos(lon), np.sin(lon)], axis=-1), (h, w, 2))
    back = panoconv.Camera.perspective(200, 120, 150.0, 150.0, 99.5, 59.5, yaw_deg=180)
    warp = panoconv.Warp(pano, back)
    assert warp.mask.all()
    out = warp.image(np.dstack([image, image[:, :, :1]]).astype(np.float32))
    # the middle pixels look along -z, within 0.005 rad: the panorama's seam, longitude ±π
    middle = out[59:61, 99:101]
    seen = np.arctan2(middle[..., 1], middle[..., 0])
    assert np.all(np.abs(seen) > np.pi - 0.01), seen
    # A lens as the source: the pixels it gives are where its own bearings land.
    lens = panoconv.Camera.kannala_brandt(400, 300, 120.0, 120.0, 199.5, 149.5, [0.01],
                                         max_fov_deg=190)
    flat = panoconv.Camera.cylindrical(300, 150, 80.0, 80.0, 149.5, 74.5)
    lw, lh = lens.size
    lu, lv = np.meshgrid(np.arange(lw, dtype=np.float32), np.arange(lh, dtype=np.float32))
    warp = panoconv.Warp(lens, flat, supersample=1)
    got = warp.image(np.dstack([lu, lv]).astype(np.float32)[:, :, :1])  # HxWx1: the lens's u
    m = warp.mask
    assert 0.2 < m.mean() < 1
    fu, fv = np.meshgrid(np.arange(300.0), np.arange(150.0))
    rays = flat.unproject(np.stack([fu[m], fv[m]], axis=1))
    want, _ = lens.project(rays)
    # (within half a pixel of the lens image's border the edge pixel is repeated)
    inner = (want[:, 0] >= 0) & (want[:, 0] <= lw - 1) & (want[:, 1] >= 0) & (want[:, 1] <= lh - 1)
    assert inner.mean() > 0.95
    assert np.abs(got[m][inner, 0] - want[inner, 0]).max() < 0.01


def test_antialias_names_the_rule_and_command_is_the_commands():
    split, _, src = source()
    # about 6 KITTI pixels a target pixel: the command's rule samples the pyramid here
    dst = panoconv.Camera.equirect(320, 200, 120.0, 120.0, 159.5, 99.5, yaw_deg=10)
    for name in ("pyramid", "taps", "command"):
        assert panoconv.Warp(src, dst, antialias=name).antialias == name
    with pytest.raises(ValueError, match='"pyramid", "taps" or "command"'):
        panoconv.Warp(src, dst, antialias="box")
    with pytest.raises(ValueError, match="supersample 8"):
        panoconv.Warp(src, dst, supersample=4, antialias="command")
    rgb = panoconv.read_image(split / "image_2" / f"{FRAME}.png")
    command = panoconv.Warp(src, dst, antialias="command").image(rgb)
    taps = panoconv.Warp(src, dst, antialias="taps").image(rgb)
    assert (command != taps).any(axis=2).sum() > 1000, "coarse pixels take the pyramid"


def test_a_panorama_source_with_the_command_s_rule_gives_panoconv_pano_s_bytes(
    tmp_path, nuscenes_equirect
):
    # A 512x256 stitched panorama to a perspective view straight back (across its seam) 3.2
    # source pixels a view pixel: the command's rule samples the panorama's wrapping pyramid
    # there, as `panoconv pano` does, byte for byte.
    out = tmp_path / "views"
    panos = nuscenes_equirect / "training" / "image_2"
    r = run(
        "pano", "--input", panos, "--output", out, "--to", "perspective", "--yaw", "180",
        "--fov", "90", "--vfov", "70", "--pano-width", "160", "--quiet",
    )
    assert r.returncode == 0, r.stderr
    first = sorted(panos.glob("*.png"))[0]
    rgb = panoconv.read_image(first)
    h, w = rgb.shape[:2]
    assert (w, h) == (512, 256)
    f = w / (2 * np.pi)
    pano = panoconv.Camera.equirect(w, h, f, f, (w - 1) / 2, (h - 1) / 2)
    want = panoconv.read_image(sorted(out.rglob(f"{first.stem}*.png"))[0])
    vh, vw = want.shape[:2]
    fv = 160 / (2 * np.pi)
    back = panoconv.Camera.perspective(vw, vh, fv, fv, (vw - 1) / 2, (vh - 1) / 2, yaw_deg=180)
    command = panoconv.Warp(pano, back, antialias="command").image(rgb)
    assert np.array_equal(command, want), f"{(command != want).any(axis=2).sum()} pixels differ"
    taps = panoconv.Warp(pano, back, antialias="taps").image(rgb)
    assert (taps != want).any(axis=2).sum() > 100, "the view's pixels take the pyramid"


def test_a_broken_scan_or_calib_is_an_error_naming_its_file(tmp_path):
    split = kitti_dir() / "training"
    calib = panoconv.read_calib(split / "calib" / f"{FRAME}.txt")
    warp = panoconv.Warp(calib.camera, calib.camera)
    scan = (split / "velodyne" / f"{FRAME}.bin").read_bytes()
    broken = tmp_path / "broken.bin"
    broken.write_bytes(scan[: len(scan) - 5])
    for read in (lambda: panoconv.read_velodyne(broken, calib),
                 lambda: warp.depth_velodyne(broken, calib)):
        with pytest.raises(Exception, match="broken.bin.*not a whole number of 16-byte points"):
            read()
    lines = (split / "calib" / f"{FRAME}.txt").read_text().splitlines()
    no_velo = tmp_path / "calib.txt"
    no_velo.write_text("\n".join(l for l in lines if not l.startswith("Tr_velo_to_cam")) + "\n")
    bare = panoconv.read_calib(no_velo, image=split / "image_2" / f"{FRAME}.png")
    with pytest.raises(Exception, match="calib.txt.*no R0_rect or Tr_velo_to_cam line"):
        warp.depth_velodyne(split / "velodyne" / f"{FRAME}.bin", bare)
