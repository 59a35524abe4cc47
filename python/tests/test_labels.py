"""Labels: every field read, box corners by KITTI's convention, the exact 2D box against what
the conversion wrote and against dense sampling (curved edges, the ±180° seam), error texts."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import panoconv

from conftest import SAMPLE, kitti_dir, run


def test_every_field_is_read():
    path = SAMPLE / "training" / "label_2" / "000000.txt"
    labels = panoconv.read_labels(path)
    lines = [l for l in path.read_text().splitlines() if l.strip()]
    assert len(labels) == len(lines)
    for label, line in zip(labels, lines):
        t = line.split()
        assert label.tokens == t
        assert label.type == t[0]
        assert label.truncated == float(t[1])
        assert label.occluded == int(t[2])
        assert label.alpha == float(t[3])
        assert label.bbox == tuple(map(float, t[4:8]))
        assert label.dimensions == tuple(map(float, t[8:11]))
        assert label.location == tuple(map(float, t[11:14]))
        assert label.rotation_y == float(t[14])
        assert label.score is None
        assert label.has_box_3d == (t[0] != "DontCare")


def test_scores_and_line_numbers(tmp_path):
    path = tmp_path / "det.txt"
    path.write_text(
        "Car 0 0 0.1 1 2 3 4 1.5 1.6 3.9 1 2 9 0.2 0.87\n\nDontCare -1 -1 -10 5 6 7 8 -1 -1 -1 -1000 -1000 -1000 -10\n"
    )
    car, dont_care = panoconv.read_labels(path)
    assert car.score == 0.87 and car.line == 1
    assert dont_care.line == 3 and not dont_care.has_box_3d


def test_box_corners_follow_kitti_s_convention():
    for label in panoconv.read_labels(kitti_dir() / "training" / "label_2" / "000001.txt"):
        if not label.has_box_3d:
            continue
        h, w, l = label.dimensions
        x = np.array([l, l, -l, -l, l, l, -l, -l]) / 2
        y = np.array([0, 0, 0, 0, -h, -h, -h, -h])
        z = np.array([w, -w, -w, w, w, -w, -w, w]) / 2
        c, s = np.cos(label.rotation_y), np.sin(label.rotation_y)
        R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
        want = (R @ np.stack([x, y, z])).T + np.array(label.location)
        assert np.abs(panoconv.box_corners(label) - want).max() <= 1e-12


def written_boxes_agree(out, frames):
    """box_2d of each written label in its written calib against the written 2D box."""
    checked = 0
    for frame in frames:
        labels = panoconv.read_labels(out / "training" / "label_2" / f"{frame}.txt")
        cam = panoconv.read_calib(out / "training" / "calib" / f"{frame}.txt").camera
        for label in labels:
            if not label.has_box_3d:
                continue
            box = panoconv.box_2d(label, cam)
            assert box is not None, (frame, label)
            # label_2 holds two decimals.
            assert np.abs(np.array(box) - np.array(label.bbox)).max() <= 0.005 + 1e-9, (
                frame, label, box)
            checked += 1
    return checked


@pytest.mark.parametrize("name", ["equirect", "cylindrical", "perspective", "fisheye"])
def test_box_2d_is_the_box_the_conversion_wrote(name, request):
    out = request.getfixturevalue(name)
    frames = sorted(p.stem for p in (out / "training" / "label_2").iterdir())
    assert written_boxes_agree(out, frames) >= 3 * len(frames)


def test_box_2d_on_real_kitti_frames(real_equirect):
    frames = sorted(p.stem for p in (real_equirect / "training" / "label_2").iterdir())
    assert len(frames) == 6
    assert written_boxes_agree(real_equirect, frames) >= 10


def dense_bounds(label, cam, n=120):
    """Bounds of the densely sampled 3D box surface, unwrapped about the centre's pixel."""
    corners = panoconv.box_corners(label)
    faces = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    s = np.linspace(0, 1, n)
    pts = []
    for a, b, c, d in faces:
        p0, p1, p3 = corners[a], corners[b], corners[d]
        grid = p0 + s[:, None, None] * (p1 - p0) + s[None, :, None] * (p3 - p0)
        pts.append(grid.reshape(-1, 3))
    pts = np.vstack(pts)
    uv, valid = cam.project(pts)
    uv = uv[valid]
    centre_u = cam.project(corners.mean(axis=0)[None])[0][0, 0]
    period = 2 * np.pi * cam.K[0, 0]
    uv[:, 0] = centre_u + (uv[:, 0] - centre_u + period / 2) % period - period / 2
    return np.array([uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max()])


def test_curved_edges_and_the_seam_in_a_full_panorama(conversions, tmp_path):
    out = conversions.get(
        "equirect_360", "--to", "equirect", "--full-360", "--pano-width", "2048", "--frames", "000000"
    )
    cam = panoconv.read_calib(out / "training" / "calib" / "000000.txt").camera
    w, h = cam.size
    # A truck right behind the camera (across the ±180° seam), a car beside it (curved edges).
    path = tmp_path / "behind.txt"
    path.write_text(
        "Truck 0 0 0 0 0 0 0 3.2 2.5 12.0 0.3 1.65 -9.0 0.4\n"
        "Car 0 0 0 0 0 0 0 1.5 1.6 3.9 4.0 1.65 2.0 1.2\n"
    )
    truck, car = panoconv.read_labels(path)
    for label in (truck, car):
        exact = np.array(panoconv.box_2d(label, cam, clip=False))
        dense = dense_bounds(label, cam)
        # Dense sampling sits inside the exact bounds, within its sampling step.
        assert np.all(exact[:2] <= dense[:2] + 1e-9) and np.all(exact[2:] >= dense[2:] - 1e-9)
        assert np.abs(exact - dense).max() <= 0.05, (label, exact, dense)
    # The truck crosses the seam: unclipped it reaches beyond the image on one side, and
    # clipped it keeps the side of its centre (the seam rule of label_2).
    raw = panoconv.box_2d(truck, cam, clip=False)
    assert raw[0] < -0.5 or raw[2] > w - 0.5
    clipped = panoconv.box_2d(truck, cam)
    centre_u = cam.project(panoconv.box_corners(truck).mean(axis=0)[None])[0][0, 0]
    assert clipped[0] <= centre_u <= clipped[2]
    assert clipped[0] == 0.0 or clipped[2] == w - 1
    # Nothing of an object far outside a narrow perspective view: None.
    narrow = panoconv.crop_resize(cam, crop=(0, 0, 10, 10))
    assert panoconv.box_2d(truck, narrow) is None


def test_dont_care_has_no_3d_box(tmp_path, equirect):
    path = tmp_path / "dc.txt"
    path.write_text("DontCare -1 -1 -10 5 6 7 8 -1 -1 -1 -1000 -1000 -1000 -10\n")
    (dont_care,) = panoconv.read_labels(path)
    cam = panoconv.read_calib(equirect / "training" / "calib" / "000000.txt").camera
    with pytest.raises(ValueError, match="DontCare at line 1 has no 3D box"):
        panoconv.box_2d(dont_care, cam)


def test_errors_carry_the_cli_s_file_line_field_text(tmp_path):
    src = tmp_path / "in"
    shutil.copytree(SAMPLE, src)
    bad = src / "training" / "label_2" / "000001.txt"
    lines = bad.read_text().splitlines()
    t = lines[2].split()
    t[12] = "abc"
    lines[2] = " ".join(t)
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(panoconv.ParseError) as info:
        panoconv.read_labels(bad)
    e = info.value
    assert str(e) == f'{bad}:3: location.y: "abc" is not a number'
    assert (e.path, e.line, e.field, e.message) == (str(bad), 3, "location.y", '"abc" is not a number')
    assert isinstance(e, panoconv.PanoconvError)
    # The command reports the same text for the frame, and converts the others.
    r = run("kitti", "--to", "equirect", "--input", src, "--output", tmp_path / "o", "--quiet")
    assert r.returncode == 1
    assert str(e) in r.stderr
    # A calib the same way.
    calib = src / "training" / "calib" / "000002.txt"
    calib.write_text(calib.read_text().replace("P2: ", "P2: x", 1))
    with pytest.raises(panoconv.ParseError) as info:
        panoconv.read_calib(calib)
    assert info.value.field == "P2[0]" and str(info.value).startswith(f"{calib}:")
    r = run("kitti", "--to", "equirect", "--input", src, "--output", tmp_path / "o2", "--quiet")
    assert str(info.value) in r.stderr
    # A file that is not there: the OS error after the path.
    with pytest.raises(panoconv.PanoconvError) as info:
        panoconv.read_labels(tmp_path / "none.txt")
    assert str(info.value).startswith(f"{tmp_path / 'none.txt'}: ")
