"""Shared set-up of the Python tests: the installed `panoconv` command, the repository's
synthetic sample and the real KITTI frames, and conversions made once per session."""

from __future__ import annotations

import json
import os
import subprocess
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "fixtures" / "synthetic_kitti"
NUSCENES = REPO / "fixtures" / "nuscenes"
KITTI360 = REPO / "fixtures" / "kitti360"

# The camera description of docs/fisheye.md: Kannala-Brandt, 190°, 10° nose down, 0.5° roll.
FISHEYE = {
    "version": 1,
    "model": "kannala_brandt",
    "width": 1280,
    "height": 966,
    "max_fov_deg": 190,
    "fx": 330.2,
    "fy": 330.9,
    "cx": 641.3,
    "cy": 480.7,
    "k": [0.04, -0.012, 0.002, -0.0002],
    "rotation": {"yaw_deg": 0, "pitch_deg": -10, "roll_deg": 0.5},
}


def command() -> Path:
    """The `panoconv` command the package installed beside this interpreter."""
    exe = "panoconv.exe" if os.name == "nt" else "panoconv"
    return Path(sysconfig.get_path("scripts")) / exe


def run(*args) -> subprocess.CompletedProcess:
    """Runs the installed command; never raises on a non-zero exit."""
    return subprocess.run(
        [str(command()), *map(str, args)], capture_output=True, text=True, timeout=600
    )


def kitti_dir() -> Path:
    """The real KITTI frames: $PANOCONV_KITTI (relative to the repository), else ../shared/kitti."""
    shared = os.environ.get("PANOCONV_SHARED", "../shared")
    d = REPO / os.environ.get("PANOCONV_KITTI", f"{shared}/kitti")
    if not (d / "training" / "image_2").is_dir():
        # Skipped (and counted by pytest) without the shared data, unless it is required.
        required = os.environ.get("CI") == "true" or os.environ.get("PANOCONV_REQUIRE_SHARED") == "1"
        message = f"no real KITTI frames at {d}"
        assert not required, message
        pytest.skip(message)
    return d


class Conversions:
    """Each conversion runs once per session, through the installed command."""

    def __init__(self, root: Path):
        self.root = root
        self.done: dict[str, Path] = {}

    def get(self, name: str, *args: str, source: Path = SAMPLE) -> Path:
        if name not in self.done:
            out = self.root / name
            r = run("kitti", "--input", source, "--output", out, "--quiet", *args)
            assert r.returncode == 0, f"panoconv kitti {args} failed:\n{r.stderr}"
            self.done[name] = out
        return self.done[name]


@pytest.fixture(scope="session")
def conversions(tmp_path_factory) -> Conversions:
    return Conversions(tmp_path_factory.mktemp("conversions"))


@pytest.fixture(scope="session")
def equirect(conversions) -> Path:
    return conversions.get("equirect", "--to", "equirect")


@pytest.fixture(scope="session")
def cylindrical(conversions) -> Path:
    return conversions.get("cylindrical", "--to", "cylindrical", "--split", "training")


@pytest.fixture(scope="session")
def perspective(conversions) -> Path:
    return conversions.get(
        "perspective", "--to", "perspective", "--px-per-deg", "9", "--split", "training"
    )


@pytest.fixture(scope="session")
def fisheye_camera_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("camera") / "front.json"
    path.write_text(json.dumps(FISHEYE))
    return path


@pytest.fixture(scope="session")
def fisheye(conversions, fisheye_camera_file) -> Path:
    return conversions.get(
        "fisheye", "--to", "fisheye", "--camera", str(fisheye_camera_file), "--frames", "000000"
    )


@pytest.fixture(scope="session")
def real_equirect(conversions) -> Path:
    return conversions.get(
        "real_equirect", "--to", "equirect", "--split", "training", source=kitti_dir()
    )


@pytest.fixture(scope="session")
def nuscenes_equirect(tmp_path_factory) -> Path:
    """The nuScenes fixture as the command stitches it: 512x256 panoramas with depth_2 and
    source_2 (black where no camera sees), no velodyne/."""
    out = tmp_path_factory.mktemp("nuscenes") / "equirect"
    r = run(
        "nuscenes", "--input", NUSCENES, "--version", "v1.0-mini", "--output", out,
        "--to", "equirect", "--pano-width", "512", "--depth", "--quiet",
    )
    assert r.returncode == 0, f"panoconv nuscenes failed:\n{r.stderr}"
    return out


@pytest.fixture(scope="session")
def kitti360_equirect(tmp_path_factory) -> Path:
    """The KITTI-360 fixture as the command stitches it: 512x256, depth_2 and source_2."""
    out = tmp_path_factory.mktemp("kitti360") / "equirect"
    r = run(
        "kitti360", "--input", KITTI360, "--sequence", "2013_05_28_drive_0000_sync",
        "--output", out, "--to", "equirect", "--pano-width", "512", "--depth", "--quiet",
    )
    assert r.returncode == 0, f"panoconv kitti360 failed:\n{r.stderr}"
    return out
