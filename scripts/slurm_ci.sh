#!/usr/bin/env bash
# The sharded recipe of docs/scaling.md on a real one-node Slurm cluster:
#   1. installs Slurm and MUNGE from Debian's packages when missing (as root, apt-get);
#   2. starts munged, slurmctld and slurmd with a private configuration in a work folder
#      (nothing under /etc is changed);
#   3. submits scripts/shard_job.sh as a 4-task array over copies of the real frames
#      ($PANOCONV_KITTI, default ../shared/kitti),
#      SIGKILLs one task's panoconv mid-run, re-submits that index (--resume completes it and
#      keeps the frames it had finished), and runs `merge` and `verify` as a dependent job;
#   4. compares every byte with one single-process run;
#   5. stops every daemon it started, by PID, also on failure.
# Usage: scripts/slurm_ci.sh   (PANOCONV=path/to/panoconv to skip the release build)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$PWD"
say() { printf 'slurm_ci: %s\n' "$*"; }
fail() {
    say "FAILED: $*"
    exit 1
}

kitti_src="${PANOCONV_KITTI:-../shared/kitti}"
kitti_src="$(realpath -m "$kitti_src")"
[ -d "$kitti_src/training/image_2" ] || fail "no KITTI frames in $kitti_src"
# docs/scaling.md shows scripts/shard_job.sh as it is
awk '/^## Slurm job array/ {on = 1} on && /^```bash$/ {getline; while ($0 != "```") {print; getline}; exit}' \
    docs/scaling.md | diff - scripts/shard_job.sh >/dev/null \
    || fail "docs/scaling.md's job script differs from scripts/shard_job.sh"
say "docs/scaling.md's job array script is scripts/shard_job.sh"

shards=4
victim=2    # the array index whose panoconv is SIGKILLed
copies=150  # ids per real frame: enough frames for the kill to land mid-run

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null \
    || ! command -v sbatch >/dev/null || ! command -v slurmd >/dev/null; then
    say "installing slurmctld slurmd slurm-client munge (apt-get)"
    [ "$(id -u)" = 0 ] || fail "installing Slurm needs root"
    export DEBIAN_FRONTEND=noninteractive
    install_slurm() { apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge; }
    # the package lists a machine already has first; `apt-get update` (seconds) only without them
    install_slurm >/dev/null 2>&1 || { apt-get update -qq >/dev/null && install_slurm >/dev/null; }
fi

if [ -z "${PANOCONV:-}" ]; then
    cargo build --release --locked --quiet --bin panoconv
    PANOCONV="${CARGO_TARGET_DIR:-$repo/target}/release/panoconv"
fi
PANOCONV="$(realpath "$PANOCONV")"
export PANOCONV

work="$(mktemp -d /tmp/panoconv-slurm.XXXXXX)"
chmod 700 "$work"
pids=()
cleanup() {
    local rc=$?
    if [ -n "${SLURM_CONF:-}" ] && [ -f "$work/slurmctld.pid" ]; then
        scancel --quiet --user=root >/dev/null 2>&1 || true
    fi
    # in reverse order of starting: slurmd, slurmctld, munged
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
        kill "${pids[i]}" 2>/dev/null || true
    done
    for p in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$p" 2>/dev/null || true
    done
    if [ "$rc" != 0 ]; then
        for log in "$work"/*.log "$work"/jobs/*.out; do
            [ -f "$log" ] && { say "--- $log (tail)"; tail -n 15 "$log"; }
        done
        say "work folder kept: $work"
    else
        rm -rf "$work"
        say "daemons stopped (pids ${pids[*]}), work folder removed"
    fi
    exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# --- the data: each real frame under $copies ids (hard links when the file system allows), in
# one process (a process per link took most of a minute)
input="$work/kitti"
python3 - "$kitti_src" "$input" "$copies" <<'PY'
import os, shutil, sys
source, target, copies = sys.argv[1], sys.argv[2], int(sys.argv[3])
for split in ("training", "testing"):
    for sub in ("image_2", "label_2", "calib"):
        folder = os.path.join(source, split, sub)
        if not os.path.isdir(folder):
            continue
        out = os.path.join(target, split, sub)
        os.makedirs(out, exist_ok=True)
        for n, name in enumerate(sorted(os.listdir(folder))):
            ext = name.rsplit(".", 1)[-1]
            for c in range(copies):
                made = os.path.join(out, f"{n * copies + c:06d}.{ext}")
                try:
                    os.link(os.path.join(folder, name), made)
                except OSError:
                    shutil.copyfile(os.path.join(folder, name), made)
PY
frames=$(find "$input" -path '*/image_2/*.png' | wc -l)
say "dataset: $frames frames ($copies ids for each frame of $kitti_src)"

# --- the reference: one process
"$PANOCONV" kitti --to equirect --input "$input" --output "$work/single" --jobs 2 --quiet
say "single-process run: $(find "$work/single" -type f | wc -l) files"

# --- the cluster
free_port() {
    local p
    while :; do
        p=$((20000 + RANDOM % 40000))
        (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null || { echo "$p"; return; }
    done
}
ctld_port=$(free_port)
slurmd_port=$(free_port)
[ "$ctld_port" != "$slurmd_port" ] || slurmd_port=$((ctld_port + 1))
mkdir -p "$work/state" "$work/spool" "$work/jobs" "$work/munge"
chmod 700 "$work/munge"
head -c 1024 /dev/urandom >"$work/munge/munge.key"
chmod 400 "$work/munge/munge.key"
sock="$work/munge/munge.socket"
munged --foreground --force --key-file="$work/munge/munge.key" --socket="$sock" \
    --pid-file="$work/munge/munged.pid" --seed-file="$work/munge/munged.seed" \
    --log-file="$work/munged.log" >"$work/munged.stderr" 2>&1 &
pids+=($!)
mem_mb=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2))
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=panoconvci
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$sock
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
MailProg=/bin/true
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SlurmdParameters=config_overrides
ReturnToService=2
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MinJobAge=600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$shards RealMemory=$mem_mb State=UNKNOWN
PartitionName=ci Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
for _ in $(seq 50); do [ -S "$sock" ] && break; sleep 0.1; done
[ -S "$sock" ] || fail "munged did not start"
slurmctld -D -i -f "$SLURM_CONF" >"$work/slurmctld.stderr" 2>&1 &
pids+=($!)
slurmd -D -N localhost -f "$SLURM_CONF" >"$work/slurmd.stderr" 2>&1 &
pids+=($!)
deadline=$((SECONDS + 60))
until sinfo -h -N -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; do
    [ $SECONDS -lt $deadline ] || fail "the node never became idle: $(sinfo -h -N -o '%T %E' 2>&1)"
    sleep 0.5
done
say "cluster up: munged, slurmctld, slurmd (pids ${pids[*]}); node $(sinfo -h -N -o '%N %T, %c CPUs')"

# --- the job array, as docs/scaling.md submits it (fewer resources: a CI machine)
out="$work/kitti_equi"
submit() {
    sbatch --parsable --chdir="$work/jobs" --output="$work/jobs/%x-%A_%a.out" \
        --cpus-per-task=1 --mem=512M --time=00:10:00 \
        --export="ALL,PANOCONV_SHARDS=$shards,PANOCONV_INPUT=$input,PANOCONV_OUTPUT=$out" "$@"
}
array=$(submit --array="0-$((shards - 1))" scripts/shard_job.sh)
say "submitted job array $array (tasks 0-$((shards - 1)))"

# SIGKILL task $victim's panoconv once it has finished some frames: the PID comes from
# `scontrol listpids` (`scancel --signal=KILL` arrives as a cancel, not as a kill).
journal="$out/panoconv.shard-$victim-of-$shards.journal"
deadline=$((SECONDS + 120))
victim_pid=""
while :; do
    [ $SECONDS -lt $deadline ] || fail "task $victim never got going"
    done_lines=$( (wc -l <"$journal") 2>/dev/null || echo 0)
    if [ "$done_lines" -ge 30 ]; then
        # listpids takes the task's own job id; the node is `localhost`, not this host's name
        task_id=$(scontrol show job "${array}_$victim" -o | grep -o '^JobId=[0-9]*' | cut -d= -f2)
        for p in $(SLURMD_NODENAME=localhost scontrol listpids "$task_id" 2>>"$work/listpids.log" | awk 'NR > 1 {print $1}'); do
            [ "$(cat "/proc/$p/comm" 2>/dev/null)" = panoconv ] && victim_pid=$p
        done
        [ -n "$victim_pid" ] && break
    fi
    state=$(scontrol show job "${array}_$victim" -o 2>/dev/null | grep -o 'JobState=[A-Z]*' || true)
    [ "$state" = JobState=COMPLETED ] && fail "task $victim finished before it could be killed ($(tail -n 3 "$work/listpids.log" 2>/dev/null))"
    sleep 0.05
done
kill -KILL "$victim_pid"
killed_at=$(($(wc -l <"$journal") - 1))
say "SIGKILLed task ${array}_$victim (panoconv pid $victim_pid) after $killed_at frames in its journal"

wait_jobs() { # until none of the given jobs is queued or running
    local deadline=$((SECONDS + 300))
    while [ -n "$(squeue -h -j "$1" -o '%i' 2>/dev/null)" ]; do
        [ $SECONDS -lt $deadline ] || fail "job(s) $1 still running after 300 s"
        sleep 0.5
    done
}
job_state() { scontrol show job "$1" -o | grep -o 'JobState=[A-Z_]*' | cut -d= -f2; }
wait_jobs "$array"
for ((k = 0; k < shards; k++)); do
    s=$(job_state "${array}_$k")
    say "task ${array}_$k: $s"
    if [ "$k" = "$victim" ]; then
        [ "$s" != COMPLETED ] || fail "the killed task is COMPLETED"
    else
        [ "$s" = COMPLETED ] || fail "task $k: $s"
    fi
done
[ -f "$journal" ] || fail "the killed task left no journal"
[ ! -f "$out/panoconv.shard-$victim-of-$shards.json" ] || fail "the killed task left a manifest"

# The outputs the killed task recorded in its journal, and their inodes: a kept file keeps it.
recorded="$work/recorded"
tail -n +2 "$journal" | grep -oE '\["[^"]+","[0-9a-f]{64}"\]' | cut -d'"' -f2 | sort -u >"$recorded"
inodes() { (cd "$out" && xargs -r stat -c '%n %i' <"$recorded" 2>/dev/null || true) | sort; }
inodes >"$work/inodes.before"

# --- re-submit the killed index; merge + verify depend on every shard
again=$(submit --array="$victim" scripts/shard_job.sh)
deps="afterok:${array}_0"
for ((k = 1; k < shards; k++)); do
    if [ "$k" = "$victim" ]; then deps="$deps:$again"; else deps="$deps:${array}_$k"; fi
done
final=$(sbatch --parsable --chdir="$work/jobs" --output="$work/jobs/merge.out" \
    --dependency="$deps" --kill-on-invalid-dep=yes --cpus-per-task=1 --mem=512M \
    --wrap "'$PANOCONV' merge '$out' && '$PANOCONV' verify '$out'")
say "re-submitted index $victim as job $again; merge+verify job $final (dependency $deps)"
wait_jobs "$again,$final"
say "job $again (index $victim again): $(job_state "$again")"
sed 's/^/  | /' "$work/jobs/panoconv-${again}_$victim.out"
s=$(job_state "$final")
say "merge+verify job $final: $s"
sed 's/^/  | /' "$work/jobs/merge.out"
[ "$s" = COMPLETED ] || fail "merge+verify: $s"
grep -q ', 0 missing, 0 changed, 0 extra' "$work/jobs/merge.out" || fail "verify reported problems"

inodes >"$work/inodes.after"
recorded_files=$(wc -l <"$work/inodes.before")
kept=$(comm -12 "$work/inodes.before" "$work/inodes.after" | wc -l)
say "the killed task's recorded frames: $kept of their $recorded_files output files kept (same inode) by the re-submitted task"
[ "$recorded_files" -gt 0 ] && [ "$kept" = "$recorded_files" ] || fail "the re-submitted task rewrote recorded frames"

# --- every byte as one process writes it
if diff -r "$work/single" "$out" >"$work/diff.txt"; then
    say "OK: $shards shards (one SIGKILLed and re-submitted) + merge == single-process run, byte for byte ($(find "$out" -type f | wc -l) files)"
else
    head -n 20 "$work/diff.txt"
    fail "the sharded output differs from the single-process run"
fi
