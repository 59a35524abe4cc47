"""The PEP 517 backend of `pip install .`: maturin, after building the `panoconv` command.

maturin builds the extension module (`panoconv._native`); a wheel of a PyO3 module cannot
also carry a Rust binary of the same project. So the command is built here first with cargo
and staged in the wheel's data folder (`target/wheel-data/scripts/`, pyproject.toml's
`[tool.maturin] data`), which installers put on PATH beside the interpreter. Every other hook
is maturin's own.

Run as a script it only stages (the release workflow does, before `maturin build`):

    python python/build_backend/panoconv_backend.py [--target TRIPLE] [--profile release]
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "target" / "wheel-data"


def stage_command(profile: str = "release", target: str | None = None) -> Path:
    """Builds `panoconv` with cargo and copies it to the wheel's scripts folder."""
    cargo = os.environ.get("CARGO", "cargo")
    build = [cargo, "build", "--locked", "-p", "panoconv", "--bin", "panoconv", "--profile", profile]
    if target:
        build += ["--target", target]
    # The command's output goes to stderr: a PEP 517 frontend reads the hook's own stdout.
    subprocess.run(build, cwd=ROOT, check=True, stdout=sys.stderr)
    metadata = subprocess.run(
        [cargo, "metadata", "--no-deps", "--format-version", "1"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    out = Path(json.loads(metadata.stdout)["target_directory"])
    if target:
        out = out / target
    out = out / ("debug" if profile in ("dev", "test") else profile)
    windows = "windows" in (target or "") or (target is None and os.name == "nt")
    exe = "panoconv.exe" if windows else "panoconv"
    scripts = DATA / "scripts"
    shutil.rmtree(scripts, ignore_errors=True)
    scripts.mkdir(parents=True)
    staged = scripts / exe
    shutil.copy2(out / exe, staged)
    return staged


# The hooks import maturin when called, so that staging alone (the script below) runs where
# only cargo and a bare Python are installed (the release workflow's manylinux containers).


def get_requires_for_build_wheel(config_settings=None):
    import maturin

    return maturin.get_requires_for_build_wheel(config_settings)


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    import maturin

    # maturin checks that the data folder exists before the command is built into it.
    DATA.mkdir(parents=True, exist_ok=True)
    return maturin.prepare_metadata_for_build_wheel(metadata_directory, config_settings)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    import maturin

    stage_command()
    return maturin.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_sdist(sdist_directory, config_settings=None):
    import maturin

    return maturin.build_sdist(sdist_directory, config_settings)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    import maturin

    stage_command()
    return maturin.build_editable(wheel_directory, config_settings, metadata_directory)


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="Build and stage the panoconv command for a wheel.")
    parser.add_argument("--profile", default="release")
    parser.add_argument("--target", default=None)
    args = parser.parse_args()
    print(stage_command(args.profile, args.target))
