"""Blender's Cryptomatte on a small scene of named objects and materials: the reference that
`tests/files/cryptomatte.rs` compares Tyndall's `Cryptomatte` node with (issue #62).

Run (Debian: apt-get install blender), from the repository root:

    blender -b --factory-startup --python scripts/cryptomatte_blender.py [-- --out DIR --samples N]

It builds a ground, a ball, two occluders sharing one material and a pillar half hidden behind the
ball (so some pixels hold three objects), renders Cycles' Cryptomatte object and material passes
(6 levels, the default Blackman-Harris 1.50 px pixel filter, N samples, 160×90) into a multi-layer
EXR, and exports the same scene as glTF with Blender's exporter (node names = object names,
material names kept). Default output: tests/fixtures/cryptomatte/ (`scene.glb`, `blender.exr`), which
the test reads, so CI needs no Blender.
"""
import math
import os
import sys

import bpy

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
WIDTH, HEIGHT = 160, 90


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out = os.path.join(ROOT, "tests", "fixtures", "cryptomatte")
    samples = 256
    i = 0
    while i < len(argv):
        if argv[i] == "--out":
            out = argv[i + 1]
            i += 2
        elif argv[i] == "--samples":
            samples = int(argv[i + 1])
            i += 2
        else:
            sys.exit(f"unknown argument {argv[i]}")
    return out, samples


def material(name, colour):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*colour, 1.0)
    return m


def place(obj, name, mat):
    obj.name = name
    obj.data.materials.append(mat)
    return obj


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    moss = material("Moss", (0.2, 0.35, 0.15))
    chalk = material("Chalk", (0.85, 0.85, 0.8))
    slate = material("Slate", (0.25, 0.27, 0.3))
    bpy.ops.mesh.primitive_plane_add(size=30, location=(0, 0, 0))
    place(bpy.context.object, "Ground", moss)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0, 0, 1.0), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    place(bpy.context.object, "Ball", chalk)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-2.6, 1.0, 1.25), scale=(1.0, 1.0, 2.5))
    place(bpy.context.object, "Occluder.Left", slate)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(2.4, -1.5, 0.9), rotation=(0, 0, 0.6),
                                    scale=(1.2, 0.8, 1.8))
    place(bpy.context.object, "Occluder.Right", slate)
    bpy.ops.mesh.primitive_cylinder_add(radius=0.35, depth=4.0, location=(0.9, 2.5, 2.0), vertices=32)
    place(bpy.context.object, "Pillar", chalk)
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens_unit = "FOV"
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle = math.radians(40.0)
    cam_data.clip_start, cam_data.clip_end = 0.1, 100.0
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0.0, -11.0, 3.5)
    direction = (0.0, 11.0, -2.5)
    import mathutils
    cam.rotation_euler = mathutils.Vector(direction).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun_data.energy = 3.0
    sun = bpy.data.objects.new("Sun", sun_data)
    sun.rotation_euler = (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(sun)
    return scene


def render(scene, samples, out):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.filter_type = "BLACKMAN_HARRIS"
    scene.cycles.filter_width = 1.5
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    layer = scene.view_layers[0]
    layer.name = "ViewLayer"
    layer.use_pass_cryptomatte_object = True
    layer.use_pass_cryptomatte_material = True
    layer.pass_cryptomatte_depth = 6
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"
    scene.render.filepath = os.path.join(out, "blender.exr")
    bpy.ops.render.render(write_still=True)


def main():
    out, samples = args()
    os.makedirs(out, exist_ok=True)
    scene = build()
    bpy.ops.export_scene.gltf(
        filepath=os.path.join(out, "scene.glb"),
        export_format="GLB",
        export_cameras=True,
        export_lights=True,
        export_apply=True,
    )
    render(scene, samples, out)
    print(f"wrote {out}/scene.glb and {out}/blender.exr")


main()
