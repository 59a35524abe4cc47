"""`Camera`: projection against the spec's formulas, unprojection round trips, the docs' numpy
function, crop and resize against the command's own --crop --resize, array handling."""

from __future__ import annotations

import re
import threading

import numpy as np
import pytest

import panoconv

from conftest import REPO

RNG = np.random.default_rng(26)


def camera_of(out, frame="000000"):
    return panoconv.read_calib(out / "training" / "calib" / f"{frame}.txt").camera


def random_points(n, centre, spread=30.0):
    """Rect points all around the camera, none within 0.5 m of its centre."""
    d = RNG.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return centre + d * RNG.uniform(0.5, spread, size=(n, 1))


def spec_ab(projection, rel):
    """(a, b) of docs/spec.md's table, in numpy."""
    x, y, z = rel.T
    if projection == "perspective":
        return x / z, y / z
    if projection == "equirect":
        return np.arctan2(x, z), np.arcsin(y / np.linalg.norm(rel, axis=1))
    if projection == "cylindrical":
        return np.arctan2(x, z), y / np.hypot(x, z)
    raise AssertionError(projection)


@pytest.mark.parametrize("name", ["equirect", "cylindrical", "perspective"])
def test_linear_projections_follow_the_spec_formulas(name, request):
    out = request.getfixturevalue(name)
    cam = camera_of(out)
    assert cam.projection == name
    pts = random_points(2000, cam.C)
    uv, valid = cam.project(pts)
    a, b = spec_ab(name, pts - cam.C)
    K = cam.K
    expected = np.stack([K[0, 0] * a + K[0, 2], K[1, 1] * b + K[1, 2]], axis=1)
    front = (pts - cam.C)[:, 2] > 0
    if name == "perspective":
        # Behind the camera there is no pixel.
        assert np.array_equal(valid, front)
        assert np.isnan(uv[~valid]).all()
    else:
        assert valid.all()
    err = np.abs(uv[valid] - expected[valid]).max()
    assert err <= 1e-9, f"{name}: {err} px"


@pytest.mark.parametrize("name", ["equirect", "cylindrical", "perspective", "fisheye"])
def test_unproject_inverts_project(name, request):
    cam = camera_of(request.getfixturevalue(name))
    pts = random_points(2000, cam.C)
    uv, valid = cam.project(pts)
    assert valid.sum() > 500
    bearings = cam.unproject(uv[valid])
    rel = pts[valid] - cam.C
    want = rel / np.linalg.norm(rel, axis=1, keepdims=True)
    err = np.abs(bearings - want).max()
    assert err <= 1e-9, f"{name}: {err}"
    # A pixel with no ray (beyond a fisheye's circle, beyond a pole) gives NaN; every pixel of
    # a perspective or cylindrical image has one.
    far = cam.unproject(np.array([[-1e7, -1e7]]))
    assert np.isnan(far).all() == (name in ("equirect", "fisheye"))


@pytest.mark.parametrize(
    "name,formula",
    [
        ("perspective", lambda r: r[:, 2]),
        ("equirect", lambda r: np.linalg.norm(r, axis=1)),
        ("cylindrical", lambda r: np.hypot(r[:, 0], r[:, 2])),
        ("fisheye", lambda r: np.linalg.norm(r, axis=1)),
    ],
)
def test_distance_is_the_one_the_projection_pairs_with(name, formula, request):
    cam = camera_of(request.getfixturevalue(name))
    pts = random_points(500, cam.C)
    assert np.abs(cam.distance(pts) - formula(pts - cam.C)).max() <= 1e-12


def docs_numpy_function():
    """The numpy function between docs/formats.md's fisheye-python markers, executed."""
    text = (REPO / "docs" / "formats.md").read_text()
    block = re.search(
        r"<!-- fisheye-python-begin -->\s*```python\n(.*?)```\s*<!-- fisheye-python-end -->",
        text,
        re.S,
    )
    assert block, "docs/formats.md: no fisheye-python block"
    scope: dict = {}
    exec(block.group(1), scope)
    return scope["read_calib"], scope["project_fisheye"]


def test_the_docs_numpy_function_agrees_with_camera_project(fisheye):
    read, project = docs_numpy_function()
    calib_path = fisheye / "training" / "calib" / "000000.txt"
    calib = read(calib_path)
    cam = panoconv.read_calib(calib_path).camera
    assert cam.projection == "fisheye" and cam.model == "kannala_brandt"
    pts = random_points(1500, cam.C)
    # The labels' 3D box corners too: the points the boxes are made of.
    for label in panoconv.read_labels(fisheye / "training" / "label_2" / "000000.txt"):
        if label.has_box_3d:
            pts = np.vstack([pts, panoconv.box_corners(label)])
    uv, valid = cam.project(pts)
    checked = 0
    for p, q, ok in zip(pts, uv, valid):
        ref = project(calib, p)
        assert (ref is not None) == bool(ok), p
        if ok:
            assert np.abs(np.array(ref) - q).max() <= 1e-9
            checked += 1
    assert checked > 700


def test_crop_resize_is_the_cli_s_crop_and_resize(conversions, cylindrical):
    crop, size = (100, 20, 600, 200), (900, 300)
    cropped = conversions.get(
        "cylindrical_crop",
        "--to", "cylindrical", "--split", "training",
        "--crop", ",".join(map(str, crop)), "--resize", "x".join(map(str, size)),
    )
    for frame in ("000000", "000001", "000002"):
        full = camera_of(cylindrical, frame)
        mine = panoconv.crop_resize(full, crop=crop, size=size)
        written = camera_of(cropped, frame)
        assert mine.size == written.size == size
        # The calib writes %.12e: 13 significant digits.
        assert np.allclose(mine.K, written.K, rtol=1e-12, atol=1e-9)
        # The half-pixel rule, by hand: cu' = s (cu - x + 0.5) - 0.5.
        K, s = full.K, size[0] / crop[2]
        assert abs(mine.K[0, 2] - (s * (K[0, 2] - crop[0] + 0.5) - 0.5)) <= 1e-9
        assert abs(mine.K[0, 0] - s * K[0, 0]) <= 1e-9
        assert np.array_equal(mine.C, full.C)


def test_crop_resize_of_a_fisheye_keeps_its_lens(fisheye):
    cam = camera_of(fisheye)
    half = panoconv.crop_resize(cam, size=(cam.width // 2, cam.height // 2))
    assert half.projection == "fisheye" and half.model == cam.model
    pts = random_points(300, cam.C)
    uv, valid = cam.project(pts)
    uv2, valid2 = half.project(pts)
    assert np.array_equal(valid, valid2)
    # Half the pixels: pixel centres at integers, so u' = (u + 0.5) / 2 - 0.5.
    assert np.abs(uv2[valid] - ((uv[valid] + 0.5) / 2 - 0.5)).max() <= 1e-9
    with pytest.raises(panoconv.PanoconvError, match="positive"):
        panoconv.crop_resize(cam, crop=(0, 0, 0, 10))


def test_contains_is_the_half_pixel_image_rectangle(equirect):
    cam = camera_of(equirect)
    w, h = cam.size
    uv = np.array([[-0.5, -0.5], [w - 0.5, 0], [0, h - 0.5], [w - 0.51, h - 0.51], [-0.51, 3]])
    assert cam.contains(uv).tolist() == [True, False, False, True, False]


def test_arrays_of_any_layout_and_dtype(equirect):
    cam = camera_of(equirect)
    pts = random_points(1000, cam.C)
    uv, valid = cam.project(pts)
    for other in (
        np.asfortranarray(pts),
        np.hstack([pts, pts])[:, :3],  # a strided view: read in place
        pts.tolist(),
    ):
        uv2, valid2 = cam.project(other)
        assert np.array_equal(uv2, uv) and np.array_equal(valid2, valid)
    uv32, _ = cam.project(pts.astype(np.float32))
    assert np.abs(uv32 - cam.project(pts.astype(np.float32).astype(np.float64))[0]).max() == 0
    with pytest.raises(ValueError, match=r"points_rect: expected an \(N, 3\) array"):
        cam.project(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"uv: expected an \(N, 2\) array"):
        cam.unproject(np.zeros((4, 3)))
    empty_uv, empty_valid = cam.project(np.zeros((0, 3)))
    assert empty_uv.shape == (0, 2) and empty_valid.shape == (0,)


def test_batches_release_the_gil_and_give_the_same_result_in_threads(equirect):
    cam = camera_of(equirect)
    pts = random_points(200_000, cam.C)
    want = cam.project(pts)[0]
    results = [None] * 4

    def work(i):
        results[i] = cam.project(pts)[0]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert np.array_equal(r, want)
    # Row by row the same as the whole batch (no dependence on how rows are split).
    assert np.array_equal(cam.project(pts[123_456:123_457])[0], want[123_456:123_457])
