#!/usr/bin/env bash
# Render the presets into docs/ (the pictures the README and the editor's preset browser show).
set -euo pipefail
cd "$(dirname "$0")/.."
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release --quiet
for scene in torus tree window fence figure window_room cathedral forest workshop; do
  ./target/release/tyndall render "graphs/physical/$scene.ron" -o "docs/physical/$scene.png" --size 960x540
done
./target/release/tyndall render graphs/lights/tree_spot.ron -o docs/lights/tree_spot.png --size 480x270
# The lamp scenes are animated: their first frame.
for preset in street_lamps stage_gobos stage_window; do
  ./target/release/tyndall render "graphs/lights/$preset.ron" -o "out/$preset.png" --size 960x540 --frames 1
  cp "out/${preset}_0001.png" "docs/lights/$preset.png"
done
./target/release/tyndall render tests/fixtures/gltf_scene.ron -o docs/physical/gltf_scene.png --size 960x540
for preset in tree_hole_filling torus_closure figure_silhouette window_soft_glow; do
  ./target/release/tyndall render "graphs/stylize/$preset.ron" -o "docs/stylize/$preset.png" --size 960x540
done
./target/release/tyndall render graphs/stylize/tree_holes_animated.ron -o docs/stylize/tree_holes_animated.png --size 960x540 --frames 0-2
for preset in alarm_tree alarm_fence tree_modulate window_light_map cathedral_stained_glass; do
  ./target/release/tyndall render "graphs/color/$preset.ron" -o "docs/color/$preset.png" --size 960x540
done
./target/release/tyndall render graphs/color/sunrise.ron -o out/sunrise.png --size 960x540 --frames 0-48
./target/release/tyndall render scripts/sunrise_sheet.ron
./target/release/tyndall render graphs/medium/tree_bilateral.ron -o docs/medium/tree_bilateral.png --size 480x270
# A frame mid-walk (at frame 0 the camera has not moved yet, and there is nothing to average).
./target/release/tyndall render graphs/medium/forest_temporal.ron -o out/forest_temporal.png --size 480x270 --frames 48
cp out/forest_temporal_0048.png docs/medium/forest_temporal.png
./target/release/tyndall render graphs/medium/fence_noise.ron -o docs/medium/fence_noise.png --size 960x540
./target/release/tyndall render graphs/medium/workshop_dust.ron -o docs/medium/workshop_dust.png --size 960x540
./target/release/tyndall render graphs/medium/fence_painted.ron -o docs/medium/fence_painted.png --size 960x540
./target/release/tyndall render graphs/medium/tree_intensity.ron -o docs/medium/tree_intensity.png --size 960x540
./target/release/tyndall render graphs/medium/forest_smoke.ron -o docs/medium/forest_smoke.png --size 960x540
./target/release/tyndall render graphs/medium/stage_haze.ron -o out/stage_haze.png --size 480x270 --frames 1
cp out/stage_haze_0001.png docs/medium/stage_haze.png
./target/release/tyndall render graphs/atmosphere/cloud_mie.ron -o docs/atmosphere/cloud_mie.png --size 960x540
./target/release/tyndall render graphs/atmosphere/fence_sunset.ron -o docs/atmosphere/fence_sunset.png --size 960x540
./target/release/tyndall render graphs/atmosphere/fence_soft_kernels.ron -o docs/atmosphere/fence_soft_kernels.png --size 320x180
./target/release/tyndall render graphs/atmosphere/rainbow.ron -o docs/atmosphere/rainbow.png --size 960x540
./target/release/tyndall render graphs/atmosphere/glory.ron -o docs/atmosphere/glory.png --size 640x360
./target/release/tyndall render graphs/atmosphere/halo.ron -o docs/atmosphere/halo.png --size 640x360
./target/release/tyndall render graphs/basics/grade.ron -o docs/basics/grade.png --size 320x180
# Plate presets write a PNG and the AOV EXR (two outputs): render into a folder, keep the PNG.
plate_out="$(mktemp -d)"
for preset in colonnade haze; do
  ./target/release/tyndall render "graphs/plate/$preset.ron" --output-dir "$plate_out"
  cp "$plate_out/out/$preset.png" "docs/plate/$preset.png"
done
rm -rf "$plate_out"
# The contact sheet of every picture above (docs/gallery.png).
scripts/make_gallery.sh
