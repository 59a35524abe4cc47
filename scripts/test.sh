#!/usr/bin/env bash
# The whole test suite. Installs what it needs first (ONNX Runtime for the style tests, from
# the PyPI wheel, into .ort/; the Python references of the tests, into .venv-test/), then runs
# every test: the Rust tests, then the Python package's (python/tests, built into
# .venv-python/ by scripts/install_python_package.sh). Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
ORT_DYLIB_PATH="$(scripts/install_ort.sh | tail -n 1)"
PANOCONV_TEST_PYTHON="$(scripts/install_test_python.sh | tail -n 1)"
# The Python package before the Rust tests: tests/rig_stream.rs converts through a Python
# adapter (its build makes the test binaries that `cargo test` below then reuses).
PANOCONV_PYTHON="$(scripts/install_python_package.sh | tail -n 1)"
export ORT_DYLIB_PATH PANOCONV_TEST_PYTHON PANOCONV_PYTHON
# --tests: the library's unit tests and the integration crate (tests/tests.rs); the examples
# (benches/*.rs measurement tools) are compiled by clippy --all-targets in CI instead.
# --workspace: the features of the Python module's dependencies too (pyo3's macros ask syn
# for more, numpy num-complex's defaults), so that `maturin develop` below finds every shared
# crate built as it needs it instead of building the library a second time.
# The tests that read ../shared (tests/needs_shared.txt) are skipped when it is absent, and
# named and counted again at the end; with CI=true or PANOCONV_REQUIRE_SHARED=1 they must run.
skips_log="$(mktemp)" skips_args="$(mktemp)"
trap 'rm -f "$skips_log" "$skips_args"' EXIT
if ! scripts/shared_skips.sh >"$skips_args" 2>"$skips_log"; then
    cat "$skips_log" >&2
    exit 1
fi
cat "$skips_log" >&2
mapfile -t skips <"$skips_args"
separator=(--)
for a in "$@"; do [[ "$a" == -- ]] && separator=(); done
cargo test --locked --workspace --tests "$@" "${separator[@]}" "${skips[@]}"
# The occlusion figures of docs/depth.md come from a cargo example (benches/occlusion_figure.rs)
# that tests/first_run.rs, which checks the other pictures, cannot build: check them here.
figures="$(mktemp -d)"
trap 'rm -rf "$figures" "$skips_log" "$skips_args"' EXIT
# (built with the same features as the tests': `cargo run` cannot take --workspace)
cargo build --locked --quiet --workspace --profile test --example occlusion_figure
"${CARGO_TARGET_DIR:-target}/debug/examples/occlusion_figure" "$figures" >/dev/null
for made in "$figures"/*.png; do
    cmp -s "$made" "docs/images/$(basename "$made")" || {
        echo "docs/images/$(basename "$made") is not what scripts/make_doc_images.sh makes: run it" >&2
        exit 1
    }
done
# The Python package (built above): the module built by `maturin develop` (sharing target/),
# the command the test build made; pytest runs against both.
# -rs: a test skipped for want of ../shared is named with its reason
"$PANOCONV_PYTHON" -m pytest -q -rs --no-fold-skipped -p no:cacheprovider python/tests
# the skipped tests last, where they are seen
cat "$skips_log" >&2
