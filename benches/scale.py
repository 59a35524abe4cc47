#!/usr/bin/env python3
"""Scale benchmark (issue 18): frames/s, peak RSS and time to the first finished frame of
`panoconv kitti --to equirect` at 1 000 and 100 000 frames, for two binaries (before and
after), on one file system in one run.

The frame sets are the real frames of $PANOCONV_KITTI/training (default ../shared/kitti)
hard-linked round-robin under new ids (no image data is copied). Each run writes into a fresh output folder, removed after.
Peak RSS is the child's ru_maxrss from wait4; the first frame is the first complete PNG in
OUT/training/image_2 (written by rename, so a visible name is a whole file).

    benches/scale.py --bin new=target/release/panoconv --bin old=/tmp/old/panoconv \
        --frames 1000 100000 --tmp /tmp/scale-bench [-- extra panoconv options]
"""

import argparse
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def make_dataset(root: Path, n: int, source: Path) -> Path:
    """`n` frames under training/, each a hard link to one of the source frames in turn."""
    ids = sorted(p.stem for p in (source / "image_2").glob("*.png"))
    d = root / f"kitti-{n}"
    if (d / "done").exists():
        return d
    shutil.rmtree(d, ignore_errors=True)
    for sub, ext in (("image_2", "png"), ("label_2", "txt"), ("calib", "txt")):
        (d / "training" / sub).mkdir(parents=True)
        for i in range(n):
            src = source / sub / f"{ids[i % len(ids)]}.{ext}"
            os.link(src, d / "training" / sub / f"{i:06d}.{ext}")
    (d / "done").touch()
    return d


def first_png(folder: Path) -> bool:
    try:
        with os.scandir(folder) as it:
            return any(e.name.endswith(".png") and not e.name.startswith(".") for e in it)
    except FileNotFoundError:
        return False


def run(binary: str, data: Path, out: Path, extra: list[str], timeout: float) -> dict:
    shutil.rmtree(out, ignore_errors=True)
    cmd = [binary, "kitti", "--to", "equirect", "--input", str(data), "--output", str(out),
           "--jobs", "2", "--quiet", *extra]
    t0 = time.monotonic()
    child = subprocess.Popen(cmd, stderr=subprocess.PIPE)
    images = out / "training" / "image_2"
    # wait4, not Popen.poll: the rusage of the child comes with its exit status
    ended = None

    def reap():
        nonlocal ended
        if ended is None:
            pid, status, usage = os.wait4(child.pid, os.WNOHANG)
            if pid:
                ended = (status, usage)
        return ended is not None

    first = None
    while first is None and not reap():
        if first_png(images):
            first = time.monotonic() - t0
        else:
            time.sleep(0.005)
    while not reap() and time.monotonic() - t0 < timeout:
        time.sleep(0.05)
    timed_out = ended is None
    if timed_out:
        child.kill()
        _, status, usage = os.wait4(child.pid, 0)
    else:
        status, usage = ended
    wall = time.monotonic() - t0
    err = child.stderr.read().decode(errors="replace")
    done = sum(1 for e in os.scandir(images) if not e.name.startswith(".")) if images.exists() else 0
    manifest = out / "panoconv.json"
    result = {
        "wall": wall,
        "frames_done": done,
        "fps": done / wall,
        "rss_mb": usage.ru_maxrss / 1024,
        "first": first,
        "manifest_mb": manifest.stat().st_size / 1e6 if manifest.exists() else None,
        "timed_out": timed_out,
        "status": status,
    }
    if not timed_out and os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{err}")
    shutil.rmtree(out, ignore_errors=True)
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--bin", action="append", required=True, help="NAME=PATH (repeatable)")
    ap.add_argument("--frames", type=int, nargs="+", default=[1000, 100000])
    ap.add_argument("--tmp", type=Path, default=Path("/tmp/panoconv-scale-bench"))
    ap.add_argument("--source", type=Path, default=ROOT / (os.environ.get("PANOCONV_KITTI") or "../shared/kitti") / "training")
    ap.add_argument("--timeout", type=float, default=1200, help="seconds a run may take")
    ap.add_argument("--keep-data", action="store_true")
    ap.add_argument("extra", nargs="*", help="more panoconv options (after --)")
    a = ap.parse_args()
    bins = [b.split("=", 1) for b in a.bin]
    a.tmp.mkdir(parents=True, exist_ok=True)
    print(f"# {os.uname().nodename}, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}; "
          f"file system of {a.tmp}: {fs_type(a.tmp)}; options: --jobs 2 {' '.join(a.extra)}",
          flush=True)
    rows = []
    for n in a.frames:
        t = time.monotonic()
        data = make_dataset(a.tmp, n, a.source)
        print(f"# {n} frames hard-linked in {time.monotonic() - t:.1f} s", flush=True)
        for name, binary in bins:
            before = os.getloadavg()[0]
            r = run(binary, data, a.tmp / "out", a.extra, a.timeout)
            r["load"] = f"{before:.1f}-{os.getloadavg()[0]:.1f}"
            rows.append((name, n, r))
            print(f"{name} {n}: {r}", flush=True)
        if not a.keep_data:
            shutil.rmtree(data)
    print()
    print("| binary | frames | wall s | frames/s | vs same binary at the fewest frames | peak RSS MB "
          "| first frame s | panoconv.json MB | load average (1 min, before-after) |")
    print("|---|---|---|---|---|---|---|---|---|")
    base = {}
    for name, n, r in rows:
        base.setdefault(name, r["fps"])
        done = f"{r['frames_done']} of {n} (killed at the time limit)" if r["timed_out"] else f"{n}"
        manifest = f"{r['manifest_mb']:.1f}" if r["manifest_mb"] else "—"
        first = f"{r['first']:.2f}" if r["first"] is not None else "—"
        print(f"| {name} | {done} | {r['wall']:.1f} | {r['fps']:.0f} | "
              f"{100 * r['fps'] / base[name]:.0f} % | {r['rss_mb']:.0f} | {first} | {manifest} "
              f"| {r['load']} |")


def fs_type(path: Path) -> str:
    best = ("", "?")
    for line in Path("/proc/mounts").read_text().splitlines():
        _, mount, kind, *_ = line.split()
        if str(path.resolve()).startswith(mount) and len(mount) > len(best[0]):
            best = (mount, kind)
    return best[1]


if __name__ == "__main__":
    main()
