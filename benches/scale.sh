#!/usr/bin/env bash
# Scale benchmark of issue 18: the release binary of this checkout against the one of OLD_REF
# (a commit: the "before"), 1 000 and 100 000 frames, same file system, same run (benches/scale.py).
#   OLD_REF=7464402 benches/scale.sh [--frames 1000 100000] [--tmp DIR] [-- panoconv options]
# The old binary is built from `git archive OLD_REF` into $OLD_DIR (default /tmp/panoconv-old),
# outside the repository. Output folders and frame sets live in --tmp and are removed after.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
old_ref="${OLD_REF:?set OLD_REF to the commit to compare against}"
old_dir="${OLD_DIR:-/tmp/panoconv-old}"
(cd "$root" && cargo build --release --quiet --bin panoconv)
rev="$(git -C "$root" rev-parse --short "$old_ref")"
if [ ! -x "$old_dir/target/release/panoconv" ] || [ "$(cat "$old_dir/rev" 2>/dev/null)" != "$rev" ]; then
    rm -rf "$old_dir/src-tree" && mkdir -p "$old_dir/src-tree"
    git -C "$root" archive "$old_ref" | tar -x -C "$old_dir/src-tree"
    (cd "$old_dir/src-tree" && cargo build --release --quiet --bin panoconv --target-dir "$old_dir/target")
    echo "$rev" >"$old_dir/rev"
fi
target="${CARGO_TARGET_DIR:-$root/target}"
exec python3 "$here/scale.py" --bin "old=$old_dir/target/release/panoconv" \
    --bin "new=$target/release/panoconv" "$@"
