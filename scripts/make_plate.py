"""Build the plate-mode fixture of graphs/plate/ with Blender (3.4 or later):

    blender -b --factory-startup --python scripts/make_plate.py -- OUT_DIR

writes OUT_DIR/colonnade.glb (the shot as Tyndall sees it: ground, columns, roof, the camera,
the sun) and OUT_DIR/plate.exr (a Cycles render of the same shot as a multi-layer EXR with
ViewLayer.Combined and ViewLayer.Depth) in which a crate stands in the foreground that the
glTF does not have: the geometry only the plate knows, which PlateDepth must respect.
"""

import math
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "."
sc = bpy.context.scene
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)


def material(name, colour):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.9
    bsdf.inputs["Specular"].default_value = 0.1
    m.diffuse_color = (*colour, 1.0)
    return m


def box(name, centre, size, mat):
    bpy.ops.mesh.primitive_cube_add(location=centre)
    o = bpy.context.active_object
    o.name = name
    o.scale = (size[0] / 2, size[1] / 2, size[2] / 2)
    bpy.ops.object.transform_apply(scale=True)
    o.data.materials.append(mat)
    return o


stone = material("Stone", (0.55, 0.5, 0.45))
ground_mat = material("Ground", (0.35, 0.33, 0.3))
crate_mat = material("Crate", (0.45, 0.28, 0.12))

bpy.ops.mesh.primitive_plane_add(size=40, location=(0, 0, 0))
ground = bpy.context.active_object
ground.name = "Ground"
ground.data.materials.append(ground_mat)
for i in range(7):
    box(f"Column{i}", (-3.6 + 1.2 * i, 2.0, 2.0), (0.45, 0.45, 4.0), stone)
box("Roof", (0.0, 2.0, 4.15), (8.6, 1.6, 0.3), stone)

cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
sc.collection.objects.link(cam)
cam.data.lens_unit = "FOV"
cam.data.angle = math.radians(60.0)
cam.data.sensor_fit = "HORIZONTAL"
cam.location = (-7.5, -3.5, 1.7)
direction = (9.0, 4.2, 0.6)
cam.rotation_euler = (
    math.atan2(math.hypot(direction[0], direction[1]), -direction[2]),
    0.0,
    math.atan2(-direction[0], direction[1]),
)
sc.camera = cam

sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sc.collection.objects.link(sun)
sun.data.energy = 3.0  # W/m², exported as 2049 lux and read back by Tyndall as 3 W/m²
sun.data.angle = 0.0
sun.data.color = (1.0, 0.9, 0.75)
# Low light from beyond the colonnade, ahead and to the left of the camera: the columns cut it
# into shafts that stream towards the camera.
sun.rotation_euler = (math.radians(64.5), 0.0, math.radians(135.0))

world = bpy.data.worlds.new("World")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.25, 0.32, 0.45, 1.0)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.4
sc.world = world

sc.render.resolution_x = 320
sc.render.resolution_y = 180
sc.render.resolution_percentage = 100
sc.render.fps = 24
sc.frame_start = 1
sc.frame_end = 1

# The glTF: everything but the crate.
bpy.ops.object.select_all(action="SELECT")
bpy.ops.export_scene.gltf(
    filepath=f"{out}/colonnade.glb",
    export_format="GLB",
    use_selection=True,
    export_cameras=True,
    export_lights=True,
    export_extras=True,
    export_yup=True,
    export_apply=True,
)

# The plate: the same shot with a crate in the foreground, rendered by Cycles.
box("Crate", (-2.6, -2.3, 0.45), (0.9, 0.9, 0.9), crate_mat)
sc.render.engine = "CYCLES"
sc.cycles.device = "CPU"
sc.cycles.samples = 48
sc.cycles.use_denoising = False
sc.cycles.seed = 1
sc.view_layers[0].use_pass_z = True
sc.view_settings.view_transform = "Standard"
s = sc.render.image_settings
s.file_format = "OPEN_EXR_MULTILAYER"
s.color_depth = "16"
s.exr_codec = "ZIP"
sc.render.filepath = f"{out}/plate.exr"
bpy.ops.render.render(write_still=True)
