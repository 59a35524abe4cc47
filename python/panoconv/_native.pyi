"""Type stubs of panoconv's compiled module (re-exported by `panoconv`)."""

from __future__ import annotations

import os
from typing import Any, Callable, Iterator, Optional, Sequence, Tuple, TypeVar, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, os.PathLike[str]]
Box = Tuple[float, float, float, float]
ArrayLike = npt.ArrayLike
# A vector argument: a tuple, a list or a 1-D numpy array (any float dtype, any layout; numbers
# of another dtype are converted), e.g. `camera.C`.
Floats = Union[Sequence[float], npt.NDArray[np.floating[Any]], npt.NDArray[np.integer[Any]]]
# Integers likewise: a tuple, a list or a 1-D numpy integer array (floats are refused).
Ints = Union[Sequence[int], npt.NDArray[np.integer[Any]]]
T = TypeVar("T")

class PanoconvError(Exception):
    """An error of panoconv: str(e) is the text the command line prints after
    `panoconv: error: `, e.g. `label_2/000004.txt:3: location.y: "abc" is not a number`."""

    path: Optional[str]
    line: Optional[int]
    field: Optional[str]
    message: str

class ParseError(PanoconvError):
    """A malformed value inside a file: `path`, `line` and `field` say where."""

class Camera:
    """The camera an image was written in: pixel = K · Γ(X − C) for a rect point X."""

    @property
    def K(self) -> npt.NDArray[np.float64]:
        """3×3 intrinsics: pixel = K · (a, b, 1) of the projection's coordinates."""
    @property
    def C(self) -> npt.NDArray[np.float64]:
        """Optical centre in rect, metres, shape (3,)."""
    @property
    def R(self) -> npt.NDArray[np.float64]:
        """The camera's axes in rect: R2 of a fisheye, the yaw/pitch/roll turn a constructor was
        given, identity for the command's linear projections."""
    @property
    def projection(self) -> str:
        """`perspective`, `equirect`, `cylindrical` or `fisheye`."""
    @property
    def model(self) -> Optional[str]:
        """A fisheye's lens model (`kannala_brandt`, `mei`, ...); None otherwise."""
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def size(self) -> Tuple[int, int]:
        """(width, height) in pixels."""
    def project(
        self, points_rect: ArrayLike
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """Pixels (N, 2) of rect points (N, 3) and whether each has one (N,); NaN where not.
        A valid pixel may lie outside the image: see `contains`."""
    def unproject(self, uv: ArrayLike) -> npt.NDArray[np.float64]:
        """Unit bearings (N, 3) in rect axes of pixels (N, 2); NaN rows where a pixel has no ray."""
    def distance(self, points_rect: ArrayLike) -> npt.NDArray[np.float64]:
        """The distance the projection pairs with (z, range or rho) of rect points (N, 3)."""
    def contains(self, uv: ArrayLike) -> npt.NDArray[np.bool_]:
        """Whether pixels (N, 2) lie on the image ([-0.5, width - 0.5) × [-0.5, height - 0.5))."""
    @property
    def parameters(self) -> list[Tuple[str, float]]:
        """A lens's parameters besides fx, fy, cx, cy (`k1`.., `xi`, ...); empty otherwise."""
    @property
    def max_fov_deg(self) -> Optional[float]:
        """A lens's full field of view, degrees; None for the linear projections."""
    @staticmethod
    def perspective(width: int, height: int, fx: float, fy: float, cx: float, cy: float,
                    yaw_deg: float = 0.0, pitch_deg: float = 0.0, roll_deg: float = 0.0,
                    centre: Optional[Floats] = None) -> Camera: ...
    @staticmethod
    def equirect(width: int, height: int, fx: float, fy: float, cx: float, cy: float,
                 yaw_deg: float = 0.0, pitch_deg: float = 0.0, roll_deg: float = 0.0,
                 centre: Optional[Floats] = None) -> Camera: ...
    @staticmethod
    def cylindrical(width: int, height: int, fx: float, fy: float, cx: float, cy: float,
                    yaw_deg: float = 0.0, pitch_deg: float = 0.0, roll_deg: float = 0.0,
                    centre: Optional[Floats] = None) -> Camera: ...
    @staticmethod
    def kannala_brandt(width: int, height: int, fx: float, fy: float, cx: float, cy: float,
                       k: Floats, yaw_deg: float = 0.0, pitch_deg: float = 0.0,
                       roll_deg: float = 0.0, centre: Optional[Floats] = None,
                       max_fov_deg: float = 180.0) -> Camera: ...
    @staticmethod
    def radial(model: str, width: int, height: int, fx: float, fy: float, cx: float, cy: float,
               yaw_deg: float = 0.0, pitch_deg: float = 0.0, roll_deg: float = 0.0,
               centre: Optional[Floats] = None, max_fov_deg: float = 180.0) -> Camera:
        """`equidistant`, `equisolid`, `stereographic` or `orthographic`."""
    @staticmethod
    def mei(width: int, height: int, fx: float, fy: float, cx: float, cy: float, xi: float,
            k: Optional[Floats] = None, p: Optional[Floats] = None, yaw_deg: float = 0.0,
            pitch_deg: float = 0.0, roll_deg: float = 0.0,
            centre: Optional[Floats] = None, max_fov_deg: float = 180.0) -> Camera: ...
    @staticmethod
    def eucm(width: int, height: int, fx: float, fy: float, cx: float, cy: float, alpha: float,
             beta: float, yaw_deg: float = 0.0, pitch_deg: float = 0.0, roll_deg: float = 0.0,
             centre: Optional[Floats] = None, max_fov_deg: float = 180.0) -> Camera: ...
    @staticmethod
    def double_sphere(width: int, height: int, fx: float, fy: float, cx: float, cy: float,
                      xi: float, alpha: float, yaw_deg: float = 0.0, pitch_deg: float = 0.0,
                      roll_deg: float = 0.0, centre: Optional[Floats] = None,
                      max_fov_deg: float = 180.0) -> Camera: ...

class Warp:
    """A source camera's image, labels and LiDAR in a target camera placed at the source's
    optical centre, as `panoconv kitti` writes them; the table is built once and kept."""

    def __init__(
        self, src: Camera, dst: Camera, supersample: int = 8, antialias: str = "pyramid"
    ) -> None:
        """supersample: 1 plain bilinear, up to 8 antialiased; antialias: "pyramid" (about
        bilinear's cost), "taps" (a tap per source pixel) or "command" (the command's rule and
        bytes: taps below 2 source pixels a pixel, 3 for a fisheye target, the pyramid above)."""
    @property
    def supersample(self) -> int: ...
    @property
    def antialias(self) -> str: ...
    def build(self) -> Warp: ...
    @property
    def src(self) -> Camera: ...
    @property
    def dst(self) -> Camera:
        """The target camera, at the source's optical centre."""
    @property
    def built(self) -> bool: ...
    @property
    def mask(self) -> npt.NDArray[np.bool_]:
        """HxW: where the source gives the pixel (the command's --mask)."""
    @property
    def coverage(self) -> float: ...
    def image(self, array: npt.NDArray) -> npt.NDArray:
        """HxW, HxWx3 or HxWx4 uint8/uint16/float32 in the target; HxWx3 uint8: the command's bytes."""
    def labels(
        self, labels: Sequence[Label], min_visible: Optional[Floats] = None
    ) -> list[Label]:
        """The label lines the command writes, for the labels with an image in the target;
        min_visible=(px, share): --min-visible (refused objects become DontCare regions)."""
    def count_objects(
        self, labels: Sequence[Label], min_visible: Optional[Floats] = None
    ) -> int:
        """The objects `labels(labels, min_visible)` writes as objects (--min-objects' count)."""
    def depth(self, points_rect: ArrayLike, occlusion: bool = True) -> npt.NDArray[np.float64]:
        """HxW metres (0: none) of rect points (N, 3): the command's depth_2 is round(d·256)."""
    def depth_velodyne(
        self, path: str | os.PathLike[str], calib: Calib, occlusion: bool = True
    ) -> npt.NDArray[np.float64]:
        """`depth(read_velodyne(path, calib), occlusion)`, the points taken as the file is read."""
    def depth_map(self, depth: ArrayLike) -> npt.NDArray[np.float64]:
        """The source's depth map (HxW metres, 0: none) in the target: each source pixel's 3D
        point, the nearest per target pixel."""
    def mask_within(self, coverage: ArrayLike) -> npt.NDArray[np.bool_]:
        """`mask` where every tap also falls on a source pixel that `coverage` (HxW) marks."""

class Calib:
    """A calib file (plain KITTI or written by panoconv): its matrices and cameras."""

    @property
    def camera(self) -> Camera:
        """The camera image_2 was taken (P2) or written (projection:, K2:, C2:) in."""
    @property
    def cameras(self) -> dict[int, Camera]:
        """Cameras by number: 2, and 3 when the calib describes it."""
    @property
    def projection(self) -> Optional[str]:
        """The `projection:` line; None for plain KITTI."""
    @property
    def path(self) -> str: ...
    @property
    def lines(self) -> list[str]:
        """The file's lines, verbatim."""
    @property
    def P0(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def P1(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def P2(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def P3(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def R0_rect(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def Tr_velo_to_cam(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def Tr_imu_to_velo(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def rect_from_velo(self) -> Optional[npt.NDArray[np.float64]]:
        """R0_rect · Tr_velo_to_cam (3×4): X_rect = M[:, :3] @ p + M[:, 3]."""

class Label:
    """One object of a KITTI label file."""

    @property
    def type(self) -> str: ...
    @property
    def truncated(self) -> float: ...
    @property
    def occluded(self) -> int: ...
    @property
    def alpha(self) -> float: ...
    @property
    def bbox(self) -> Box:
        """(left, top, right, bottom) as written in the file."""
    @property
    def dimensions(self) -> Tuple[float, float, float]:
        """(height, width, length), metres."""
    @property
    def location(self) -> Tuple[float, float, float]:
        """Bottom centre of the 3D box in rect, metres."""
    @property
    def rotation_y(self) -> float: ...
    @property
    def score(self) -> Optional[float]: ...
    @property
    def has_box_3d(self) -> bool: ...
    @property
    def tokens(self) -> list[str]: ...
    @property
    def line(self) -> int:
        """1-based line in the file."""

class Frame:
    """One frame of a `Dataset`."""

    id: str
    split: str
    image: str
    image_3: Optional[str]
    depth: Optional[str]
    mask: Optional[str]
    source_map: Optional[str]
    labels: list[Label]
    calib: Calib
    @property
    def camera(self) -> Camera: ...

class Dataset:
    """The frames of one split (`training`, `testing`) of a dataset in KITTI's layout."""

    def __init__(self, path: PathLike, split: str = "training") -> None: ...
    @property
    def ids(self) -> list[str]: ...
    @property
    def root(self) -> str: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: Union[int, str]) -> Frame: ...
    def __iter__(self) -> Iterator[Frame]: ...

class VerifyReport:
    """What `panoconv verify` found; str() is exactly what it prints."""

    @property
    def ok(self) -> bool: ...
    @property
    def listed(self) -> int: ...
    @property
    def matched(self) -> int: ...
    @property
    def missing(self) -> int: ...
    @property
    def changed(self) -> int: ...
    @property
    def extra(self) -> int: ...
    @property
    def problems(self) -> list[Tuple[str, str, str]]:
        """(kind, path, printed line) per problem."""
    @property
    def summary(self) -> str: ...
    @property
    def exit_code(self) -> int:
        """0 everything matches, 1 problems found (as `panoconv verify`)."""

def read_calib(
    path: PathLike,
    size: Optional[Ints] = None,
    image: Optional[PathLike] = None,
) -> Calib:
    """Reads a calib file; camera sizes from `size`, else `image`, else ../image_2/<id>.png."""

def read_labels(path: PathLike) -> list[Label]:
    """Reads a KITTI label file (ParseError names file, line and field)."""

def box_corners(obj: Label) -> npt.NDArray[np.float64]:
    """The 8 corners (8, 3) of the object's 3D box in rect: bottom face, then top."""

def box_2d(obj: Label, camera: Camera, clip: bool = True) -> Optional[Box]:
    """The exact 2D box of the object's 3D box in `camera`, clipped as label_2 writes it;
    None when nothing of it is in the image. ValueError for objects without a 3D box."""

def crop_resize(
    camera: Camera,
    crop: Optional[Ints] = None,
    size: Optional[Ints] = None,
) -> Camera:
    """The camera after cropping (x, y, width, height) then resizing to (width, height)."""

def read_manifest(path: PathLike) -> dict:
    """The manifest `OUT/panoconv.json` (or of the folder `OUT`) as Python values."""

def verify(path: PathLike) -> VerifyReport:
    """`panoconv verify PATH` as a report."""

def read_camera(path: PathLike, centre: Optional[Floats] = None) -> Camera:
    """A camera file (description or native calibration) in rect axes, at `centre` or the origin."""
def read_image(path: PathLike) -> npt.NDArray[np.uint8]:
    """An image file as HxWx3 uint8 RGB."""
def read_depth(path: PathLike) -> npt.NDArray[np.float64]:
    """A 16-bit depth PNG as HxW metres (value / 256), 0 where none."""
def read_velodyne(path: PathLike, calib: Calib) -> npt.NDArray[np.float64]:
    """A Velodyne scan's finite points in rect (N, 3), as the command's --depth takes them."""
def best_draw(
    min_objects: int, draw: Callable[[int], T], count: Callable[[T], int]
) -> Tuple[T, int]:
    """--min-objects' redraw: draw(0), draw(1), ... (up to 16) until count(drawn) reaches
    min_objects; (drawn, count) of that draw, else of the first draw that counted most."""
def _camera_wire(camera: Camera) -> str:
    """The camera as `panoconv rig-stream` reads it (JSON): a pinhole or a camera description."""
