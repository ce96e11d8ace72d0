#!/usr/bin/env bash
# Fresh-process time with and without pipelines made up front (issue #43, item 3).
# Usage: scripts/bench_up_front.sh [GRAPH] [SIZE] [RUNS]
# Warms the pipeline cache and the recipes file once, then renders GRAPH in RUNS fresh processes
# per setting, alternating the two settings so that a slow moment of the machine hits both, and
# prints each run's wall time (process start to picture written) and the --stats pipelines lines.
set -euo pipefail
cd "$(dirname "$0")/.."
graph="${1:-graphs/stylize/tree_hole_filling.ron}"
size="${2:-480x270}"
runs="${3:-5}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release --quiet
cache="$(mktemp -d)"
out="$(mktemp -d)"
trap 'rm -rf "$cache" "$out"' EXIT
export TYNDALL_CACHE_DIR="$cache"
bin=./target/release/tyndall
"$bin" render "$graph" -o "$out/warm.png" --size "$size" >/dev/null
for i in $(seq 1 "$runs"); do
  for setting in 1 0; do
    start=$(date +%s.%N)
    TYNDALL_PIPELINES_UP_FRONT=$setting "$bin" render "$graph" -o "$out/r$setting.png" \
      --size "$size" --stats >"$out/stats" 2>&1
    end=$(date +%s.%N)
    made=$(grep -o 'made up front on worker threads: [0-9]*' "$out/stats" | grep -o '[0-9]*$' || echo 0)
    printf 'up_front=%s run %s: %.3f s, %s pipelines made up front\n' \
      "$setting" "$i" "$(awk "BEGIN{print $end - $start}")" "$made"
  done
done
cmp "$out/r1.png" "$out/r0.png" && echo "pictures identical"
