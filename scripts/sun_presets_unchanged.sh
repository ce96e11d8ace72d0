#!/usr/bin/env bash
# Do the sun's presets render byte for byte as they did at an earlier commit? Builds BASE in a
# throw-away worktree (its own target dir: a full release build, ~10 min on two cores), renders
# every preset outside graphs/lights, graphs/lib and graphs/bench with both binaries at 160×90,
# frame 1, EXR (every output of the presets with several), and compares the files' bytes.
#   scripts/sun_presets_unchanged.sh BASE      # e.g. 3d985aa, the commit before issue #44
# BASE_BIN=path/to/old/tyndall skips building BASE (a binary built from it already);
# NEW_BIN=path/to/new/tyndall skips building the working tree (e.g. one built in a worktree).
set -euo pipefail
cd "$(dirname "$0")/.."
base="${1:?usage: scripts/sun_presets_unchanged.sh BASE-COMMIT}"
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
if [ -n "${NEW_BIN:-}" ]; then
  new="$NEW_BIN"
else
  cargo build --release --quiet
  new="target/release/tyndall"
fi
tmp="$(mktemp -d)"
trap 'git worktree remove --force "$tmp/base" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
if [ -n "${BASE_BIN:-}" ]; then
  old="$BASE_BIN"
else
  git worktree add --detach "$tmp/base" "$base" >/dev/null
  (cd "$tmp/base" && cargo build --release --quiet -p tyndall)
  old="$tmp/base/target/release/tyndall"
fi
same=0 differ=0
for g in $(ls graphs/*/*.ron | grep -v '^graphs/\(lights\|lib\|bench\)/'); do
  # Presets added after BASE (e.g. graphs/color/window_aces.ron, whose nodes BASE lacks) have
  # nothing to compare with.
  if ! git cat-file -e "$base:$g" 2>/dev/null; then
    echo "new since $base: $g"
    continue
  fi
  n="$(echo "$g" | tr / _)"
  for side in old new; do
    bin="$old"; [ "$side" = new ] && bin="$new"
    mkdir -p "$tmp/$side/$n"
    # One output: as a float EXR (stricter than the preset's PNG); several: as written.
    "$bin" render "$g" -o "$tmp/$side/$n/out.exr" --size 160x90 --frames 1 --progress none \
      > /dev/null 2>&1 ||
      "$bin" render "$g" --size 160x90 --frames 1 --progress none --output-dir "$tmp/$side/$n" > /dev/null
  done
  for f in $(cd "$tmp/new/$n" && find . -type f | sort); do
    if cmp -s "$tmp/old/$n/$f" "$tmp/new/$n/$f"; then
      same=$((same + 1))
    else
      differ=$((differ + 1))
      echo "differs: $g ${f#./}"
    fi
  done
done
echo "$same files identical, $differ differ (base $base)"
