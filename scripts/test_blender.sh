#!/usr/bin/env bash
# The Blender add-on's headless test (integrations/blender/tests/test_addon.py) against the
# Blender on PATH (Debian's 3.4 here), with a throw-away user scripts folder so the install
# leaves nothing in ~/.config/blender. Usage: scripts/test_blender.sh [path/to/tyndall]
set -euo pipefail
cd "$(dirname "$0")/.."
tyndall="${1:-target/debug/tyndall}"
[ -x "$tyndall" ] || cargo build --quiet
scripts="$(mktemp -d)"
trap 'rm -rf "$scripts"' EXIT
BLENDER_USER_SCRIPTS="$scripts" BLENDER_USER_CONFIG="$scripts/config" \
  blender -b --factory-startup --python-exit-code 1 \
  --python integrations/blender/tests/test_addon.py -- "$tyndall"
