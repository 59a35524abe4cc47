"""`read_manifest` and `verify`: the manifest as JSON reads it, and the command's verdict."""

from __future__ import annotations

import json
import shutil

import pytest

import panoconv

from conftest import run


def test_read_manifest_is_the_json(equirect):
    m = panoconv.read_manifest(equirect)
    want = json.loads((equirect / "panoconv.json").read_text())
    assert m == want
    assert list(m) == list(want)
    assert panoconv.read_manifest(equirect / "panoconv.json") == want


def test_verify_says_what_the_command_says(equirect, tmp_path):
    out = tmp_path / "o"
    shutil.copytree(equirect, out)
    report = panoconv.verify(out)
    r = run("verify", out)
    assert report.ok and report.exit_code == r.returncode == 0
    assert str(report) == r.stdout
    assert report.listed == report.matched > 0 and report.problems == []
    # A changed file, a missing one and an extra one.
    (out / "training" / "label_2" / "000001.txt").write_text("changed\n")
    (out / "training" / "calib" / "000002.txt").unlink()
    (out / "training" / "stray.txt").write_text("x\n")
    report = panoconv.verify(out)
    r = run("verify", out)
    assert not report.ok and report.exit_code == r.returncode == 1
    assert str(report) == r.stdout
    assert (report.changed, report.missing, report.extra) == (1, 1, 1)
    kinds = {kind: path for kind, path, _ in report.problems}
    assert kinds == {
        "changed": "training/label_2/000001.txt",
        "missing": "training/calib/000002.txt",
        "extra": "training/stray.txt",
    }


def test_a_bad_manifest_raises_the_command_s_error(tmp_path):
    with pytest.raises(panoconv.PanoconvError) as info:
        panoconv.verify(tmp_path)
    r = run("verify", tmp_path)
    assert r.returncode == 2
    assert r.stderr == f"panoconv: error: {info.value}\n"
    (tmp_path / "panoconv.json").write_text('{\n  "frames": [\n    oops\n')
    with pytest.raises(panoconv.ParseError) as info:
        panoconv.verify(tmp_path)
    r = run("verify", tmp_path)
    assert r.stderr == f"panoconv: error: {info.value}\n"
    assert info.value.line == 3
    with pytest.raises(panoconv.ParseError) as info:
        panoconv.read_manifest(tmp_path)
    assert info.value.line == 3 and info.value.field.startswith("column ")
