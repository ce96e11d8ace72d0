#!/usr/bin/env bash
# The README's animations (docs/anim/*.webp), each `tyndall render --frames` into PNGs, then
# encoded by Debian's ffmpeg (libwebp) into an animated WebP, quality 80, looping (≤ 5 MB each;
# a GIF of the forest at the same size was 7.2 MB with 192 colours and visibly banded):
#   forest_holes.webp   graphs/stylize/tree_holes_animated.ron: the camera walks out of the
#                       trees towards the clearing, the foliage holes drift (left physical,
#                       right stylized), frames 1–96 every 2nd, 12 fps (4 s)
#   sunrise.webp        graphs/color/sunrise.ron: the key-framed sunrise TF, frames 0–48, 12 fps
#   cathedral_sun.webp  graphs/color/cathedral_stained_glass.ron: the sun sweeps across the nave
#                       while the camera dollies in, frames 1–96 every 2nd, 12 fps
#   forest_temporal.webp graphs/medium/forest_temporal.ron: the forest walk marched with 24
#                       jittered steps, left as it is, right through TemporalAccumulate; every
#                       frame 24–71 at 24 fps (2 s: shimmer is a frame-to-frame change)
#   street_lantern.webp graphs/lights/street_lamps.ron: the lantern swings once on its wire, its
#                       fans sweeping the fog, while the camera creeps up the street (left
#                       physical, right stylized), frames 1–48 at 24 fps (2 s)
# Usage: scripts/render_animations.sh [SIZE]   (SIZE per picture, default 480x270)
set -euo pipefail
cd "$(dirname "$0")/.."
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
size="${1:-480x270}"
cargo build --release --quiet
mkdir -p docs/anim
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
anim() {
  local name="$1" preset="$2" frames="$3" fps="${4:-12}"
  mkdir -p "$tmp/$name"
  ./target/release/tyndall render "$preset" -o "$tmp/$name/f.png" --size "$size" \
    --frames "$frames" --progress none
  ffmpeg -loglevel error -y -framerate "$fps" -pattern_type glob -i "$tmp/$name/f_*.png" \
    -c:v libwebp_anim -quality 80 -loop 0 "docs/anim/$name.webp"
  echo "docs/anim/$name.webp: $(stat -c %s "docs/anim/$name.webp") bytes"
}
anim forest_holes graphs/stylize/tree_holes_animated.ron 1-96x2
anim sunrise graphs/color/sunrise.ron 0-48
anim cathedral_sun graphs/color/cathedral_stained_glass.ron 1-96x2
anim forest_temporal graphs/medium/forest_temporal.ron 24-71 24
anim street_lantern graphs/lights/street_lamps.ron 1-48 24
