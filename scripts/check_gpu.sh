#!/usr/bin/env bash
# The GPU check of the style pass, in one command on a machine with an NVIDIA GPU:
#   1. installs the GPU variant of ONNX Runtime (`scripts/install_ort.sh --gpu`; from the wheels
#      in DIR with `--wheels DIR`, for a machine without network; skipped when <repo>/.ort-gpu/
#      is already installed);
#   2. converts the shipped sample (fixtures/synthetic_kitti) with `--style` on the CPU and with
#      `--device cuda`, through the same library, for each model: the fixtures' miniature
#      generator, and the real vintagify generator when .style/vintagify.onnx exists
#      (scripts/make_vintagify_onnx.sh);
#   3. prints the largest difference per pixel channel between the two outputs and how many
#      values differ; exit 1 when a run fails or a difference exceeds MAX_DIFF (default 2).
#
#   scripts/check_gpu.sh [--wheels DIR] [--bin PANOCONV]
# PANOCONV: the binary (default target/release/panoconv, built when cargo is there).
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"
wheels=() bin="" max="${MAX_DIFF:-2}"
while [[ $# -gt 0 ]]; do
    case "$1" in
        --wheels) wheels=(--wheels "${2:?--wheels needs a folder}"); shift ;;
        --bin) bin="${2:?--bin needs a path}"; shift ;;
        *) echo "check_gpu: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
if [[ -z "$bin" ]]; then
    bin="$REPO/target/release/panoconv"
    if command -v cargo >/dev/null 2>&1; then
        cargo build --release --locked --quiet --bin panoconv
    fi
fi
[[ -x "$bin" ]] || { echo "check_gpu: no panoconv binary at $bin (give --bin)" >&2; exit 2; }
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
lib="$(scripts/install_ort.sh --gpu "${wheels[@]}" | tail -n 1)"
echo "library: $lib"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
models=(fixtures/style/generator.onnx)
[[ -f .style/vintagify.onnx ]] && models+=(.style/vintagify.onnx)
status=0
for model in "${models[@]}"; do
    name="$(basename "$model" .onnx)"
    for device in cpu cuda; do
        start=$(date +%s%N)
        if ! "$bin" kitti --to equirect --input fixtures/synthetic_kitti --output "$work/$name-$device" \
            --style "$model" --device "$device" --ort-lib "$lib" --quiet 2>"$work/$name-$device.err"; then
            echo "FAIL $name --device $device:"; cat "$work/$name-$device.err"; status=1; continue 2
        fi
        echo "$name --device $device: $((($(date +%s%N) - start) / 1000000)) ms"
    done
    python3 - "$work/$name-cpu" "$work/$name-cuda" "$max" "$name" <<'PY' || status=1
import pathlib, struct, sys, zlib

def pixels(path):
    """8-bit RGB/RGBA/grey PNG (what panoconv writes) as bytes, filters undone."""
    data = path.read_bytes()
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, depth, ctype = ihdr[:4]
    assert depth == 8, f"{path}: bit depth {depth}"
    bpp = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
    raw, stride, out, prev = zlib.decompress(idat), w * bpp, bytearray(), bytearray(w * bpp)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out += line
        prev = line
    return out

cpu, cuda, limit, name = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
worst, differ, total = 0, 0, 0
for p in sorted(cpu.rglob("image_*/*.png")):
    a, b = pixels(p), pixels(cuda / p.relative_to(cpu))
    assert len(a) == len(b), p
    d = [abs(x - y) for x, y in zip(a, b)]
    worst, differ, total = max(worst, max(d)), differ + sum(1 for v in d if v), total + len(d)
print(f"{name}: cuda vs cpu: max difference {worst} levels, {differ} of {total} values differ")
sys.exit(0 if worst <= limit and total else 1)
PY
done
exit $status
