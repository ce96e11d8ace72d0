"""Shared helpers of the scene scripts (scripts/scenes/*.py), run inside Blender 3.4 or later:

    blender -b --factory-startup --python scripts/scenes/NAME.py -- OUT.glb

Each script empties the factory scene, builds its shot from a fixed seed (so the file it writes
is the same byte for byte on the same Blender version), and exports one binary glTF with the
camera, the sun (KHR_lights_punctual), their animation and each object's `tyndall_tag` custom
property, which the exporter writes as glTF extras and Tyndall reads as the object's tags.
Units are metres; the sun's strength is W/m² (Tyndall reads the exported lux back as W/m²)."""

import math
import sys

import bmesh
import bpy


def out_path(default):
    """The output path after `--`, else `default`."""
    return sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv[:-1] else default


def clear():
    """An empty scene: the factory cube, light and camera removed."""
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    for m in list(bpy.data.meshes):
        bpy.data.meshes.remove(m)


def material(name, colour):
    """A rough diffuse material of linear base colour `colour` (exported as baseColorFactor)."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.9
    bsdf.inputs["Specular"].default_value = 0.1
    m.diffuse_color = (*colour, 1.0)
    return m


class Mesh:
    """One object's triangles, built from boxes, cylinders and quads in world space."""

    def __init__(self, name, mat, tag):
        self.name, self.mat, self.tag = name, mat, tag
        self.bm = bmesh.new()

    def box(self, centre, size, rot_z=0.0, rot_x=0.0):
        """An axis-aligned box of `size` (x, y, z) at `centre`, turned `rot_x` then `rot_z` rad."""
        geom = bmesh.ops.create_cube(self.bm, size=1.0)
        verts = geom["verts"]
        bmesh.ops.scale(self.bm, vec=size, verts=verts)
        if rot_x:
            bmesh.ops.rotate(self.bm, verts=verts, cent=(0, 0, 0),
                             matrix=_rot("X", rot_x))
        if rot_z:
            bmesh.ops.rotate(self.bm, verts=verts, cent=(0, 0, 0),
                             matrix=_rot("Z", rot_z))
        bmesh.ops.translate(self.bm, vec=centre, verts=verts)

    def cylinder(self, base, radius, height, segments=16, radius_top=None):
        """An upright cylinder (a cone when `radius_top` differs) standing on `base`."""
        top = radius if radius_top is None else radius_top
        geom = bmesh.ops.create_cone(self.bm, cap_ends=True, segments=segments,
                                     radius1=radius, radius2=top, depth=height)
        bmesh.ops.translate(self.bm, vec=(base[0], base[1], base[2] + height / 2),
                            verts=geom["verts"])

    def quad(self, corners):
        """A single two-sided quad (Tyndall draws without back-face culling)."""
        vs = [self.bm.verts.new(c) for c in corners]
        self.bm.faces.new(vs)

    def finish(self, collection=None):
        """The object, linked into the scene, with its material and `tyndall_tag`."""
        me = bpy.data.meshes.new(self.name)
        bmesh.ops.triangulate(self.bm, faces=self.bm.faces[:])
        self.bm.to_mesh(me)
        self.bm.free()
        o = bpy.data.objects.new(self.name, me)
        (collection or bpy.context.scene.collection).objects.link(o)
        if self.mat is not None:
            o.data.materials.append(self.mat)
        o["tyndall_tag"] = self.tag
        return o


def conifer(trunks, crowns, x, y, h):
    """A conifer `h` m tall standing at (x, y, 0): a trunk into `trunks`, a cone into `crowns`."""
    trunks.cylinder((x, y, 0.0), 0.25, h * 0.5, segments=8)
    crowns.cylinder((x, y, h * 0.35), h * 0.28, h * 0.65, segments=10, radius_top=0.2)


def _rot(axis, angle):
    from mathutils import Matrix

    return Matrix.Rotation(angle, 3, axis)


def medium_box(lo, hi):
    """The medium's bounds: a box tagged `medium` (not drawn by Tyndall)."""
    m = Mesh("Medium", None, "medium")
    m.box(tuple((a + b) / 2 for a, b in zip(lo, hi)), tuple(b - a for a, b in zip(lo, hi)))
    return m.finish()


def look_at(eye, target):
    """Blender camera Euler angles (XYZ) looking from `eye` to `target`, no roll."""
    d = [t - e for t, e in zip(target, eye)]
    return (math.atan2(math.hypot(d[0], d[1]), -d[2]), 0.0, math.atan2(-d[0], d[1]))


def camera(keys, fov_deg=60.0, clip_end=200.0):
    """The shot's camera; `keys`: [(frame, eye, target)], linear between keys; `fov_deg` is
    horizontal, `clip_end` the far plane in metres."""
    sc = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    sc.collection.objects.link(cam)
    cam.data.lens_unit = "FOV"
    cam.data.angle = math.radians(fov_deg)
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.clip_start, cam.data.clip_end = 0.1, clip_end
    for frame, eye, target in keys:
        cam.location = eye
        cam.rotation_euler = look_at(eye, target)
        cam.keyframe_insert("location", frame=frame)
        cam.keyframe_insert("rotation_euler", frame=frame)
    _linear(cam)
    sc.camera = cam
    return cam


def sun(keys, strength, colour):
    """The sun; `keys`: [(frame, elevation°, azimuth°)]: the direction the light comes from,
    azimuth measured from +Y towards +X (Blender's axes, Z up), linear between keys."""
    sc = bpy.context.scene
    s = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sc.collection.objects.link(s)
    s.data.energy = strength
    s.data.angle = math.radians(0.53)
    s.data.color = colour
    for frame, elevation, azimuth in keys:
        # The light shines along the object's −Z: tilt it by 90° − elevation about X, then
        # turn it so it shines from `azimuth` towards the opposite side.
        s.rotation_euler = (math.radians(90.0 - elevation), 0.0, math.radians(180.0 - azimuth))
        s.keyframe_insert("rotation_euler", frame=frame)
    _linear(s)
    return s


def _linear(obj):
    if obj.animation_data and obj.animation_data.action:
        for fc in obj.animation_data.action.fcurves:
            for k in fc.keyframe_points:
                k.interpolation = "LINEAR"


def export(path, frames):
    """Frame range `frames` (first, last) at 24 fps; everything exported as one .glb."""
    sc = bpy.context.scene
    sc.render.fps = 24
    sc.frame_start, sc.frame_end = frames
    sc.frame_set(frames[0])
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        use_selection=True,
        export_cameras=True,
        export_lights=True,
        export_extras=True,
        export_yup=True,
        export_apply=True,
        export_animations=True,
        export_frame_range=True,
        export_force_sampling=True,
        export_nla_strips=False,
    )
