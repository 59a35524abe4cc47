"""panoconv: KITTI datasets in panoramic, cylindrical and fisheye cameras, from Python.

The `panoconv` command converts datasets; this module reads what it wrote with the exact
camera maths of the conversion (compiled from the same Rust code): cameras that project rect
points and unproject pixels, KITTI labels, the exact 2D box of a 3D box in any camera, crop
and resize of a camera, the manifest and its check, and a frame iterator. docs/python.md.
"""

from ._native import (
    Calib,
    Camera,
    Dataset,
    Frame,
    Label,
    PanoconvError,
    ParseError,
    VerifyReport,
    Warp,
    __version__,
    best_draw,
    box_2d,
    box_corners,
    crop_resize,
    read_calib,
    read_camera,
    read_depth,
    read_image,
    read_labels,
    read_manifest,
    read_velodyne,
    verify,
)
from .random_cameras import CameraSampler, RandomCameraDataset, SplitMix64, sample_seed

__all__ = [
    "Calib",
    "CameraSampler",
    "RandomCameraDataset",
    "SplitMix64",
    "sample_seed",
    "Camera",
    "Dataset",
    "Frame",
    "Label",
    "PanoconvError",
    "ParseError",
    "VerifyReport",
    "Warp",
    "__version__",
    "best_draw",
    "box_2d",
    "box_corners",
    "crop_resize",
    "read_calib",
    "read_camera",
    "read_depth",
    "read_image",
    "read_labels",
    "read_manifest",
    "read_velodyne",
    "verify",
]
