#!/usr/bin/env python3
"""Side-by-side run (called by benches/run.sh, which builds and sets up the venv).

Builds an N-frame KITTI set from $PANOCONV_KITTI, default ../shared/kitti (the 7 real frames
copied under N ids, in a temporary folder), then runs, alternately for several rounds:
  panoconv     `panoconv kitti --to equirect --quiet` (release build)
  opencv       benches/opencv_convert.py (cv2.imread / remap CV_16SC2 / imwrite, Pool of J)
  floor        benches/codec_floor.rs: read + decode every input, encode its warped image, no warp
  io_floor     the floor plus the I/O every converted frame does: the manifest's BLAKE3 of the
               input and the output PNG, and the output PNG's atomic write (codec_floor --io)
and prints medians of wall time, frames/s, CPU seconds (user+sys of the process tree, from
wait4) and peak RSS (largest single process), plus output bytes and the ratios.
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def run(cmd):
    """Runs cmd; returns (wall s, cpu s of its process tree, peak RSS MB, stdout)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=out, stderr=err, text=True)
        # wait4: the child's own rusage, including its reaped children (the Pool workers);
        # ru_maxrss is then the largest single process.
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if p.returncode != 0:
            sys.exit(f"{cmd[0]} failed ({p.returncode}):\n{err.read()}")
        return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024, out.read()


def make_set(src, dst, n):
    """n frames: copies of src's frames (training and testing) under ids 000000..n-1."""
    base = []
    for split in ("training", "testing"):
        d = os.path.join(src, split, "image_2")
        if os.path.isdir(d):
            base += [(split, f[:-4]) for f in sorted(os.listdir(d)) if f.endswith(".png")]
    pairs = []
    for i in range(n):
        split, fid = base[i % len(base)]
        new = f"{i:06d}"
        for sub, ext in (("image_2", ".png"), ("calib", ".txt"), ("label_2", ".txt")):
            s = os.path.join(src, split, sub, fid + ext)
            if os.path.exists(s):
                os.makedirs(os.path.join(dst, split, sub), exist_ok=True)
                shutil.copyfile(s, os.path.join(dst, split, sub, new + ext))
        pairs.append((os.path.join(dst, split, "image_2", new + ".png"), split, fid))
    return pairs


def image_bytes(out):
    total = 0
    for split in ("training", "testing"):
        d = os.path.join(out, split, "image_2")
        if os.path.isdir(d):
            total += sum(os.path.getsize(os.path.join(d, f)) for f in os.listdir(d))
    return total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--floor", required=True)
    ap.add_argument("--kitti", default=os.path.join(ROOT, os.environ.get("PANOCONV_KITTI") or "../shared/kitti"))
    ap.add_argument("--frames", type=int, default=210)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=os.cpu_count())
    ap.add_argument("--compression", default="default")
    ap.add_argument("--tmp", default=None, help="where the frame sets go (default: $TMPDIR)")
    ap.add_argument("--only", default="panoconv,opencv,floor,io_floor")
    ap.add_argument("--json", default=None, help="also write the medians here")
    ap.add_argument("--old", default=None,
                    help="an earlier panoconv binary, run as 'old' in the same rounds")
    a = ap.parse_args()

    kitti = os.path.abspath(a.kitti)
    tmp = tempfile.mkdtemp(prefix="panoconv-bench-", dir=a.tmp)
    try:
        ref = os.path.join(tmp, "ref")
        run([a.bin, "kitti", "--to", "equirect", "--quiet", "--input", kitti, "--output", ref])
        data = os.path.join(tmp, "in")
        pairs = make_set(kitti, data, a.frames)
        pairs_file = os.path.join(tmp, "pairs.txt")
        with open(pairs_file, "w") as f:
            for inp, split, fid in pairs:
                f.write(f"{inp} {os.path.join(ref, split, 'image_2', fid + '.png')}\n")

        def panoconv(binary=a.bin):
            out = os.path.join(tmp, "out-panoconv")
            shutil.rmtree(out, ignore_errors=True)
            r = run([binary, "kitti", "--to", "equirect", "--quiet", "--jobs", str(a.jobs),
                     "--png-compression", a.compression, "--input", data, "--output", out])
            return r[:3] + (image_bytes(out),)

        def opencv():
            out = os.path.join(tmp, "out-opencv")
            shutil.rmtree(out, ignore_errors=True)
            r = run([sys.executable, os.path.join(HERE, "opencv_convert.py"), "--input", data,
                     "--output", out, "--ref", ref, "--jobs", str(a.jobs)])
            return r[:3] + (image_bytes(out),)

        def floor():
            wall, cpu, rss, out = run([a.floor, "--pairs", pairs_file, "--jobs", str(a.jobs),
                                       "--compression", a.compression])
            j = json.loads(out)
            return j["seconds"], cpu, rss, j["bytes"]

        def io_floor():
            out = os.path.join(tmp, "out-io-floor")
            shutil.rmtree(out, ignore_errors=True)
            os.mkdir(out)
            wall, cpu, rss, stdout = run([a.floor, "--pairs", pairs_file, "--jobs", str(a.jobs),
                                          "--compression", a.compression, "--io", out])
            j = json.loads(stdout)
            return j["seconds"], cpu, rss, j["bytes"]

        runners = {"panoconv": panoconv, "opencv": opencv, "floor": floor, "io_floor": io_floor,
                   "old": lambda: panoconv(a.old)}
        names = [n for n in a.only.split(",") if n] + (["old"] if a.old else [])
        results = {n: [] for n in names}
        loads = {n: [] for n in names}
        for r in range(a.rounds):
            order = names if r % 2 == 0 else names[::-1]
            for n in order:
                before = os.getloadavg()[0]
                results[n].append(runners[n]())
                w, c, m, b = results[n][-1]
                # the 1-minute load average before and after: how busy the shared machine was
                loads[n].append((before, os.getloadavg()[0]))
                print(f"round {r} {n:9s} wall {w:7.3f} s  {a.frames / w:7.1f} fr/s  cpu {c:7.2f} s"
                      f"  rss {m:6.1f} MB  bytes {b}  load {before:.1f}-{loads[n][-1][1]:.1f}",
                      file=sys.stderr)

        med = {}
        for n, rs in results.items():
            walls = [x[0] for x in rs]
            med[n] = {
                "wall_s": statistics.median(walls),
                "wall_min_s": min(walls),
                "wall_max_s": max(walls),
                "fps": a.frames / statistics.median(walls),
                "cpu_s": statistics.median([x[1] for x in rs]),
                "peak_rss_mb": max(x[2] for x in rs),
                "bytes": rs[-1][3],
                "load_min": min(min(x) for x in loads[n]),
                "load_max": max(max(x) for x in loads[n]),
            }
        print(f"\n{a.frames} frames, {a.rounds} rounds, --jobs {a.jobs}, {os.cpu_count()} cores,"
              f" compression {a.compression}, in {tmp}")
        print(f"{'':10s} {'wall s (min-max)':>22s} {'frames/s':>9s} {'CPU s':>7s} {'CPU ms/fr':>9s}"
              f" {'RSS MB':>7s} {'bytes':>11s} {'load':>9s}")
        for n, m in med.items():
            print(f"{n:10s} {m['wall_s']:7.3f} ({m['wall_min_s']:.3f}-{m['wall_max_s']:.3f})"
                  f" {m['fps']:9.1f} {m['cpu_s']:7.2f} {1e3 * m['cpu_s'] / a.frames:9.2f}"
                  f" {m['peak_rss_mb']:7.1f} {m['bytes']:11d}"
                  f" {m['load_min']:4.1f}-{m['load_max']:.1f}")
        all_loads = [x for ls in loads.values() for l in ls for x in l]
        load_note = f"load {min(all_loads):.1f}-{max(all_loads):.1f}" if all_loads else "load ?"

        def paired(other, i=0):
            """Per round, other's wall time (i=0) or CPU time (i=1) over panoconv's (the two ran
            minutes apart at most, so a slow spell of a shared machine slows both): median and
            range."""
            rs = [o[i] / p[i] for p, o in zip(results["panoconv"], results[other])]
            return f"per round {statistics.median(rs):.2f}x ({min(rs):.2f}-{max(rs):.2f})"

        if "panoconv" in med and "opencv" in med:
            p, o = med["panoconv"], med["opencv"]
            print(f"panoconv/opencv: {p['fps'] / o['fps']:.2f}x frames/s"
                  f" [{paired('opencv')}],"
                  f" {p['cpu_s'] / o['cpu_s']:.2f}x CPU [{paired('opencv', 1)} less],"
                  f" {p['bytes'] / o['bytes']:.3f}x bytes ({load_note})")
        if "panoconv" in med and "floor" in med:
            p, f = med["panoconv"], med["floor"]
            inv = [p_[0] / f_[0] for p_, f_ in zip(results["panoconv"], results["floor"])]
            inv_cpu = [p_[1] / f_[1] for p_, f_ in zip(results["panoconv"], results["floor"])]
            print(f"panoconv/floor: {p['wall_s'] / f['wall_s']:.2f}x wall"
                  f" [per round {statistics.median(inv):.2f}x ({min(inv):.2f}-{max(inv):.2f})],"
                  f" {p['cpu_s'] / f['cpu_s']:.2f}x CPU [per round {statistics.median(inv_cpu):.2f}x"
                  f" ({min(inv_cpu):.2f}-{max(inv_cpu):.2f})] ({load_note})")
        if "panoconv" in med and "io_floor" in med:
            p, f = med["panoconv"], med["io_floor"]
            inv = [p_[0] / f_[0] for p_, f_ in zip(results["panoconv"], results["io_floor"])]
            print(f"panoconv/io_floor: {p['wall_s'] / f['wall_s']:.2f}x wall"
                  f" [per round {statistics.median(inv):.2f}x ({min(inv):.2f}-{max(inv):.2f})],"
                  f" {p['cpu_s'] / f['cpu_s']:.2f}x CPU ({load_note})")
        if "floor" in med and "io_floor" in med:
            f, i = med["floor"], med["io_floor"]
            print(f"io_floor/floor: {i['wall_s'] / f['wall_s']:.2f}x wall,"
                  f" {i['cpu_s'] / f['cpu_s']:.2f}x CPU: what the frame's writes and manifest"
                  f" hashes add to the floor ({load_note})")
        if "panoconv" in med and "old" in med:
            p, o = med["panoconv"], med["old"]
            print(f"panoconv/old: {p['fps'] / o['fps']:.2f}x frames/s [{paired('old')}],"
                  f" {p['cpu_s'] / o['cpu_s']:.2f}x CPU, {p['bytes'] / o['bytes']:.3f}x bytes"
                  f" ({load_note})")
        if a.json:
            with open(a.json, "w") as f:
                json.dump({"frames": a.frames, "jobs": a.jobs, "medians": med}, f, indent=1)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
