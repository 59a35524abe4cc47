#!/usr/bin/env bash
# The tests of tests/needs_shared.txt whose data is absent: one `--skip NAME` pair of lines per
# test on stdout (the arguments scripts/test.sh gives the test binaries), and on stderr one line
# per skipped test and the count. The data: the real KITTI frames ($PANOCONV_KITTI, else
# $PANOCONV_SHARED/kitti), the panoramas ($PANOCONV_SHARED/pano) and the PandaSet frames
# ($PANOCONV_SHARED/pandaset/002); $PANOCONV_SHARED defaults to
# ../shared beside the repository. When the data must be there (CI=true or
# PANOCONV_REQUIRE_SHARED=1), absent data is an error instead (exit 1, naming what is missing).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
shared="${PANOCONV_SHARED:-../shared}"
declare -A where=([kitti]="${PANOCONV_KITTI:-$shared/kitti}" [pano]="$shared/pano" [pandaset]="$shared/pandaset/002")
required=0
[[ "${CI:-}" == true || "${PANOCONV_REQUIRE_SHARED:-}" == 1 ]] && required=1
absent=()
for data in kitti pano pandaset; do
    [[ -d "${where[$data]}" ]] || absent+=("$data")
done
if ((${#absent[@]} > 0 && required)); then
    for data in "${absent[@]}"; do
        echo "shared data missing: $data is not at ${where[$data]} (required: CI=true or PANOCONV_REQUIRE_SHARED=1); put the project's shared/ folder beside the repository" >&2
    done
    exit 1
fi
skipped=0
while read -r name data; do
    [[ -z "$name" || "$name" == \#* ]] && continue
    for a in "${absent[@]}"; do
        if [[ "$a" == "$data" ]]; then
            printf -- '--skip\n%s\n' "$name"
            echo "skipped: $name (needs $data: ${where[$data]} is absent)" >&2
            skipped=$((skipped + 1))
        fi
    done
done <tests/needs_shared.txt
if ((skipped > 0)); then
    echo "$skipped tests skipped: their shared data is absent (tests/needs_shared.txt)" >&2
fi
