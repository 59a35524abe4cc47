"""Rig sources written in Python: a dataset as a short adapter over its own devkit.

A `RigSource` lists its frames and reads each as a `RigFrame` (cameras with their poses,
3D boxes, LiDAR points, all in the dataset's world frame: metres, z up). `convert_rig` runs
the `panoconv` command's `rig-stream` conversion with the options of `panoconv nuscenes`,
serving it the adapter's frames over the command's stdin and stdout: everything but the
adapter's reads runs in the command (Rust, outside the GIL). docs/python.md.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import sysconfig
import traceback
from typing import Any, Iterable, Optional, Sequence

import numpy as np

from ._native import Camera, _camera_wire


class RigCamera:
    """One camera of a frame: its image file, its lens (`panoconv.Camera`, in its own axes:
    x right, y down, z forward) and `world_from_camera` (4 x 4) when the image was taken.
    `time`: when it was taken, seconds after the frame's time (the LiDAR sweep's, at which the
    boxes hold); None: at the frame's time."""

    def __init__(
        self,
        name: str,
        image: Any,
        camera: Camera,
        world_from_camera: Any,
        time: Optional[float] = None,
    ):
        self.name = name
        self.image = image
        self.camera = camera
        self.world_from_camera = world_from_camera
        self.time = time

    def __repr__(self) -> str:
        return f"RigCamera({self.name!r}, {str(self.image)!r})"


class Box3D:
    """A 3D object in the world frame: `type` the KITTI class written, `centre` (x, y, z),
    `size` (length, width, height), and either `yaw` (radians, counter-clockwise about the
    world's z axis, from its x axis to the box's front) or `rotation` (3 x 3, world from box:
    x along the length towards the front, z up). `points`: the dataset's sensor-point count
    (0: left out as unseen); `instance`: the dataset's id of the object (int or str);
    `velocity`: (vx, vy, vz) in the world frame, m/s, where known (None: taken as still; a
    depth-guided stitch moves the box to each camera's time); `time`: when the box holds,
    seconds after the frame's time (a rotating LiDAR measures an object as it passes it; None:
    the frame's time)."""

    def __init__(
        self,
        type: str,
        centre: Any,
        size: Any,
        yaw: Optional[float] = None,
        rotation: Any = None,
        label: Optional[str] = None,
        points: Optional[int] = None,
        instance: Any = None,
        velocity: Any = None,
        time: Optional[float] = None,
    ):
        self.type = type
        self.centre = centre
        self.size = size
        self.yaw = yaw
        self.rotation = rotation
        self.label = label
        self.points = points
        self.instance = instance
        self.velocity = velocity
        self.time = time

    def __repr__(self) -> str:
        return f"Box3D({self.type!r}, centre={self.centre!r}, size={self.size!r})"


class RigFrame:
    """One frame: `cameras` (RigCamera, the same names in the same order in every frame),
    `boxes` (Box3D), `lidar` (N x 3 or N x 4 with intensity, world frame), `world_from_lidar`
    (4 x 4), `record` (JSON values written first in objects/ID.json) and `inputs` (the other
    files read, hashed into the manifest)."""

    def __init__(
        self,
        cameras: Sequence[RigCamera],
        boxes: Iterable[Box3D] = (),
        lidar: Any = None,
        world_from_lidar: Any = None,
        record: Optional[dict] = None,
        inputs: Iterable[Any] = (),
    ):
        self.cameras = list(cameras)
        self.boxes = list(boxes)
        self.lidar = lidar
        self.world_from_lidar = world_from_lidar
        self.record = record
        self.inputs = list(inputs)


class RigSource:
    """A rig dataset: subclass it with `frames()` and `read(frame_id)`.

    Optional: `name` (the manifest's command), `root` (the input folder; inputs are recorded
    relative to it), `cameras()` (name and `panoconv.Camera` of each camera; default: those of
    the first frame that reads), `not_frames()` (frames the dataset lists without their files:
    named, not converted), `lidar_azimuth_step_deg` (the LiDAR's, for the depth maps'
    occlusion filter; default 0.2)."""

    name: str = "rig"
    root: Any = None
    lidar_azimuth_step_deg: Optional[float] = None

    def frames(self) -> list:
        raise NotImplementedError("a RigSource needs frames()")

    def read(self, frame_id: str) -> RigFrame:
        raise NotImplementedError("a RigSource needs read(frame_id)")

    def not_frames(self) -> list:
        return []

    def cameras(self) -> list:
        errors = []
        for frame_id in self.frames():
            try:
                frame = self.read(frame_id)
            except Exception as e:  # the next frame may read
                errors.append(f"{frame_id}: {_raised(e)}")
                continue
            return [(c.name, c.camera) for c in frame.cameras]
        raise ValueError("no frame reads to give the camera set: " + "; ".join(errors[:3]))


class _FieldError(Exception):
    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


def _raised(e: BaseException) -> str:
    """An exception's message and where it was raised (its traceback's last entry)."""
    text = f"{type(e).__name__}: {e}"
    tb = traceback.extract_tb(e.__traceback__)
    if tb:
        last = tb[-1]
        text += f" (at {os.path.basename(last.filename)}:{last.lineno}: {(last.line or '').strip()})"
    return text


def _finite(value: Any) -> Any:
    """Nested lists of floats with the non-finite numbers as strings (the command names them)."""
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value if np.isfinite(value) else str(value)


def _floats(value: Any, field: str) -> Any:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise _FieldError(field, f"not an array of numbers ({e})") from None
    return _finite(a.tolist())


def _camera(camera: Any, field: str) -> dict:
    if not isinstance(camera, Camera):
        raise _FieldError(field, f"{type(camera).__name__} is not a panoconv.Camera")
    try:
        return json.loads(_camera_wire(camera))
    except ValueError as e:
        raise _FieldError(field, str(e)) from None


def _count(value: Any, field: str) -> Optional[int]:
    if value is None:
        return None
    if isinstance(value, str):
        # a stable number for a string id (a UUID): the first 8 bytes of its BLAKE2b
        return int.from_bytes(hashlib.blake2b(value.encode(), digest_size=8).digest(), "little")
    try:
        n = int(value)
    except (TypeError, ValueError):
        raise _FieldError(field, f"{value!r} is not an integer") from None
    if n != value or n < 0:
        raise _FieldError(field, f"{value!r} is not an integer >= 0")
    return n


def _box(b: Any, field: str) -> dict:
    if not isinstance(b, Box3D):
        raise _FieldError(field, f"{type(b).__name__} is not a panoconv.Box3D")
    out = {
        "type": b.type,
        "centre": _floats(b.centre, f"{field}.centre"),
        "size": _floats(b.size, f"{field}.size"),
        "label": b.label,
        "points": _count(b.points, f"{field}.points"),
        "instance": _count(b.instance, f"{field}.instance"),
    }
    if b.yaw is not None:
        out["yaw"] = _floats(b.yaw, f"{field}.yaw")
    if b.rotation is not None:
        out["rotation"] = _floats(b.rotation, f"{field}.rotation")
    if getattr(b, "velocity", None) is not None:
        out["velocity"] = _floats(b.velocity, f"{field}.velocity")
    if getattr(b, "time", None) is not None:
        out["time"] = _floats(b.time, f"{field}.time")
    return out


def _frame(frame: Any) -> tuple[dict, bytes]:
    if not isinstance(frame, RigFrame):
        raise _FieldError("read", f"returned {type(frame).__name__}, not a panoconv.RigFrame")
    header: dict = {"cameras": [], "boxes": [], "inputs": [os.fspath(p) for p in frame.inputs]}
    for k, c in enumerate(frame.cameras):
        field = f"cameras[{k}]"
        if not isinstance(c, RigCamera):
            raise _FieldError(field, f"{type(c).__name__} is not a panoconv.RigCamera")
        wire = {
            "name": c.name,
            "image": os.path.abspath(os.fspath(c.image)),
            "camera": _camera(c.camera, f"{field}.camera"),
            "world_from_camera": _floats(c.world_from_camera, f"{field}.world_from_camera"),
        }
        if getattr(c, "time", None) is not None:
            wire["time"] = _floats(c.time, f"{field}.time")
        header["cameras"].append(wire)
    header["boxes"] = [_box(b, f"boxes[{k}]") for k, b in enumerate(frame.boxes)]
    if frame.world_from_lidar is not None:
        header["world_from_lidar"] = _floats(frame.world_from_lidar, "world_from_lidar")
    if frame.record is not None:
        if not isinstance(frame.record, dict):
            raise _FieldError("record", f"{type(frame.record).__name__} is not a dict")
        header["record"] = frame.record
    payload = b""
    if frame.lidar is not None:
        try:
            points = np.ascontiguousarray(frame.lidar, dtype="<f8")
        except (TypeError, ValueError) as e:
            raise _FieldError("lidar", f"not an array of numbers ({e})") from None
        header["lidar"] = {"shape": list(points.shape)}
        payload = points.tobytes()
    return header, payload


def _dumps(header: dict, field: str) -> bytes:
    try:
        return json.dumps(header, allow_nan=False).encode()
    except (TypeError, ValueError) as e:
        raise _FieldError(field, f"not JSON values ({e})") from None


def _open(source: Any) -> dict:
    for method in ("frames", "read"):
        if not callable(getattr(source, method, None)):
            return {"error": f"{type(source).__name__} has no {method}() method (docs/python.md)"}
    if isinstance(source, RigSource) and type(source).read is RigSource.read:
        return {"error": f"{type(source).__name__} has no read(frame_id) method (docs/python.md)"}
    try:
        frames = [str(f) for f in source.frames()]
        not_frames = [str(f) for f in (getattr(source, "not_frames", lambda: [])() or [])]
        cameras = getattr(source, "cameras", None)
        cameras = cameras() if callable(cameras) else RigSource.cameras(source)
        wire = [
            {"name": str(n), "camera": _camera(c, f"cameras[{k}].camera")}
            for k, (n, c) in enumerate(cameras)
        ]
    except _FieldError as e:
        return {"error": str(e)}
    except Exception as e:
        return {"error": _raised(e)}
    root = getattr(source, "root", None)
    return {
        "name": str(getattr(source, "name", None) or "rig"),
        "root": os.path.abspath(os.fspath(root) if root is not None else os.getcwd()),
        "frames": frames,
        "not_frames": not_frames,
        "cameras": wire,
        "lidar_azimuth_step_deg": getattr(source, "lidar_azimuth_step_deg", None),
    }


def _read(source: Any, frame_id: str) -> tuple[dict, bytes]:
    try:
        frame = source.read(frame_id)
    except Exception as e:
        return {"error": f"read raised {_raised(e)}", "field": "read"}, b""
    try:
        header, payload = _frame(frame)
        return header, payload
    except _FieldError as e:
        return {"error": e.message, "field": e.field}, b""


def command() -> str:
    """The `panoconv` command: $PANOCONV_COMMAND, else the one installed beside Python."""
    given = os.environ.get("PANOCONV_COMMAND")
    if given:
        return given
    exe = "panoconv.exe" if os.name == "nt" else "panoconv"
    return os.path.join(sysconfig.get_path("scripts"), exe)


def _serve(proc: subprocess.Popen, source: Any) -> None:
    """Answers the command's requests until it closes its stdout; other lines pass through."""
    assert proc.stdout is not None and proc.stdin is not None
    for line in proc.stdout:
        try:
            request = json.loads(line)
        except ValueError:
            request = None
        if not (isinstance(request, dict) and "protocol" in request and "op" in request):
            sys.stdout.buffer.write(line)  # e.g. the command's --help
            sys.stdout.flush()
            continue
        if request["op"] == "open":
            header, payload = _open(source), b""
        else:
            header, payload = _read(source, str(request.get("frame")))
        header["bytes"] = len(payload)
        try:
            text = _dumps(header, "record")
        except _FieldError as e:
            payload = b""
            text = _dumps({"error": e.message, "field": e.field, "bytes": 0}, "error")
        proc.stdin.write(text + b"\n" + payload)
        proc.stdin.flush()


def convert_rig(source: Any, output: Any, args: Sequence[Any] = ()) -> int:
    """Converts `source` (a RigSource) into `output` with `args`, the options of
    `panoconv nuscenes` (`["--to", "equirect", "--depth", ...]`, the same defaults, help and
    errors); returns the command's exit code (0 all frames, 1 some failed, 2 set-up error)."""
    exe = command()
    if not os.path.isfile(exe):
        sys.stderr.write(f"panoconv: the command is not installed at {exe}\n")
        return 2
    argv = [exe, "rig-stream", "--output", os.fspath(output), *map(str, args)]
    proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        _serve(proc, source)
    except BrokenPipeError:
        pass  # the command ended early; its exit code says why
    except KeyboardInterrupt:
        pass  # the command stops too (exit 130), its manifest lists the finished frames
    finally:
        try:
            proc.stdin.close()
        except BrokenPipeError:
            pass
    return proc.wait()
