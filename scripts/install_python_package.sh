#!/usr/bin/env bash
# Builds the Python package (`import panoconv` and the `panoconv` command, pyproject.toml) into
# a virtual environment of its own, `<repo>/.venv-python/`, for the Python tests
# (python/tests). The build tools come from PyPI, pinned; the extension module is built by
# `maturin develop` in cargo's dev profile, which shares target/ and the library the Rust tests
# already built, and the command staged beside it is the binary `cargo test` built.
# (`pip install .` builds both in release instead, the library without its `cli` and `ort`
# features: docs/python.md.)
#
# Always prints the absolute path of the environment's python on stdout (last line).
#
# Environment:
#   PYTHON   interpreter that makes the environment (default: python3)
set -euo pipefail

PYTHON="${PYTHON:-python3}"
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$REPO/.venv-python"
REQUIREMENTS=(
    "maturin==1.16.0"
    "numpy==2.2.6"
    "pytest==9.2.0"
    # the PandaSet adapter's optional extra (panoconv[pandaset]): its pickles
    "pandas==2.2.3"
)
STAMP="$VENV/.panoconv-requirements"
WANT="$(printf '%s\n' "${REQUIREMENTS[@]}")"
cd "$REPO"

if ! [[ -x "$VENV/bin/python" && -f "$STAMP" && "$(cat "$STAMP")" == "$WANT" ]]; then
    echo "install_python_package: installing ${REQUIREMENTS[*]} into $VENV" >&2
    rm -rf "$VENV"
    "$PYTHON" -m venv "$VENV" >&2
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
        "${REQUIREMENTS[@]}" >&2
    printf '%s\n' "$WANT" >"$STAMP"
fi

# The command: the binary of the Rust tests' build (`cargo test` builds it; this is a no-op
# after scripts/test.sh's own `cargo test`), staged where pyproject.toml's `data` folder has it.
# Building it any other way (`cargo build --bin`, or without --workspace) would resolve other
# features and rebuild.
cargo test --locked --workspace --tests --no-run --quiet >&2
mkdir -p target/wheel-data/scripts
rm -f target/wheel-data/scripts/*
cp "${CARGO_TARGET_DIR:-target}/debug/panoconv" target/wheel-data/scripts/panoconv

# With the library's default features, as the test build has them: the module then links that
# build of the library instead of compiling it a second time without them (a whole optimised
# build of the library less; the features add code the module never calls). CI checks the
# module against the library without them (`cargo check -p panoconv-python`).
VIRTUAL_ENV="$VENV" PATH="$VENV/bin:$PATH" "$VENV/bin/maturin" develop --locked --quiet \
    --features panoconv/default >&2
echo "$VENV/bin/python"
