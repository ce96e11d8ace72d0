#!/usr/bin/env bash
# Fuzz every reader of user files (issue #15, item 4): the RON graph loader, the EXR and PNG
# readers, the glTF loader and the OpenVDB reader, all targets at once, SECONDS each (default 600).
#
#   scripts/fuzz.sh [SECONDS]
#
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`). Seeds are in
# fuzz/corpus/TARGET (committed); the growing working corpus goes to fuzz/corpus-run/TARGET and
# crashes to fuzz/artifacts/TARGET (both ignored). Logs: out/fuzz-TARGET.log; the last line of
# each is libFuzzer's summary (executions, speed, coverage). Exit 1 when a target crashed.
set -uo pipefail
cd "$(dirname "$0")/../fuzz"
SECS="${1:-600}"
TARGETS="graph_ron image_exr image_png gltf vdb_read"
mkdir -p ../out
cargo +nightly fuzz build -s none || exit 2
pids=()
for t in $TARGETS; do
  mkdir -p "corpus-run/$t"
  cp -n corpus/"$t"/* "corpus-run/$t/" 2>/dev/null || true
  cargo +nightly fuzz run -s none "$t" "corpus-run/$t" -- \
    -max_total_time="$SECS" -rss_limit_mb=4096 -print_final_stats=1 > "../out/fuzz-$t.log" 2>&1 &
  pids+=($!)
done
status=0
i=0
for t in $TARGETS; do
  if ! wait "${pids[$i]}"; then status=1; echo "$t: CRASHED (see fuzz/artifacts/$t)"; fi
  i=$((i + 1))
done
for t in $TARGETS; do
  echo "== $t"
  grep -E "^#[0-9]+.*DONE|^stat::number_of_executed_units|^stat::average_exec_per_sec|^Done [0-9]+ runs" "../out/fuzz-$t.log" | tail -n 4
done
exit $status
