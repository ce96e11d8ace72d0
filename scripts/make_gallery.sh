#!/usr/bin/env bash
# docs/gallery.png: a contact sheet of the preset pictures under docs/ (scripts/render_docs.sh
# renders them), three to a row, each scaled to 640 wide (a side-by-side before/after keeps its
# 1920×540 shape at 640×180; a single 960×540 picture is 320×180, centred), tiled by Debian's
# ffmpeg.
set -euo pipefail
cd "$(dirname "$0")/.."
files=()
for d in physical stylize color medium atmosphere plate lights; do
  for f in docs/$d/*.png; do
    case "$f" in *_000[1-9].png|*blender_before_after.png) continue;; esac
    files+=("$f")
  done
done
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
i=0
for f in "${files[@]}"; do
  ffmpeg -loglevel error -y -i "$f" \
    -vf "scale=w=640:h=180:force_original_aspect_ratio=decrease,pad=640:180:(ow-iw)/2:(oh-ih)/2:color=0x101014" \
    "$tmp/$(printf %03d $i).png"
  i=$((i + 1))
done
rows=$(( (i + 2) / 3 ))
ffmpeg -loglevel error -y -framerate 1 -i "$tmp/%03d.png" \
  -vf "tile=3x${rows}:padding=4:color=0x101014" -frames:v 1 docs/gallery.png
echo "docs/gallery.png: ${i} pictures, $(stat -c %s docs/gallery.png) bytes"
