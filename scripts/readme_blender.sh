#!/usr/bin/env bash
# docs/plate/blender_before_after.png: a Blender scene rendered by Cycles, before and after the
# add-on's "Render shafts" (scripts/blender_before_after.py). Needs blender and oiiotool.
set -euo pipefail
cd "$(dirname "$0")/.."
tyndall="${1:-target/release/tyndall}"
[ -x "$tyndall" ] || cargo build --release --quiet
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
BLENDER_USER_SCRIPTS="$work/scripts" BLENDER_USER_CONFIG="$work/config" \
  blender -b --factory-startup --python-exit-code 1 \
  --python scripts/blender_before_after.py -- "$tyndall" "$work" > "$work/log" 2>&1 \
  || { tail -20 "$work/log"; exit 1; }
oiiotool "$work/before.png" "$work/after.png" --mosaic 2x1 -o docs/plate/blender_before_after.png
echo "wrote docs/plate/blender_before_after.png"
