#!/usr/bin/env bash
# Regenerate the committed scenes (scenes/*.glb) from their scripts with Debian's Blender 3.4:
#   scripts/scenes/make_all.sh            # writes scenes/cathedral.glb, forest.glb, workshop.glb, street.glb, stage.glb, rainbow.glb, glory.glb, halo.glb (and scenes/gobo_rays.png)
# Each script uses a fixed seed, so on the same Blender version the files come out byte for byte
# the same (tests/blender.rs checks it); another Blender version's exporter may order or round
# differently.
set -euo pipefail
cd "$(dirname "$0")/../.."
for s in cathedral forest workshop street stage rainbow glory halo; do
  blender -b --factory-startup --python "scripts/scenes/$s.py" -- "scenes/$s.glb" > /dev/null
  echo "scenes/$s.glb: $(stat -c %s "scenes/$s.glb") bytes"
done
