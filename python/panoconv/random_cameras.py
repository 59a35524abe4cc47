"""Random target cameras at training time: a seeded camera sampler and a dataset that warps
each sample's image, labels and LiDAR into a freshly drawn camera (docs/python.md).

The sampler draws with its own generator (SplitMix64 on Python integers) and derives every
drawn value with IEEE additions, multiplications, divisions and square roots only (the sines
and tangents below are series of them), so a seed gives the same parameters, bit for bit, on
every platform and Python version, whatever numpy's or `random`'s global state.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ._native import (
    Camera,
    Dataset,
    Warp,
    best_draw,
    box_corners,
    read_depth,
    read_image,
)

_MASK = (1 << 64) - 1
_PI = 3.141592653589793
_DEG = _PI / 180.0

LINEAR = ("perspective", "cylindrical", "equirect")
RADIAL = ("equidistant", "equisolid", "stereographic", "orthographic")
LENSES = ("kannala_brandt", *RADIAL, "mei", "eucm", "double_sphere")
MODELS = LINEAR + LENSES

# Lens parameters drawn when `params` does not name them: an ideal lens of each family.
DEFAULT_PARAMS = {
    "kannala_brandt": {"k": (0.0, 0.0, 0.0, 0.0)},
    "mei": {"xi": 1.0, "k": (0.0, 0.0), "p": (0.0, 0.0)},
    "eucm": {"alpha": 0.6, "beta": 1.0},
    "double_sphere": {"xi": 0.0, "alpha": 0.6},
}


class SplitMix64:
    """Steele, Lea and Flood's SplitMix64: a 64-bit state, integer maths only."""

    def __init__(self, seed: int):
        self.state = int(seed) & _MASK

    def next_u64(self) -> int:
        self.state = (self.state + 0x9E3779B97F4A7C15) & _MASK
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
        return z ^ (z >> 31)

    def unit(self) -> float:
        """A double in [0, 1): 53 random bits."""
        return (self.next_u64() >> 11) * (1.0 / (1 << 53))

    def uniform(self, lo: float, hi: float) -> float:
        return lo + (hi - lo) * self.unit()

    def below(self, n: int) -> int:
        """An integer in [0, n) (the modulo bias of 64 bits is below 2^-40 for any list here)."""
        return self.next_u64() % n


def sample_seed(seed: int, epoch: int, index: int) -> int:
    """The seed of sample `index` of epoch `epoch`: a function of the three alone, so a data
    loader gives each sample the same camera whatever the number of its workers."""
    rng = SplitMix64(seed)
    for part in (epoch, index):
        rng = SplitMix64(rng.next_u64() ^ (int(part) & _MASK))
    return rng.next_u64()


def _sin(x: float) -> float:
    """sin x for |x| <= 2π by its series: + and * only, the same bits everywhere."""
    term, total = x, x
    for i in range(1, 40):
        term = -term * x * x / ((2 * i) * (2 * i + 1))
        total += term
    return total


def _cos(x: float) -> float:
    term, total = 1.0, 1.0
    for i in range(1, 40):
        term = -term * x * x / ((2 * i - 1) * (2 * i))
        total += term
    return total


def lens_radius(model: str, theta: float, params: dict) -> float:
    """The normalised image radius of field angle `theta` (radians) of a lens (distortion
    terms besides Kannala-Brandt's polynomial left out): what sets a lens's focal length from
    its field of view."""
    s, c = _sin(theta), _cos(theta)
    if model in ("kannala_brandt", "equidistant"):
        k = list(params.get("k", ())) + [0.0] * 4
        t2 = theta * theta
        return theta * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
    if model == "equisolid":
        return 2 * _sin(theta / 2)
    if model == "stereographic":
        return 2 * _sin(theta / 2) / _cos(theta / 2)
    if model == "orthographic":
        return s
    if model == "mei":
        return s / (c + params["xi"])
    if model == "eucm":
        a, b = params["alpha"], params["beta"]
        return s / (a * (b * s * s + c * c) ** 0.5 + (1 - a) * c)
    if model == "double_sphere":
        xi, a = params["xi"], params["alpha"]
        return s / (a * (s * s + (xi + c) ** 2) ** 0.5 + (1 - a) * (xi + c))
    raise ValueError(f"unknown lens model {model!r}")


def _range(value, name):
    """(lo, hi) of a number or a pair."""
    if isinstance(value, (int, float)):
        return (float(value), float(value))
    lo, hi = value
    if not lo <= hi:
        raise ValueError(f"{name}: expected lo <= hi, got {value!r}")
    return (float(lo), float(hi))


class CameraSampler:
    """Draws target cameras: `sample(seed)` gives a `Camera`, `draw(seed)` its parameters.

    Every range is a number (fixed) or a `(lo, hi)` pair, drawn uniformly:

    - `model`: a projection family or lens model (`perspective`, `cylindrical`, `equirect`,
      `kannala_brandt`, `equidistant`, `equisolid`, `stereographic`, `orthographic`, `mei`,
      `eucm`, `double_sphere`), or a list of them (one drawn per sample);
    - `width`, `height`: pixels (integers, or integer ranges);
    - `fov_deg`: the horizontal field of view of the linear projections (square pixels:
      fy = fx), the full field of view of a lens (`max_fov_deg`, its circle's diameter being
      `circle` times the image height: 1 is a circular fisheye inscribed in the image, the
      image diagonal over the height fills it);
    - `yaw_deg`, `pitch_deg`, `roll_deg`: the camera's turn in rect (docs/fisheye.md's
      convention: yaw to the right, pitch up, roll clockwise);
    - `principal_px`: the principal point's offset from the image centre, pixels, each axis;
    - `params`: lens parameters by name (`k` a list of up to 4 ranges for Kannala-Brandt, 2
      for MEI; `xi`, `alpha`, `beta`; `p` a list of 2), for every model that has them, or by
      model (`{"mei": {"k": [...]}}`); the ideal lens of the model where absent.

    A lens whose drawn parameters cannot show the field of view is drawn again (up to 100
    times, from the same generator: still a function of the seed).
    """

    def __init__(
        self,
        model="kannala_brandt",
        width=640,
        height=480,
        fov_deg=(180.0, 200.0),
        yaw_deg=0.0,
        pitch_deg=0.0,
        roll_deg=0.0,
        principal_px=0.0,
        circle=1.0,
        params=None,
    ):
        self.models = (model,) if isinstance(model, str) else tuple(model)
        for m in self.models:
            if m not in MODELS:
                raise ValueError(f"unknown model {m!r}: one of {', '.join(MODELS)}")
        self.width = tuple(int(v) for v in _range(width, "width"))
        self.height = tuple(int(v) for v in _range(height, "height"))
        self.fov_deg = _range(fov_deg, "fov_deg")
        self.yaw_deg = _range(yaw_deg, "yaw_deg")
        self.pitch_deg = _range(pitch_deg, "pitch_deg")
        self.roll_deg = _range(roll_deg, "roll_deg")
        self.principal_px = _range(principal_px, "principal_px")
        self.circle = _range(circle, "circle")
        self.params = dict(params or {})

    def __repr__(self):
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"CameraSampler({fields})"

    def _lens_params(self, model: str, rng: SplitMix64) -> dict:
        out = {}
        own = self.params.get(model, {})
        for name, default in DEFAULT_PARAMS.get(model, {}).items():
            value = own.get(name, self.params.get(name, default))
            if isinstance(default, tuple):
                if len(value) > len(default):
                    raise ValueError(
                        f"{model}: {name} takes at most {len(default)} ranges, not {len(value)}"
                        f" (params={{{model!r}: {{{name!r}: ...}}}} sets one model's)"
                    )
                out[name] = [rng.uniform(*_range(v, name)) for v in value]
            else:
                out[name] = rng.uniform(*_range(value, name))
        return out

    def draw(self, rng_or_seed) -> dict:
        """The parameters of a drawn camera (what `sample` builds the camera from)."""
        rng = rng_or_seed if isinstance(rng_or_seed, SplitMix64) else SplitMix64(rng_or_seed)
        model = self.models[rng.below(len(self.models))]
        width = self.width[0] + rng.below(self.width[1] - self.width[0] + 1)
        height = self.height[0] + rng.below(self.height[1] - self.height[0] + 1)
        fov = rng.uniform(*self.fov_deg)
        angles = [rng.uniform(*r) for r in (self.yaw_deg, self.pitch_deg, self.roll_deg)]
        cx = (width - 1) / 2 + rng.uniform(*self.principal_px)
        cy = (height - 1) / 2 + rng.uniform(*self.principal_px)
        drawn = {"model": model, "width": width, "height": height, "cx": cx, "cy": cy}
        drawn.update(zip(("yaw_deg", "pitch_deg", "roll_deg"), angles))
        half = fov * _DEG / 2
        if model == "perspective":
            if not fov < 180:
                raise ValueError(f"a perspective camera sees less than 180°, not {fov}")
            f = (width / 2) / (_sin(half) / _cos(half))
        elif model in LINEAR:
            f = width / (2 * half)
        else:
            circle = rng.uniform(*self.circle)
            for _ in range(100):
                params = self._lens_params(model, rng)
                r = lens_radius(model, half, params)
                if r > 0:
                    break
            else:
                raise ValueError(f"{model}: no drawn parameters show {fov}° in 100 draws")
            f = circle * (height / 2) / r
            drawn.update(params, max_fov_deg=fov)
        drawn.update(fx=f, fy=f)
        return drawn

    def sample(self, rng_or_seed) -> Camera:
        """A drawn camera (seed: an integer, or a `SplitMix64` to draw from)."""
        return camera_of(self.draw(rng_or_seed))


def camera_of(drawn: dict) -> Camera:
    """The `Camera` of drawn parameters (`CameraSampler.draw`)."""
    d = dict(drawn)
    model = d.pop("model")
    common = [d.pop(k) for k in ("width", "height", "fx", "fy", "cx", "cy")]
    angles = {k: d.pop(k) for k in ("yaw_deg", "pitch_deg", "roll_deg")}
    if model in LINEAR:
        return getattr(Camera, model)(*common, **angles)
    if model in RADIAL:
        return Camera.radial(model, *common, **angles, **d)
    return getattr(Camera, model)(*common, **angles, **d)


class RandomCameraDataset:
    """The frames of a KITTI (or converted: `kitti`, `kitti360`, `nuscenes`) `root`, each in a
    camera drawn for it.

    `ds[i]` is a dict of numpy arrays: `image` (HxWx3 uint8), `mask` (HxW bool: where the
    source gives the pixel from its own data: within the source image and, for a source with
    `mask_2/` or `source_2/`, within the area its cameras cover), `depth` (HxW float32 metres,
    0: none; from `velodyne/` where the frame's scan is kept, else from `depth_2/`; all 0
    without either), `boxes_2d` (N, 4) and `classes` (N,) and `truncated` (N,) of the objects
    with a 3D box, `boxes_3d` (N, 7: x, y, z, h, w, l, rotation_y in rect, as label_2),
    `corners_3d` (N, 8, 3: the box corners in the target camera's axes about its centre,
    R^T·(X − C)), `ignore_boxes` (M, 4: DontCare regions, and the objects `min_visible`
    refuses), `K`, `R`, `C` and `camera` (the drawn parameters), `attempt` (which draw of the
    sample: `min_objects`), `id`, `index`, `epoch`. The camera of sample `i` is drawn from
    `sample_seed(seed, epoch, i)`: the same whatever the number of workers. `set_epoch`
    changes the epoch. Picklable (it holds paths and the sampler; each process opens the
    frames itself).

    `min_visible` and `min_objects` are the command's `--min-visible` and `--min-objects` of
    `--augment`, by the same code: an object whose 2D box is narrower than `px` pixels or has
    less than `share` of its full box in the image is a DontCare region, and a camera holding
    fewer than `min_objects` objects is drawn again (up to 16 draws, the next ones from the
    same generator), else the draw holding most is kept. `supersample` and `antialias` are
    `Warp`'s: a target pixel up to `supersample` source pixels wide averages them (1: plain
    bilinear; 8, the default), through the source's pyramid (`"pyramid"`, the default, about
    the cost of bilinear), a tap per source pixel (`"taps"`) or the command's rule (`"command"`,
    its bytes: the taps below 2 source pixels, 3 for a fisheye, the pyramid above).
    """

    def __init__(
        self,
        root,
        sampler: CameraSampler,
        seed: int = 0,
        split: str = "training",
        depth: bool = True,
        supersample: int = 8,
        min_visible=(2.0, 0.1),
        min_objects: int = 0,
        antialias: str = "pyramid",
    ):
        self.root = Path(os.fspath(root))
        self.sampler = sampler
        self.seed = int(seed)
        self.split = split
        self.depth = depth
        self.supersample = supersample
        self.antialias = antialias
        self.min_visible = None if min_visible is None else tuple(float(v) for v in min_visible)
        self.min_objects = int(min_objects)
        self.epoch = 0
        self._frames = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_frames"] = None
        return state

    def set_epoch(self, epoch: int):
        self.epoch = int(epoch)

    @property
    def frames(self) -> Dataset:
        if self._frames is None:
            self._frames = Dataset(self.root, self.split)
        return self._frames

    def __len__(self) -> int:
        return len(self.frames)

    def _draw(self, index, frame, labels):
        """The drawn camera's parameters, its warp and its draw's number: `--min-objects`'s
        redraw (`best_draw`), every draw from the sample's one generator."""
        rng = SplitMix64(sample_seed(self.seed, self.epoch, index))
        src = frame.camera

        def draw(attempt):
            drawn = self.sampler.draw(rng)
            return (
                drawn,
                Warp(src, camera_of(drawn), self.supersample, self.antialias),
                attempt,
            )

        def count(drawn):
            return drawn[1].count_objects(labels, self.min_visible)

        if self.min_objects <= 0 or not labels:
            return draw(0)
        return best_draw(self.min_objects, draw, count)[0]

    def __getitem__(self, index: int) -> dict:
        if not -len(self) <= index < len(self):
            raise IndexError(f"index {index} out of range for {len(self)} frames")
        index %= len(self)
        frame = self.frames[index]
        source_labels = frame.labels if frame.labels is not None else []
        drawn, warp, attempt = self._draw(index, frame, source_labels)
        image = warp.image(read_image(frame.image))
        dst = warp.dst
        labels = warp.labels(source_labels, self.min_visible)
        objects = [o for o in labels if o.has_box_3d]
        regions = [o for o in labels if not o.has_box_3d]
        boxes_3d = np.array(
            [(*o.location, *o.dimensions, o.rotation_y) for o in objects], np.float64
        ).reshape(-1, 7)
        corners = np.array([box_corners(o) for o in objects]).reshape(-1, 8, 3)
        corners_cam = (corners - dst.C) @ dst.R
        return {
            "image": image,
            "mask": self._mask(frame, warp),
            "depth": self._depth(frame, warp),
            "boxes_2d": np.array([o.bbox for o in objects], np.float64).reshape(-1, 4),
            "classes": np.array([o.type for o in objects], dtype=str),
            "truncated": np.array([o.truncated for o in objects], np.float64),
            "boxes_3d": boxes_3d,
            "corners_3d": corners_cam,
            "ignore_boxes": np.array([o.bbox for o in regions], np.float64).reshape(-1, 4),
            "K": dst.K,
            "R": dst.R,
            "C": dst.C,
            "camera": drawn,
            "attempt": attempt,
            "id": frame.id,
            "index": index,
            "epoch": self.epoch,
        }

    def _mask(self, frame, warp: Warp) -> np.ndarray:
        coverage = source_coverage(frame)
        return warp.mask if coverage is None else warp.mask_within(coverage)

    def _depth(self, frame, warp: Warp) -> np.ndarray:
        h, w = warp.dst.height, warp.dst.width
        if self.depth:
            velodyne = self.root / self.split / "velodyne" / f"{frame.id}.bin"
            if velodyne.is_file() and frame.calib.rect_from_velo is not None:
                return warp.depth_velodyne(velodyne, frame.calib).astype(np.float32)
            if frame.depth is not None:
                return warp.depth_map(read_depth(frame.depth)).astype(np.float32)
        return np.zeros((h, w), np.float32)


def source_coverage(frame):
    """Where a frame's image holds trustworthy source data (HxW bool), or None where all of it
    does: `mask_2` (white), else a rig's `source_2` below 64 (a camera seen to see the pixel's
    point; the far fill's 64-127, the fallback's 128-254 and the uncovered 255 are not)."""
    if frame.mask is not None:
        return read_image(frame.mask)[..., 0] > 0
    if frame.source_map is not None:
        return read_image(frame.source_map)[..., 0] < 64
    return None
