"""What a Python rig source costs beside the conversion itself, on a PandaSet sequence:

    python scripts/rig_source_speed.py SEQ SCRATCH [rig options...]

1. the adapter's own reads (`PandaSet.read` of every frame), timed alone;
2. `convert_rig` over those frames already read (the adapter's reading aside): the Python
   side's serialising of each frame, the pipe, the command's checks, and the conversion;
3. the same answers encoded beforehand and replayed to `panoconv rig-stream` byte for byte:
   the conversion with the pipe and the checks, and no Python work per frame.

(2) − (3) is what the Python side adds per run. Each conversion runs `--repeat` times (default
3); the best wall time of each is printed, and the CPU time of the command (its children's
rusage) and of this Python process, which a loaded machine disturbs less. The outputs of (2)
and (3) are compared byte for byte.
"""

from __future__ import annotations

import filecmp
import json
import os
import resource
import shutil
import subprocess
import sys
import time

import panoconv
from panoconv import rig
from panoconv.sources.pandaset import PandaSet


def replay(answers: dict, output: str, args: list) -> int:
    """`panoconv rig-stream` fed the encoded answers of `answers` (request key → bytes)."""
    argv = [rig.command(), "rig-stream", "--output", output, *args]
    proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    for line in proc.stdout:
        request = json.loads(line)
        proc.stdin.write(answers[request.get("frame", "open")])
        proc.stdin.flush()
    proc.stdin.close()
    return proc.wait()


def encode(header: dict, payload: bytes) -> bytes:
    header["bytes"] = len(payload)
    return json.dumps(header, allow_nan=False).encode() + b"\n" + payload


def same_tree(a: str, b: str) -> bool:
    for root, _, files in os.walk(a):
        for f in files:
            x = os.path.join(root, f)
            y = os.path.join(b, os.path.relpath(x, a))
            if not (os.path.isfile(y) and filecmp.cmp(x, y, shallow=False)):
                return False
    return True


def main() -> int:
    seq, scratch, args = sys.argv[1], sys.argv[2], sys.argv[3:]
    repeat = 3
    if "--repeat" in args:
        k = args.index("--repeat")
        repeat = int(args[k + 1])
        del args[k : k + 2]
    args = [*args, "--quiet"]
    source = PandaSet(seq)
    t = time.perf_counter()
    frames = {f: source.read(f) for f in source.frames()}
    read_s = time.perf_counter() - t

    class Read(PandaSet):
        def read(self, frame_id):
            return frames[frame_id]

    cached = Read(seq)
    answers = {"open": encode(rig._open(cached), b"")}
    for f in frames:
        answers[f] = encode(*rig._read(cached, f))
    best = {"python": float("inf"), "replay": float("inf")}
    command_cpu = {"python": float("inf"), "replay": float("inf")}
    python_cpu = {"python": float("inf"), "replay": float("inf")}
    for i in range(repeat):
        # alternate the order: on a loaded machine the first of a pair is often the slower
        for route in list(best) if i % 2 == 0 else list(best)[::-1]:
            out = os.path.join(scratch, route)
            shutil.rmtree(out, ignore_errors=True)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t, cpu = time.perf_counter(), time.process_time()
            code = panoconv.convert_rig(cached, out, args) if route == "python" else replay(answers, out, args)
            best[route] = min(best[route], time.perf_counter() - t)
            python_cpu[route] = min(python_cpu[route], time.process_time() - cpu)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            used = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
            command_cpu[route] = min(command_cpu[route], used)
            assert code == 0, (route, code)
    same = same_tree(os.path.join(scratch, "python"), os.path.join(scratch, "replay"))
    n = len(frames)
    print(f"{n} frames; the adapter's reads: {read_s:.2f} s ({read_s / n:.3f} s/frame)")
    print(f"convert_rig over read frames: {best['python']:.2f} s; replayed answers: {best['replay']:.2f} s")
    print(f"the command's CPU: {command_cpu['python']:.2f} s and {command_cpu['replay']:.2f} s; this process's CPU: {python_cpu['python']:.2f} s and {python_cpu['replay']:.2f} s")
    total = lambda r: command_cpu[r] + python_cpu[r]  # noqa: E731
    print(f"the Python side adds {100 * (best['python'] / best['replay'] - 1):+.1f} % wall, {100 * (total('python') / total('replay') - 1):+.1f} % CPU; same bytes: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
