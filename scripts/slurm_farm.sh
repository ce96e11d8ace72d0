#!/usr/bin/env bash
# Render on a real farm engine: start a one-machine Slurm cluster on localhost from Debian's
# packages (slurm-wlm, munge), submit an array job of 4 chunks rendering 16 frames with
# `tyndall render --chunk`, wait for it, and check that every frame arrived exactly once.
#
#   scripts/slurm_farm.sh [GRAPH] [OUT_DIR]      (run as root, or with sudo available)
#
# Needs the release binary (cargo build --release). Installs slurm-wlm and munge if missing.
# Everything the cluster writes lives under a temporary folder; the daemons are stopped on exit.
set -euo pipefail
cd "$(dirname "$0")/.."
GRAPH="${1:-graphs/basics/grade.ron}"
OUT="$(realpath -m "${2:-out/slurm}")"
BIN="$(realpath target/release/tyndall)"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
[ -x "$BIN" ] || { echo "build first: cargo build --release" >&2; exit 2; }
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends slurm-wlm munge
fi

WORK="$(mktemp -d /tmp/tyndall-slurm.XXXXXX)"
HOST="$(hostname -s)"
CPUS="$(nproc)"
mkdir -p "$WORK"/{spool/ctld,spool/d,log,munge} "$OUT"
rm -f "$OUT"/frame.*.png "$OUT"/task-*.log

# munge: a fresh key and a private socket, so nothing on the machine is touched.
dd if=/dev/urandom of="$WORK/munge/munge.key" bs=1 count=1024 status=none
chmod 0400 "$WORK/munge/munge.key"
SOCKET="$WORK/munge/munge.socket"
munged --force --key-file="$WORK/munge/munge.key" --socket="$SOCKET" \
  --pid-file="$WORK/munge/munged.pid" --log-file="$WORK/log/munged.log" --seed-file="$WORK/munge/seed"

cat > "$WORK/slurm.conf" <<CONF
ClusterName=tyndall
SlurmctldHost=$HOST
AuthType=auth/munge
AuthInfo=socket=$SOCKET
CredType=cred/munge
SlurmUser=$(id -un)
SlurmdUser=root
StateSaveLocation=$WORK/spool/ctld
SlurmdSpoolDir=$WORK/spool/d
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/log/slurmctld.log
SlurmdLogFile=$WORK/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
NodeName=$HOST CPUs=$CPUS State=UNKNOWN
PartitionName=farm Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$WORK/slurm.conf"

cleanup() {
  for pid in "$WORK/slurmd.pid" "$WORK/slurmctld.pid" "$WORK/munge/munged.pid"; do
    [ -f "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
  done
}
trap cleanup EXIT

slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
  if sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then break; fi
  sleep 1
done
sinfo

# The array job: 4 tasks, each renders its chunk of frames 1-16, one CPU each.
JOB=$(sbatch --parsable --array=0-3 --cpus-per-task=1 --output="$OUT/task-%a.log" \
  --export=ALL,XDG_RUNTIME_DIR=/tmp,WGPU_BACKEND=vulkan --wrap \
  "'$BIN' render '$(realpath "$GRAPH")' --frames 1-16 --chunk \$((SLURM_ARRAY_TASK_ID + 1))/4 \
   --size 320x180 -o '$OUT/frame.####.png' --progress json")
echo "submitted array job $JOB"
for _ in $(seq 600); do
  if [ -z "$(squeue -h -j "$JOB" 2>/dev/null)" ]; then break; fi
  sleep 1
done
sacct -j "$JOB" 2>/dev/null || true

# Every frame exactly once: 16 files, and the tasks' JSON lines name each frame once, written.
status=0
files=$(ls "$OUT"/frame.*.png 2>/dev/null | wc -l)
written=$(cat "$OUT"/task-*.log | grep -o '"frame":[0-9]*,"status":"written"' | sort | uniq -c)
once=$(echo "$written" | awk '$1 == 1' | wc -l)
twice=$(echo "$written" | awk '$1 > 1' | wc -l)
echo "files: $files of 16; frames written once: $once; more than once: $twice"
for f in $(seq 1 16); do
  [ -f "$OUT/$(printf 'frame.%04d.png' "$f")" ] || { echo "missing frame $f"; status=1; }
done
[ "$files" -eq 16 ] && [ "$once" -eq 16 ] && [ "$twice" -eq 0 ] || status=1
grep -h "files written" "$OUT"/task-*.log
if [ $status -eq 0 ]; then echo "OK: every frame arrived exactly once"; else echo "FAILED"; fi
exit $status
