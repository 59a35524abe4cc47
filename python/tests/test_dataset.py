"""`Dataset`: the frames of a converted dataset with their paths, labels and cameras."""

from __future__ import annotations

import numpy as np
import pytest

import panoconv

from conftest import SAMPLE


@pytest.fixture(scope="session")
def with_depth(conversions):
    return conversions.get(
        "cylindrical_depth", "--to", "cylindrical", "--frames", "000000", "--depth", "--mask"
    )


def test_frames_paths_labels_and_cameras(equirect):
    ds = panoconv.Dataset(equirect, "training")
    images = sorted(p.stem for p in (equirect / "training" / "image_2").iterdir())
    assert ds.ids == images and len(ds) == len(images) == 3
    frames = list(ds)
    assert [f.id for f in frames] == images
    for f in frames:
        assert f.split == "training"
        assert f.image == str(equirect / "training" / "image_2" / f"{f.id}.png")
        # Only camera 2 was converted (no --cameras 2,3), without --depth or --mask.
        assert f.image_3 is None and f.depth is None and f.mask is None
        want = panoconv.read_labels(equirect / "training" / "label_2" / f"{f.id}.txt")
        assert [l.tokens for l in f.labels] == [l.tokens for l in want]
        calib = panoconv.read_calib(equirect / "training" / "calib" / f"{f.id}.txt")
        assert np.array_equal(f.camera.K, calib.camera.K)
        assert np.array_equal(f.camera.C, calib.camera.C)
        assert f.camera.projection == "equirect"
        assert sorted(f.calib.cameras) == [2]
    assert ds[-1].id == images[-1] and ds["000001"].id == "000001"
    with pytest.raises(IndexError):
        ds[3]
    with pytest.raises(KeyError):
        ds["999999"]


def test_a_split_without_labels(equirect):
    ds = panoconv.Dataset(equirect, split="testing")
    assert len(ds) == 1
    assert ds[0].labels == [] and ds[0].camera.projection == "equirect"


def test_depth_and_mask_paths(with_depth):
    (frame,) = list(panoconv.Dataset(with_depth))
    assert frame.depth == str(with_depth / "training" / "depth_2" / "000000.png")
    assert frame.mask == str(with_depth / "training" / "mask_2" / "000000.png")


def test_plain_kitti_gives_the_perspective_camera_of_p2():
    ds = panoconv.Dataset(SAMPLE)
    cam = ds[0].camera
    P2 = ds[0].calib.P2
    assert cam.projection == "perspective" and ds[0].calib.projection is None
    # P2 = K [I | t] and C = -K^-1 P2[:, 3].
    assert np.allclose(cam.K, P2[:, :3] / P2[2, 2], rtol=0, atol=1e-9)
    assert np.allclose(cam.C, -np.linalg.solve(P2[:, :3], P2[:, 3]), rtol=0, atol=1e-12)


def test_set_up_errors_are_the_cli_s(tmp_path):
    with pytest.raises(panoconv.PanoconvError) as info:
        panoconv.Dataset(tmp_path / "absent")
    assert str(info.value) == f"input {tmp_path / 'absent'} is not a directory"
    with pytest.raises(panoconv.PanoconvError, match="unknown split"):
        panoconv.Dataset(SAMPLE, "validation")


def test_the_torch_style_wrapper_of_the_docs(equirect):
    class KittiPano:
        """What docs/python.md shows (torch.utils.data.Dataset is a plain base class)."""

        def __init__(self, root, split="training"):
            self.frames = panoconv.Dataset(root, split)

        def __len__(self):
            return len(self.frames)

        def __getitem__(self, i):
            f = self.frames[i]
            boxes = np.array([l.bbox for l in f.labels if l.type != "DontCare"]).reshape(-1, 4)
            return {"image": f.image, "boxes": boxes, "K": f.camera.K, "id": f.id}

    data = KittiPano(equirect)
    assert len(data) == 3
    item = data[1]
    assert item["id"] == "000001" and item["boxes"].shape[1] == 4 and item["K"].shape == (3, 3)
