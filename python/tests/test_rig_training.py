"""Training on a rig's output (the nuScenes and KITTI-360 fixtures stitched by the command):
the depth of `RandomCameraDataset` from `depth_2`, warped exactly (each source depth pixel's
own 3D point, the nearest per target pixel, against numpy over the cameras' projections); its
mask within the panorama's coverage (`source_2`), exactly the pixels every tap of which is
covered; the command's `--min-visible` rule and `--min-objects` redraw; the defaults
(`supersample` 8 through the pyramid)."""

from __future__ import annotations

import numpy as np
import pytest

import panoconv
from panoconv.random_cameras import CameraSampler, RandomCameraDataset, camera_of

from conftest import kitti_dir


def sampler():
    """Cameras looking all around the panorama, up and down into its uncovered rows."""
    return CameraSampler(
        model=["kannala_brandt", "equirect", "perspective", "cylindrical"],
        width=(160, 240), height=(120, 180), fov_deg=(80, 150), yaw_deg=(-180, 180),
        pitch_deg=(-40, 40), roll_deg=(-10, 10),
    )


def target(frame, drawn):
    """The drawn camera at the frame camera's centre, as the dataset warps into it."""
    return panoconv.Warp(frame.camera, camera_of(drawn))


def rounded(x):
    """Rust's f64::round: halves away from zero (numpy's round takes halves to even)."""
    return np.sign(x) * np.floor(np.abs(x) + 0.5)


def depth_by_points(src, dst, depth):
    """The exact depth of `depth` (over src's pixels) in dst, in numpy: each pixel's point on
    its ray at its distance, projected into dst, the nearest by dst's distance per pixel.
    Returns the map and the pixels a point lands on within 1e-6 px of a pixel border (which
    rounding may give to either side)."""
    v, u = np.nonzero(depth > 0)
    rays = src.unproject(np.stack([u, v], axis=1).astype(np.float64))
    ok = np.isfinite(rays).all(axis=1)
    rays, d = rays[ok], depth[v[ok], u[ok]]
    # the distance src pairs with is homogeneous: the point at distance d is t·ray, t = d / D(ray)
    points = src.C + rays * (d / src.distance(src.C + rays))[:, None]
    uv, valid = dst.project(points)
    w, h = dst.size
    px = rounded(uv[valid])
    dist = dst.distance(points[valid])
    on = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
    out = np.full((h, w), np.inf)
    cols, rows = px[on, 0].astype(int), px[on, 1].astype(int)
    np.minimum.at(out, (rows, cols), dist[on])
    out[np.isinf(out)] = 0
    frac = np.abs(np.abs(uv[valid] - np.floor(uv[valid])) - 0.5)
    edge = (frac < 1e-6).any(axis=1) & on
    border = np.zeros((h, w), bool)
    border[rows[edge[on]], cols[edge[on]]] = True
    return out, border


@pytest.fixture(params=["nuscenes_equirect", "kitti360_equirect"])
def rig(request):
    """A rig's converted output: no velodyne/, depth_2 and source_2."""
    return request.getfixturevalue(request.param)


def test_depth_comes_from_depth_2_exactly(rig):
    root = rig
    assert not (root / "training" / "velodyne").exists()
    ds = RandomCameraDataset(root, sampler(), seed=3)
    compared = 0
    for i in range(len(ds)):
        frame = ds.frames[i]
        src_depth = panoconv.read_depth(frame.depth)
        assert (src_depth > 0).sum() > 1000
        # the source map through itself: every value back on its own pixel
        same = panoconv.Warp(frame.camera, frame.camera).depth_map(src_depth)
        assert np.array_equal(same > 0, src_depth > 0)
        assert np.abs(same - src_depth).max() < 1e-9
        with pytest.raises(ValueError, match="depth: expected the source camera's 512x256"):
            panoconv.Warp(frame.camera, frame.camera).depth_map(src_depth[:10])
        for epoch in range(4):
            ds.set_epoch(epoch)
            x = ds[i]
            dst = target(frame, x["camera"]).dst
            want, border = depth_by_points(frame.camera, dst, src_depth)
            got = x["depth"]
            assert got.dtype == np.float32 and got.shape == want.shape
            if epoch == 0:
                assert (got > 0).sum() > 100, "a rig's output gives depth (was all 0)"
            keep = ~border
            assert np.array_equal(got[keep] > 0, want[keep] > 0), x["camera"]
            assert np.abs(got[keep] - want[keep].astype(np.float32)).max() <= 1e-5 * want.max()
            assert border.sum() <= 0.01 * max((want > 0).sum(), 1)
            compared += int((want[keep] > 0).sum())
    assert compared > 2000


def test_the_mask_is_the_panorama_s_coverage(rig):
    ds = RandomCameraDataset(rig, sampler(), seed=11)
    uncovered_seen = 0
    for i in range(len(ds)):
        frame = ds.frames[i]
        # the pixels a camera is seen to give (the far fill's and the fallback's aside)
        coverage = panoconv.read_image(frame.source_map)[..., 0] < 64
        # the cameras cover a band: black above and below
        assert 0.2 < coverage.mean() < 0.9
        for epoch in range(4):
            ds.set_epoch(epoch)
            x = ds[i]
            warp = target(frame, x["camera"])
            mask = x["mask"]
            # every tap covered, exactly: the covered share warped through the same taps is 1
            share = warp.image(coverage.astype(np.float32))
            assert np.array_equal(mask, warp.mask & (share == 1.0))
            assert np.array_equal(mask, warp.mask_within(coverage))
            assert np.array_equal(warp.mask_within(np.ones_like(coverage)), warp.mask)
            # no pixel of the mask is the uncovered area's black
            black = (x["image"] == 0).all(axis=2)
            assert not (black & mask).any()
            uncovered_seen += int((~mask).sum())
            if black.sum() > 100:
                assert (~mask[black]).mean() == 1.0
    assert uncovered_seen > 10_000  # (before: the mask was all True over the black)
    with pytest.raises(ValueError, match="coverage: expected the source camera's 512x256"):
        warp.mask_within(coverage.T)


def test_kitti_s_mask_2_is_the_coverage_of_a_converted_kitti(conversions):
    # a kitti output with --mask: its black outside the source is masked in a drawn camera
    out = conversions.get("equirect_mask", "--to", "equirect", "--mask", "--split", "training")
    ds = RandomCameraDataset(out, sampler(), seed=1)
    x = ds[0]
    frame = ds.frames[0]
    coverage = panoconv.read_image(frame.mask)[..., 0] > 0
    assert np.array_equal(x["mask"], target(frame, x["camera"]).mask_within(coverage))
    assert not (x["mask"] & (x["image"] == 0).all(axis=2)).any()


def visible_share(obj, cam):
    """Share of the object's full projected box inside the image, and its clipped box."""
    full = panoconv.box_2d(obj, cam, clip=False)
    clipped = panoconv.box_2d(obj, cam)
    area = lambda b: max(b[2] - b[0], 0) * max(b[3] - b[1], 0)
    return area(clipped) / area(full), clipped


def test_slivers_are_dont_care_as_with_augment(nuscenes_equirect):
    ds = RandomCameraDataset(nuscenes_equirect, sampler(), seed=0)
    off = RandomCameraDataset(nuscenes_equirect, sampler(), seed=0, min_visible=None)
    refused = checked = corners = 0
    for epoch in range(6):
        ds.set_epoch(epoch)
        off.set_epoch(epoch)
        for i in range(len(ds)):
            x, y = ds[i], off[i]
            assert x["camera"] == y["camera"]
            frame = ds.frames[i]
            src = [o for o in frame.labels]
            warp = target(frame, x["camera"])
            kept = [o for o in warp.labels(src, (2, 0.1)) if o.has_box_3d]
            for obj, box in zip(kept, x["boxes_2d"]):
                share, clipped = visible_share(obj, warp.dst)
                assert np.allclose(box, obj.bbox)
                # the rule on the written box: 2 px a side, a tenth of the full box (to the
                # two decimals label_2 writes)
                assert box[2] - box[0] >= 2 and box[3] - box[1] >= 2, box
                assert share >= 0.1 - 0.01, (share, box)
                checked += 1
            # (the car, 0.99 truncated, was such a corner)
            assert (x["truncated"] <= 0.9).all(), x["truncated"]
            corners += int((y["truncated"] > 0.9).sum())
            refused += len(y["classes"]) - len(x["classes"])
            assert len(x["ignore_boxes"]) - len(y["ignore_boxes"]) == len(y["classes"]) - len(x["classes"])
    assert checked > 20 and refused >= corners > 0, (checked, refused, corners)


def test_min_objects_redraws_as_the_command(nuscenes_equirect):
    narrow = CameraSampler(model="perspective", width=160, height=120, fov_deg=(30, 50),
                           yaw_deg=(-180, 180), pitch_deg=(-30, 30))
    first = RandomCameraDataset(nuscenes_equirect, narrow, seed=4)
    ds = RandomCameraDataset(nuscenes_equirect, narrow, seed=4, min_objects=3)
    redrawn = 0
    for i in range(len(ds)):
        x, x0 = ds[i], first[i]
        assert x0["attempt"] == 0
        frame = ds.frames[i]
        # the draws of the sample's generator, counted with the command's rule: the first
        # reaching 3, else the first of those holding most
        rng = panoconv.SplitMix64(panoconv.sample_seed(4, 0, i))
        counts = []
        for _ in range(16):
            warp = panoconv.Warp(frame.camera, camera_of(narrow.draw(rng)))
            counts.append(warp.count_objects(frame.labels, (2, 0.1)))
            if counts[-1] >= 3:
                break
        assert x["attempt"] == counts.index(max(counts))
        assert len(x["classes"]) == max(counts)
        if x["attempt"] == 0:
            assert x["camera"] == x0["camera"]
        redrawn += x["attempt"] > 0
    assert redrawn >= 1


def test_best_draw_is_the_command_s_rule():
    calls = []

    def draw(attempt):
        calls.append(attempt)
        return [0, 2, 1, 5, 3][attempt] if attempt < 5 else 1

    assert panoconv.best_draw(3, draw, lambda n: n) == (5, 5) and calls == [0, 1, 2, 3]
    calls.clear()
    # none reaches 9: all 16 drawn, the first holding most kept
    assert panoconv.best_draw(9, draw, lambda n: n) == (5, 5) and calls == list(range(16))
    assert panoconv.best_draw(0, draw, lambda n: n) == (0, 0)

    def fails(attempt):
        raise RuntimeError(f"draw {attempt}")

    with pytest.raises(RuntimeError, match="draw 0"):
        panoconv.best_draw(1, fails, lambda n: n)


def test_the_default_is_the_pyramid(nuscenes_equirect):
    frame = panoconv.Dataset(nuscenes_equirect)[0]
    src = frame.camera
    # 30 px a radian against the panorama's 81: coarser, where antialiasing matters
    dst = panoconv.Camera.kannala_brandt(200, 150, 30.0, 30.0, 99.5, 74.5, [0.01], max_fov_deg=190)
    image = panoconv.read_image(frame.image)
    warp = panoconv.Warp(src, dst)
    assert (warp.supersample, warp.antialias) == (8, "pyramid")
    assert np.array_equal(warp.image(image), panoconv.Warp(src, dst, 8, "pyramid").image(image))
    # plain bilinear is one argument away, and differs (the target is coarser here)
    assert not np.array_equal(warp.image(image), panoconv.Warp(src, dst, supersample=1).image(image))
    ds = RandomCameraDataset(nuscenes_equirect, sampler(), seed=2)
    assert (ds.supersample, ds.antialias) == (8, "pyramid")
    x = ds[0]
    fast = panoconv.Warp(src, camera_of(x["camera"]))
    assert np.array_equal(x["image"], fast.image(image))


def test_kitti_frames_still_take_their_scan():
    # plain KITTI keeps its velodyne/: the depth is the scan's, as before
    ds = RandomCameraDataset(kitti_dir(), sampler(), seed=5)
    x = ds[1]
    frame = ds.frames[1]
    warp = target(frame, x["camera"])
    split = kitti_dir() / "training"
    scan = panoconv.read_velodyne(split / "velodyne" / f"{frame.id}.bin", frame.calib)
    assert np.array_equal(x["depth"], warp.depth(scan).astype(np.float32))
