#!/usr/bin/env bash
# `tyndall job` run for real by Open Job Description's own CLI (PyPI: openjd-cli), issue #62:
# the template passes `openjd check`; one task is killed after its first frame, then the whole
# step runs and every frame is written exactly once, the killed task's finished frame skipped.
# tests/cli.rs runs it (TYNDALL_BIN: the binary under test); by hand:
#
#     bash scripts/test_openjd.sh [path/to/tyndall]
set -euo pipefail
cd "$(dirname "$0")/.."
TYNDALL="${1:-${TYNDALL_BIN:-$PWD/target/debug/tyndall}}"
VENV="${TYNDALL_OPENJD_VENV:-target/openjd-venv}"
if [ ! -x "$VENV/bin/openjd" ]; then
  "${PYTHON:-python3}" -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check "openjd-cli>=0.7,<1"
fi
OPENJD="$(cd "$VENV" && pwd)/bin/openjd"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
# The graph beside the job file, so Graph and OutputDir are PATH parameters (relative defaults).
cp graphs/physical/window.ron "$WORK/shot.ron"
"$TYNDALL" job "$WORK/shot.ron" --frames 1-20 --chunk 8 --output-dir "$WORK/renders" \
  --size 480x270 -o "$WORK/job.yaml"
grep -q "type: PATH" "$WORK/job.yaml" || { echo "FAIL: no PATH parameter"; exit 1; }
"$OPENJD" check "$WORK/job.yaml"

# Task 2 (frames 8-14: 20 frames in 3 contiguous runs of 7, 7, 6), killed once its first
# frame is on disk.
setsid "$OPENJD" run "$WORK/job.yaml" --step Render --task-param Chunk=2 >"$WORK/killed.log" 2>&1 &
pid=$!
for _ in $(seq 1 600); do
  if compgen -G "$WORK/renders/out/window_0008.png" >/dev/null; then break; fi
  sleep 0.05
done
kill -KILL -- "-$pid" 2>/dev/null || true
wait "$pid" 2>/dev/null || true
before=$(find "$WORK/renders" -name 'window_*.png' | wc -l)
echo "killed task 2 with $before of its 7 frames written"
[ "$before" -ge 1 ] || { echo "FAIL: task 2 wrote nothing before it was killed"; cat "$WORK/killed.log"; exit 1; }
[ "$before" -lt 7 ] || { echo "FAIL: task 2 finished before it was killed (nothing to resume)"; exit 1; }

# The whole step: three tasks; the frames task 2 wrote are skipped.
"$OPENJD" run "$WORK/job.yaml" --step Render >"$WORK/run.log" 2>&1 || { cat "$WORK/run.log"; exit 1; }
grep -q "Chunks run: 3" "$WORK/run.log" || { echo "FAIL: not 3 tasks"; cat "$WORK/run.log"; exit 1; }
grep -Eq "[1-9][0-9]* skipped \(already there\)" "$WORK/run.log" \
  || { echo "FAIL: the resumed task skipped nothing"; cat "$WORK/run.log"; exit 1; }
files=$(cd "$WORK/renders" && find . -type f | sort)
expected=$(for f in $(seq 1 20); do printf './out/window_%04d.png\n' "$f"; done)
if [ "$files" != "$expected" ]; then
  echo "FAIL: the files are not frames 1-20 exactly once:"; echo "$files"; exit 1
fi
echo "openjd: 20 frames in 3 tasks, each written once; the killed task resumed"
