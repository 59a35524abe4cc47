"""The `panoconv` command the wheel installs: the same CLI, the same exit codes."""

from __future__ import annotations

import subprocess
import sys

import panoconv

from conftest import SAMPLE, command, run


def test_the_command_is_installed_beside_the_interpreter():
    assert command().is_file()
    r = run("--version")
    assert r.returncode == 0, r.stderr
    assert r.stdout == f"panoconv {panoconv.__version__}\n"


def test_python_m_panoconv_runs_the_same_command():
    r = subprocess.run(
        [sys.executable, "-m", "panoconv", "--version"], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout == f"panoconv {panoconv.__version__}\n"


def test_a_conversion_through_the_command_writes_a_verified_dataset(equirect):
    for sub in ("image_2", "label_2", "calib"):
        assert sorted(p.name for p in (equirect / "training" / sub).iterdir()), sub
    r = run("verify", equirect)
    assert r.returncode == 0, r.stderr
    assert r.stdout == str(panoconv.verify(equirect))


def test_exit_codes_are_the_cli_s(tmp_path):
    # 2: set-up error, nothing written.
    missing = tmp_path / "absent"
    r = run("kitti", "--to", "equirect", "--input", missing, "--output", tmp_path / "o")
    assert r.returncode == 2
    assert r.stderr.startswith("panoconv: error: ")
    assert not (tmp_path / "o").exists()
    # 2 for a usage error (clap).
    assert run("kitti", "--to", "nowhere").returncode == 2
    # 1: some frames failed, the others converted.
    src = tmp_path / "in"
    subprocess.run(["cp", "-r", str(SAMPLE), str(src)], check=True)
    (src / "training" / "label_2" / "000001.txt").write_text("Car 0 0 0 1 2 3 4 1.5 1.6 3.9 1 abc 9 0\n")
    r = run("kitti", "--to", "equirect", "--input", src, "--output", tmp_path / "o1", "--quiet")
    assert r.returncode == 1
    assert "000001" in r.stderr
    assert (tmp_path / "o1" / "training" / "image_2" / "000000.png").is_file()
