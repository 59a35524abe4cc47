"""`python -m panoconv pandaset`'s own options (../shared/pandaset, skipped without it):
`--lidar` and `--vehicle-box` are parameters of the run, so `--resume` with other values is
refused."""

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

