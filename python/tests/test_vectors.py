"""Vector arguments as a user has them: every function that takes a vector takes it as a
tuple, a list or a numpy array (float64, float32, integers, a strided or reversed view), with
the same result as the tuple; anything else is a TypeError naming the argument."""

from __future__ import annotations

import json

import numpy as np
import pytest

import panoconv

from conftest import FISHEYE, SAMPLE

CENTRE = (0.25, -1.5, 2.0)


def forms(values, dtypes=(np.float64, np.float32)):
    """The same numbers as a tuple, a list, arrays of each dtype, a strided view of a larger
    array and a reversed view (both read in place, not contiguous)."""
    values = tuple(values)
    out = [("tuple", values), ("list", list(values))]
    for dtype in dtypes:
        out.append((np.dtype(dtype).name, np.array(values, dtype)))
    wide = np.zeros(2 * len(values), dtypes[0])
    wide[::2] = values
    out.append(("strided", wide[::2]))
    out.append(("reversed", np.array(values[::-1], dtypes[0])[::-1]))
    return out


def same_camera(a, b):
    assert a.size == b.size and a.projection == b.projection and a.model == b.model
    for attr in ("K", "R", "C"):
        assert np.array_equal(getattr(a, attr), getattr(b, attr)), attr
    assert a.parameters == b.parameters


# Every constructor with its vector arguments: name -> (call, the vectors and their tuple form).
COMMON = (320, 240, 150.0, 150.0, 159.5, 119.5)
CONSTRUCTORS = {
    "perspective": lambda **v: panoconv.Camera.perspective(*COMMON, **v),
    "equirect": lambda **v: panoconv.Camera.equirect(*COMMON, **v),
    "cylindrical": lambda **v: panoconv.Camera.cylindrical(*COMMON, **v),
    "kannala_brandt": lambda **v: panoconv.Camera.kannala_brandt(
        *COMMON, **{"k": (0.01, -0.002), **v}, max_fov_deg=190),
    "radial": lambda **v: panoconv.Camera.radial("equisolid", *COMMON, **v, max_fov_deg=190),
    "mei": lambda **v: panoconv.Camera.mei(
        *COMMON, 1.1, **{"k": (-0.05, 0.01), "p": (0.001, -0.0005), **v}),
    "eucm": lambda **v: panoconv.Camera.eucm(*COMMON, 0.6, 1.1, **v),
    "double_sphere": lambda **v: panoconv.Camera.double_sphere(*COMMON, -0.1, 0.6, **v),
}
VECTORS = [(name, "centre", CENTRE) for name in CONSTRUCTORS] + [
    ("kannala_brandt", "k", (0.01, -0.002)),
    ("mei", "k", (-0.05, 0.01)),
    ("mei", "p", (0.001, -0.0005)),
]


@pytest.mark.parametrize("name,arg,values", VECTORS, ids=[f"{n}-{a}" for n, a, _ in VECTORS])
def test_camera_constructors_take_any_vector(name, arg, values):
    make = CONSTRUCTORS[name]
    want = make(**{arg: values})
    for form, value in forms(values):
        got = make(**{arg: value})
        if form == "float32":
            # the float32 numbers, exactly
            same_camera(got, make(**{arg: tuple(float(v) for v in np.float32(values))}))
        else:
            same_camera(got, want)
    if arg == "centre":
        # the centre a user has: another camera's C, and integers
        same_camera(make(centre=want.C), want)
        assert np.array_equal(make(centre=np.array([1, 2, 3])).C, [1.0, 2.0, 3.0])
        assert np.array_equal(make(centre=None).C, np.zeros(3))


@pytest.mark.parametrize("bad,message", [
    ("abc", "centre: expected numbers"),
    ((1.0, 2.0), "centre: expected 3 numbers, got 2"),
    (np.zeros((3, 1)), "centre: expected numbers"),
    ({"x": 1.0}, "centre: expected numbers"),
])
def test_a_wrong_vector_is_a_type_error_naming_it(bad, message):
    with pytest.raises(TypeError, match=message):
        panoconv.Camera.perspective(*COMMON, centre=bad)


def test_read_camera_takes_the_centre_of_a_calib(tmp_path, equirect):
    path = tmp_path / "lens.json"
    path.write_text(json.dumps(FISHEYE))
    calib = panoconv.read_calib(equirect / "training" / "calib" / "000000.txt")
    # the call of the issue: a calib's camera centre, a numpy array
    cam = panoconv.read_camera(path, centre=calib.camera.C)
    assert np.array_equal(cam.C, calib.camera.C)
    want = panoconv.read_camera(path, centre=CENTRE)
    for form, value in forms(CENTRE, (np.float64,)):
        same_camera(panoconv.read_camera(path, centre=value), want)
    with pytest.raises(TypeError, match="centre: expected 3 numbers"):
        panoconv.read_camera(path, centre=[1.0])


def test_crop_resize_and_read_calib_take_integer_vectors(equirect):
    calib_path = equirect / "training" / "calib" / "000000.txt"
    camera = panoconv.read_calib(calib_path).camera
    crop, size = (40, -10, 600, 300), (300, 150)
    want = panoconv.crop_resize(camera, crop=crop, size=size)
    int_forms = lambda v: forms(v, (np.int64, np.int32, np.uint16 if min(v) >= 0 else np.int16))
    for (_, c), (_, s) in zip(int_forms(crop), int_forms(size)):
        same_camera(panoconv.crop_resize(camera, crop=c, size=s), want)
    w, h = camera.size
    want = panoconv.read_calib(calib_path, size=(w, h))
    for _, s in int_forms((w, h)):
        same_camera(panoconv.read_calib(calib_path, size=s).camera, want.camera)
    # a float is refused rather than truncated; a negative size is not a size
    with pytest.raises(TypeError, match="size: expected 2 integers"):
        panoconv.crop_resize(camera, size=np.array([300.0, 150.0]))
    with pytest.raises(TypeError, match="crop: expected 4 integers"):
        panoconv.crop_resize(camera, crop=(1, 2, 3))
    with pytest.raises(ValueError, match="size: -5 is not a size"):
        panoconv.read_calib(calib_path, size=[-5, 10])


def test_warp_labels_take_min_visible_as_any_vector():
    calib = panoconv.read_calib(SAMPLE / "training" / "calib" / "000000.txt")
    labels = panoconv.read_labels(SAMPLE / "training" / "label_2" / "000000.txt")
    dst = panoconv.Camera.perspective(200, 150, 60.0, 60.0, 99.5, 74.5, yaw_deg=20)
    warp = panoconv.Warp(calib.camera, dst)
    want = [l.tokens for l in warp.labels(labels, (3, 0.5))]
    for _, value in forms((3, 0.5)):
        assert [l.tokens for l in warp.labels(labels, min_visible=value)] == want
        assert warp.count_objects(labels, value) == warp.count_objects(labels, (3, 0.5))
    with pytest.raises(ValueError, match="min_visible: .*SHARE from 0 to 1"):
        warp.labels(labels, (2, 1.5))
