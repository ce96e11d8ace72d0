"""Smoke for the looks of issue #61 (item 6), simulated by Mantaflow:

    blender -b --factory-startup --python scripts/scenes/smoke.py -- scenes/smoke/forest_plume_####.vdb [FIRST LAST]
    blender -b --factory-startup --python scripts/scenes/smoke.py -- scenes/smoke/stage_haze_####.vdb 120 120 --look stage

`--look forest` (the default) is the forest clearing's plume below; `--look stage` is a hazer's
haze on the stage of scenes/stage.glb: a domain 15 × 10 × 6 m over the stage (x −7.5…7.5,
y −4.5…5.5, z 1…7 in Blender's Z-up world, 64 voxels on its longest side), a hazer of 0.4 m at
stage left, 0.6 m above the boards at (−6.8, 2.5, 1.6), blowing cool, heavy haze across the stage
along +X that hardly rises (no heat, a density buoyancy of −0.05 that keeps it low). In Tyndall:
`translate` (−7.5, 1.0, 4.5), the domain's low corner in Y-up.

A smoke domain 14 × 12 × 10 m (Blender's Z up) stands in the clearing of scenes/forest.glb,
between the camera and the sun (its low corner at (−7, −9, 0)), 64 voxels on its longest side;
a sphere of 1 m on the ground at (−3.5, −3) emits smoke that rises and drifts along +X. Blender 3.4's
`bpy.ops.fluid.bake_all` fails on Debian's build, so the script steps the simulation frame by
frame with a `REPLAY` cache in OpenVDB format (Blosc, half floats: what Blender writes for a
Mantaflow cache) and copies frames FIRST…LAST (default 90 90) to the output pattern (`####`: the
frame). Grids: density, temperature, flame, shadow, velocity.

In Tyndall: `VdbVolume` with `up_axis` = z, `voxel_centers` = blender and `translate` = the
domain's low corner in Tyndall's Y-up world, (−7, 0, 9): the cache's index space starts at the
domain's corner. The seed is Mantaflow's own (deterministic on one machine)."""

import os
import shutil
import sys
import tempfile

import bpy

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
look = "forest"
if "--look" in args:
    i = args.index("--look")
    look = args[i + 1]
    del args[i:i + 2]
pattern = args[0] if args else f"scenes/smoke/{'forest_plume' if look == 'forest' else 'stage_haze'}_####.vdb"
first, last = (int(args[1]), int(args[2])) if len(args) >= 3 else (90, 90)

# (domain centre, domain size, emitter centre, emitter radius, buoyancy from density and from
# heat, flow temperature, initial velocity, vorticity), Blender coordinates.
LOOKS = {
    "forest": ((0.0, -3.0, 5.0), (14.0, 12.0, 10.0), (-3.5, -3.0, 0.8), 1.0, 1.2, 0.4, 1.5,
               (1.5, 0.0, 0.3), 0.15),
    "stage": ((0.0, 0.5, 4.0), (15.0, 10.0, 6.0), (-6.8, 2.5, 1.6), 0.4, -0.05, 0.0, 0.0,
              (4.0, -0.8, 0.0), 0.3),
}
if look not in LOOKS:
    sys.exit(f"--look {look}: expected one of {', '.join(LOOKS)}")
centre, size, at, radius, alpha, beta, temperature, velocity, vorticity = LOOKS[look]

for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)

cache = tempfile.mkdtemp(prefix="tyndall_smoke_")
bpy.ops.mesh.primitive_cube_add(size=1.0, location=centre)
bpy.context.active_object.scale = size
bpy.ops.object.transform_apply(scale=True)
domain = bpy.context.active_object
domain.name = "SmokeDomain"
d = domain.modifiers.new("Fluid", "FLUID")
d.fluid_type = "DOMAIN"
s = d.domain_settings
s.domain_type = "GAS"
s.resolution_max = 64
s.use_noise = False
s.vorticity = vorticity
s.alpha = alpha  # buoyancy from density
s.beta = beta  # buoyancy from heat
s.cache_directory = cache
s.cache_type = "REPLAY"
s.cache_data_format = "OPENVDB"
s.openvdb_cache_compress_type = "BLOSC"
s.cache_frame_start = 1
s.cache_frame_end = last

bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=at)
emitter = bpy.context.active_object
emitter.name = "Emitter"
f = emitter.modifiers.new("Fluid", "FLUID")
f.fluid_type = "FLOW"
fs = f.flow_settings
fs.flow_type = "SMOKE"
fs.flow_behavior = "INFLOW"
fs.density = 1.0
fs.temperature = temperature
fs.use_initial_velocity = True
fs.velocity_coord = velocity

scene = bpy.context.scene
for frame in range(1, last + 1):
    scene.frame_set(frame)

os.makedirs(os.path.dirname(os.path.abspath(pattern)), exist_ok=True)
for frame in range(first, last + 1):
    src = os.path.join(cache, "data", f"fluid_data_{frame:04d}.vdb")
    dst = pattern.replace("####", f"{frame:04d}")
    shutil.copyfile(src, dst)
    print(f"{dst}: {os.path.getsize(dst)} bytes")
shutil.rmtree(cache, ignore_errors=True)
