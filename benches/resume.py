#!/usr/bin/env python3
"""Resume and merge at scale: peak RSS, wall time, frames/s and time to the first new frame of
`panoconv kitti --resume` and of `panoconv merge`, for several binaries on the same states.

For each frame count N, a state is made once with the first binary given (the frames of
$PANOCONV_KITTI/training hard-linked round-robin under N ids, as benches/scale.py does):
  - parts: `kitti --to equirect --shard 0/2` and `--shard 1/2` into one folder (the input of
    `merge`);
  - killed: the parts merged, then the last `--redo` fraction of the frames dropped from the
    manifest (`"complete": false`) and their outputs removed, as a run stopped before them
    leaves it (the input of `--resume`: most frames to re-check and keep, the rest to convert).
A state already in --tmp from an earlier call (same N) is reused.
Each binary then runs `merge` on a copy of the parts' manifests and `--resume` on a
hard-linked copy of the killed state (safe: panoconv writes every file by a rename). The
first new frame is the first moment one of the dropped frames' image_2 PNGs exists.
Each binary also makes its own early-killed state and resumes it: a fresh run SIGKILLed as
soon as its journal holds the `--early` fraction of the frames (no manifest yet: the records
are the journal's, most frames are still to convert), then `--resume` to the end ("kill" and
"resume-early" rows, "resume" being the late kill above). Every figure line carries the load
average.

    benches/resume.py --bin new=target/release/panoconv --bin old=/tmp/old/panoconv \
        --frames 1000 100000 --tmp /tmp/resume-bench [-- extra panoconv options]
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scale import ROOT, fs_type, make_dataset  # noqa: E402


def load() -> str:
    return "load " + " ".join(f"{x:.1f}" for x in os.getloadavg())


def timed(cmd: list[str], watch: list[Path] | None = None,
          kill_at: tuple[Path, int] | None = None) -> dict:
    """Runs `cmd`: wall, peak RSS (wait4) and, with `watch`, when one of those files first
    exists (polled every 20 ms: a few stat calls, not a listing of 100 000 files). With
    `kill_at` (journal, k) the process is SIGKILLed once that journal holds k frame lines."""
    t0 = time.monotonic()
    child = subprocess.Popen(cmd, stderr=subprocess.PIPE)
    first = first_cpu = None
    lines = JournalLines(kill_at[0]) if kill_at else None
    killed = False
    while True:
        pid, status, usage = os.wait4(child.pid, os.WNOHANG)
        if pid:
            break
        if watch and first is None and any(p.exists() for p in watch):
            first = time.monotonic() - t0
            first_cpu = cpu_seconds(child.pid)
        if lines and not killed and lines.frames() >= kill_at[1]:
            child.kill()
            killed = True
        time.sleep(0.02)
    wall = time.monotonic() - t0
    err = child.stderr.read().decode(errors="replace")
    if killed:
        if os.WIFSIGNALED(status) and os.WTERMSIG(status) == 9:
            return {"wall": wall, "rss_mb": usage.ru_maxrss / 1024, "first": None,
                    "first_cpu": None, "cpu": usage.ru_utime + usage.ru_stime,
                    "frames": lines.frames()}
        sys.exit(f"{' '.join(cmd)} was to be killed, but ended first:\n{err}")
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{err}")
    return {"wall": wall, "rss_mb": usage.ru_maxrss / 1024, "first": first,
            "first_cpu": first_cpu, "cpu": usage.ru_utime + usage.ru_stime}


class JournalLines:
    """The frame lines of a growing journal, counted from the bytes appended since the last
    call (the first line is the header)."""

    def __init__(self, path: Path):
        self.path, self.read, self.newlines = path, 0, 0

    def frames(self) -> int:
        try:
            with self.path.open("rb") as f:
                f.seek(self.read)
                chunk = f.read()
        except FileNotFoundError:
            return 0
        self.read += len(chunk)
        self.newlines += chunk.count(b"\n")
        return max(0, self.newlines - 1)


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds a live process has used so far (its threads included): on a
    loaded machine, the part of the wait that is the program's own work."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def drop_last(out: Path, k: int) -> None:
    """Drops the last `k` frames of OUT's manifest and removes their outputs."""
    path = out / "panoconv.json"
    doc = json.loads(path.read_text())
    doc["frames"], dropped = doc["frames"][:-k], doc["frames"][-k:]
    doc["complete"] = False
    for r in dropped:
        for rel, _ in r["outputs"]:
            (out / rel).unlink(missing_ok=True)
    path.write_text(json.dumps(doc, indent=2))


def convert(binary: str, data: Path, out: Path, extra: list[str], more: list[str]) -> list[str]:
    return [binary, "kitti", "--to", "equirect", "--input", str(data), "--output", str(out),
            "--jobs", "2", "--quiet", *extra, *more]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--bin", action="append", required=True, help="NAME=PATH (repeatable)")
    ap.add_argument("--frames", type=int, nargs="+", default=[1000, 100000])
    ap.add_argument("--tmp", type=Path, default=Path("/tmp/panoconv-resume-bench"))
    ap.add_argument("--source", type=Path,
                    default=ROOT / (os.environ.get("PANOCONV_KITTI") or "../shared/kitti") / "training")
    ap.add_argument("--keep-states", action="store_true", help="keep the frame sets and states")
    ap.add_argument("--redo", type=float, default=0.5,
                    help="fraction of the frames whose image_2 PNG is removed before --resume")
    ap.add_argument("--early", type=float, default=0.05,
                    help="fraction of the frames journalled when the early kill comes")
    ap.add_argument("extra", nargs="*", help="more panoconv options (after --)")
    a = ap.parse_args()
    bins = [b.split("=", 1) for b in a.bin]
    a.tmp.mkdir(parents=True, exist_ok=True)
    print(f"# {os.uname().nodename}, {os.cpu_count()} CPUs; file system of {a.tmp}: "
          f"{fs_type(a.tmp)}; options: --jobs 2 {' '.join(a.extra)}", flush=True)
    rows = []
    for n in a.frames:
        data = make_dataset(a.tmp, n, a.source)
        parts, half = a.tmp / f"parts-{n}", a.tmp / f"killed-{n}"
        shutil.rmtree(half, ignore_errors=True)
        t = time.monotonic()
        first_bin = bins[0][1]
        made = all((parts / f"panoconv.shard-{k}-of-2.json").exists() for k in (0, 1))
        if not made:
            shutil.rmtree(parts, ignore_errors=True)
            for k in (0, 1):
                timed(convert(first_bin, data, parts, a.extra, ["--shard", f"{k}/2"]))
        # hard links: no run writes into an existing file (every write is a rename)
        subprocess.run(["cp", "-al", str(parts), str(half)], check=True)
        timed([first_bin, "merge", str(half)])
        # in a process of its own: this one's peak RSS would be every child's floor (ru_maxrss
        # of a forked child starts from its parent's)
        dropped = max(1, round(n * a.redo))
        subprocess.run([sys.executable, __file__, "--drop-last", str(half), str(dropped)],
                       check=True)
        print(f"# {n} frames: states made in {time.monotonic() - t:.0f} s", flush=True)
        for name, binary in bins:
            for mode in ("merge", "resume"):
                work = a.tmp / "work"
                shutil.rmtree(work, ignore_errors=True)
                if mode == "merge":
                    # merge reads the parts' manifests only
                    work.mkdir()
                    for k in (0, 1):
                        shutil.copy(parts / f"panoconv.shard-{k}-of-2.json", work)
                else:
                    subprocess.run(["cp", "-al", str(half), str(work)], check=True)
                before = load()
                if mode == "merge":
                    r = timed([binary, "merge", str(work)])
                else:
                    images = work / "training" / "image_2"
                    r = timed(convert(binary, data, work, a.extra, ["--resume"]),
                              [images / f"{i:06d}.png" for i in range(n - dropped, n)])
                r["load"] = f"{before} / after {load()}"
                rows.append((name, mode, n, r))
                print(f"{name} {mode} {n}: {r}", flush=True)
                shutil.rmtree(work, ignore_errors=True)
            for mode, r in early_kill(binary, data, a.tmp / "work", n, a.early, a.extra):
                rows.append((name, mode, n, r))
                print(f"{name} {mode} {n}: {r}", flush=True)
        if not a.keep_states:
            for d in (parts, half, data):
                shutil.rmtree(d, ignore_errors=True)
    print()
    print("| binary | command | frames | wall s | CPU s | frames/s | vs same at the fewest frames "
          "| peak RSS MB | first new frame s (CPU s by then) | load average (1, 5, 15 min) "
          "before / after |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    base = {}
    for name, mode, n, r in rows:
        # a killed run did only its journalled frames
        fps = r.get("frames", n) / r["wall"]
        base.setdefault((name, mode), fps)
        first = "—"
        if r["first"] is not None:
            first = f"{r['first']:.2f} ({r['first_cpu']:.2f})"
        label = mode
        if "frames" in r:
            label = f"{mode} (after {r['frames']} frames)"
        elif "kept" in r:
            label = f"{mode} ({r['kept']} kept)"
        print(f"| {name} | {label} | {n} | {r['wall']:.1f} | {r['cpu']:.1f} | {fps:.0f} | "
              f"{100 * fps / base[(name, mode)]:.0f} % | {r['rss_mb']:.0f} | {first} | {r['load']} |")


def missing_pngs(images: Path, start: int, n: int, k: int) -> list[Path]:
    """The first `k` ids from `start` whose image_2 PNG does not exist (one stat each)."""
    out = []
    for i in range(start, n):
        p = images / f"{i:06d}.png"
        if not p.exists():
            out.append(p)
            if len(out) == k:
                break
    return out


def early_kill(binary: str, data: Path, work: Path, n: int, early: float,
               extra: list[str]) -> list[tuple[str, dict]]:
    """A fresh run SIGKILLed once its journal holds `early` of the `n` frames, then
    `--resume`d to the end: the figures of both."""
    shutil.rmtree(work, ignore_errors=True)
    journal = work / "panoconv.journal"
    before = load()
    killed = timed(convert(binary, data, work, extra, []), kill_at=(journal, max(1, round(n * early))))
    killed["load"] = f"{before} / after {load()}"
    before = load()
    kept = JournalLines(journal).frames()
    images = work / "training" / "image_2"
    # the resumed run converts the frames still to do first, from where each worker of the
    # killed run stopped: watch the first ids without a PNG from the start and from halfway
    todo = [p for start in (0, n // 2) for p in missing_pngs(images, start, n, 3)]
    resumed = timed(convert(binary, data, work, extra, ["--resume"]), todo)
    resumed["load"] = f"{before} / after {load()}"
    resumed["kept"] = kept
    shutil.rmtree(work, ignore_errors=True)
    return [("kill", killed), ("resume-early", resumed)]


if __name__ == "__main__":
    if sys.argv[1:2] == ["--drop-last"]:
        drop_last(Path(sys.argv[2]), int(sys.argv[3]))
    else:
        main()
