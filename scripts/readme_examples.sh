#!/usr/bin/env bash
# Runs the README's "Use" block as it stands in README.md, line by line and top to bottom, from
# the repository root (on the shipped sample and camera files), printing each command with the
# last lines of its standard error and its exit code, then `panoconv verify` on every dataset
# the block wrote. A transcript for people; the test suite checks the same behaviours one by one.
#
# Usage: scripts/readme_examples.sh [PANOCONV_BINARY]   (default: panoconv on the PATH, else
# target/release/panoconv, else target/debug/panoconv). With PANOCONV_EXAMPLES_DIR=DIR (a new
# folder) the block's $W is DIR and kept, every step's standard output appended to
# DIR/stdout.log. Exit status: the number of failed steps (0: every line succeeded).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$(pwd)"
bin="${1:-}"
[[ -z "$bin" || "$bin" = /* ]] || bin="$repo/$bin"
if [[ -z "$bin" ]]; then
    bin="$(command -v panoconv || true)"
    [[ -n "$bin" ]] || bin="$repo/target/release/panoconv"
    [[ -x "$bin" ]] || bin="$repo/target/debug/panoconv"
fi
[[ -x "$bin" ]] || { echo "no panoconv binary: cargo build first" >&2; exit 2; }
panoconv() { "$bin" "$@"; }

# The indented block that follows the "## Use" heading.
mapfile -t lines < <(awk '
    /^## Use/ { inside = 1; next }
    inside && /^## / { exit }
    inside && /^    / { started = 1; print substr($0, 5); next }
    inside && started && /^$/ { exit }
' README.md)
[[ ${#lines[@]} -gt 0 ]] || { echo "README.md: no Use block" >&2; exit 2; }

log=/dev/null
failures=0
echo "# README.md's Use block, ${#lines[@]} lines, $("$bin" --version), from $repo"
for line in "${lines[@]}"; do
    echo "\$ $line"
    out="$(mktemp)" err="$(mktemp)"
    eval "$line" >"$out" 2>"$err"
    code=$?
    if [[ "$line" == W=* && -n "${PANOCONV_EXAMPLES_DIR:-}" ]]; then
        rmdir "$W"
        W="$PANOCONV_EXAMPLES_DIR"
        mkdir "$W" || exit 2
        log="$W/stdout.log"
    fi
    { echo "\$ $line"; cat "$out"; } >>"$log"
    sed 's/^/    /' "$err" | tail -n 4
    echo "    -> exit $code"
    rm -f "$out" "$err"
    if [[ $code -ne 0 ]]; then
        echo "    !! failed"
        failures=$((failures + 1))
    fi
done
echo "# every dataset the block wrote, verified"
while IFS= read -r manifest; do
    dir="$(dirname "$manifest")"
    echo "\$ panoconv verify ${dir/#$W/\$W}"
    panoconv verify "$dir" | tail -n 1 | sed 's/^/    /'
    code=${PIPESTATUS[0]}
    if [[ $code -ne 0 ]]; then
        echo "    !! failed"
        failures=$((failures + 1))
    fi
done < <(find "$W" -maxdepth 2 -name panoconv.json | sort)
echo "# $failures failed"
[[ -z "${PANOCONV_EXAMPLES_DIR:-}" ]] && rm -rf "$W"
exit "$failures"
