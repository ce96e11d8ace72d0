#!/usr/bin/env bash
# Screenshot of the editor in a real window under Xvfb (lavapipe): docs/editor.png.
# Needs: apt-get install xvfb xauth imagemagick (and mesa-vulkan-drivers).
set -euo pipefail
cd "$(dirname "$0")/.."
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release --quiet
Xvfb :77 -screen 0 1400x860x24 >/dev/null 2>&1 &
xvfb=$!
trap 'kill $xvfb 2>/dev/null || true' EXIT
sleep 1
DISPLAY=:77 ./target/release/tyndall edit "${1:-graphs/physical/tree.ron}" >/dev/null 2>&1 &
app=$!
sleep "${WAIT:-12}"
DISPLAY=:77 import -window root docs/editor.png
kill $app 2>/dev/null || true
echo "wrote docs/editor.png"
