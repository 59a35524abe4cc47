"""`python -m panoconv pandaset`'s own options (../shared/pandaset, skipped without it):
`--lidar` and `--vehicle-box` are parameters of the run, so `--resume` with other values is
refused; `--lidar none` reads no scan, so `--depth` is refused before anything is written and
the stitch is fixed (and the manifest says so)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from test_rig_source import pandaset_dir


def run(seq: Path, out: Path, *args: str):
    """The adapter at 256 px over the sequence's four frames."""
    return subprocess.run(
        [sys.executable, "-m", "panoconv", "pandaset", "--input", str(seq), "--to", "equirect",
         "--pano-width", "256", "--output", str(out), *args],
        capture_output=True, text=True, timeout=600,
    )


def test_resume_with_other_adapter_options_is_refused(tmp_path):
    pytest.importorskip("pandas")
    seq, out = pandaset_dir(), tmp_path / "out"
    r = run(seq, out, "--lidar", "pandar64", "--depth", "--quiet")
    assert r.returncode == 0, r.stderr
    manifest = (out / "panoconv.json").read_bytes()
    params = json.loads(manifest)["parameters"]
    assert "lidar=pandar64" in params["source_options"], params
    for other in (["--lidar", "both"], ["--lidar", "pandar64", "--vehicle-box", "none"]):
        r = run(seq, out, *other, "--depth", "--resume")
        assert r.returncode == 2, (other, r.stderr)
        assert "other parameters (source_options)" in r.stderr, (other, r.stderr)
        # refused before the run: the manifest is the first run's
        assert (out / "panoconv.json").read_bytes() == manifest, other
    r = run(seq, out, "--lidar", "pandar64", "--depth", "--resume")
    assert r.returncode == 0 and "4 kept from the previous run" in r.stderr, r.stderr


def test_lidar_none_refuses_depth_and_stitches_fixed(tmp_path):
    pytest.importorskip("pandas")
    seq = pandaset_dir()
    r = run(seq, tmp_path / "depth", "--lidar", "none", "--depth")
    assert r.returncode == 2, r.stderr
    assert "--depth" in r.stderr and "--lidar none" in r.stderr, r.stderr
    assert not (tmp_path / "depth").exists(), "nothing is written"
    r = run(seq, tmp_path / "guided", "--lidar", "none", "--stitch-mode", "depth")
    assert r.returncode == 2 and "--stitch-mode depth" in r.stderr, r.stderr
    assert not (tmp_path / "guided").exists()
    # the default stitch: fixed, said once, and recorded as the frames got it
    r = run(seq, tmp_path / "fixed", "--lidar", "none")
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("no scan to guide the stitch, so it is fixed") == 1, r.stderr
    params = json.loads((tmp_path / "fixed" / "panoconv.json").read_text())["parameters"]
    assert params["stitch_mode"] == "fixed", params
    assert params["depth"] is None
