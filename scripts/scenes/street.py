"""A street of lamp posts in fog under a moon, and a lantern swinging on a wire (issue #44):

    blender -b --factory-startup --python scripts/scenes/street.py -- scenes/street.glb

A cobbled street 8 m wide between a row of house fronts (left) and a garden wall with railings
(right). Three lamp posts stand along the right kerb; each head holds a spot light (a 60 W-ish
street lamp: 900 W in Blender's units, 72 W/sr, warm) shining down through a louvred grille,
so each cone of light in the fog is striped along the street. Between the second and third posts a lantern
hangs from a wire across the street: a point light (800 W, 64 W/sr) inside a cage of eight
bars, swinging ±14° about the wire (frames 1–48, 2 s at 24 fps, one full swing), so its
radial shafts sweep the fog. A weak blue moon (0.08 W/m²) shines from behind the houses.

Lights, in node order: `Moon` (directional), `Lamp_1`, `Lamp_2`, `Lamp_3` (spot), `Lantern`
(point). Tags: `ground`, `houses`, `wall` (garden wall and railings), `posts` (the posts, arms
and grilles), `lantern` (the cage); the medium is a box over the street up to 7 m."""

import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("street.glb")

stone = common.material("Cobbles", (0.09, 0.085, 0.08))
plaster = common.material("Plaster", (0.35, 0.3, 0.24))
brick = common.material("Brick", (0.2, 0.1, 0.07))
iron = common.material("Iron", (0.03, 0.03, 0.03))

ground = common.Mesh("Ground", stone, "ground")
ground.box((0, 0, -0.1), (40, 80, 0.2))
# Kerbs.
for x in (-4.0, 4.0):
    ground.box((x, 0, 0.06), (0.3, 80, 0.12))
ground.finish()

# House fronts on the left: a wall 9 m high with rows of recessed windows, roofs stepping.
houses = common.Mesh("Houses", plaster, "houses")
for i, y0 in enumerate(range(-30, 30, 6)):
    h = 8.0 + (i % 3) * 1.2
    houses.box((-6.5, y0 + 3, h / 2), (1.0, 6.0, h))
    for z in (2.0, 5.0):
        for dy in (1.5, 4.5):
            # Window frames proud of the wall: their shadows break the moonlight.
            houses.box((-5.92, y0 + dy, z), (0.16, 1.3, 0.12))
            houses.box((-5.92, y0 + dy, z + 1.5), (0.16, 1.3, 0.12))
houses.finish()

# Garden wall with railings on the right: the lamps' cones and the moon fall through them.
wall = common.Mesh("Wall", brick, "wall")
wall.box((6.0, 0, 0.5), (0.4, 80, 1.0))
for k in range(-200, 200):
    wall.box((6.0, k * 0.2, 1.8), (0.05, 0.05, 1.6))
wall.box((6.0, 0, 2.6), (0.08, 80, 0.08))
wall.finish()

posts = common.Mesh("Posts", iron, "posts")
LAMPS = [(-10.0, "Lamp_1"), (2.0, "Lamp_2"), (14.0, "Lamp_3")]
HEAD = 5.2
for y, _ in LAMPS:
    posts.cylinder((4.6, y, 0.0), 0.09, HEAD + 0.3, segments=12)
    posts.box((3.85, y, HEAD + 0.25), (1.5, 0.08, 0.08))  # the arm over the road
    # The head: a hood over the light and a grille of five slats under it, running along the
    # street, so the sheets of shadow they cast are seen edge-on from the camera.
    posts.box((3.2, y, HEAD + 0.2), (0.7, 0.7, 0.1))
    for s in range(5):
        posts.box((3.2 - 0.3 + s * 0.15, y, HEAD - 0.25), (0.07, 0.6, 0.04))
posts.finish()

common.medium_box((-6.0, -40.0, 0.0), (5.9, 40.0, 7.0))


def spot(name, location, power, colour, size_deg, blend):
    o = bpy.data.objects.new(name, bpy.data.lights.new(name, "SPOT"))
    bpy.context.scene.collection.objects.link(o)
    o.location = location
    o.data.energy = power
    o.data.color = colour
    o.data.spot_size = math.radians(size_deg)
    o.data.spot_blend = blend
    o.data.shadow_soft_size = 0.0
    o.rotation_euler = (0.0, 0.0, 0.0)  # shining straight down (−Z)
    return o


moon = common.sun([(1, 38.0, 250.0)], strength=0.08, colour=(0.55, 0.65, 1.0))
moon.name = "Moon"
moon.data.name = "Moon"
for y, name in LAMPS:
    spot(name, (3.2, y, HEAD), 900.0, (1.0, 0.72, 0.4), 100.0, 0.15)

# The lantern: a pivot on the wire, the cage and the light hang 1.2 m below it and swing.
pivot = bpy.data.objects.new("Wire", None)
bpy.context.scene.collection.objects.link(pivot)
pivot.location = (0.0, 8.0, 6.4)
cage = common.Mesh("Cage", iron, "lantern")
for k in range(8):
    a = 2 * math.pi * (k + 0.5) / 8
    cage.box((0.22 * math.cos(a), 0.22 * math.sin(a), -1.2), (0.04, 0.04, 0.5))
cage.box((0, 0, -0.93), (0.5, 0.5, 0.05))  # the roof
cage.box((0, 0, -1.47), (0.5, 0.5, 0.05))  # the floor
cage.box((0, 0, -0.45), (0.02, 0.02, 0.9))  # the chain to the wire
cage_obj = cage.finish()
cage_obj.parent = pivot
lantern = bpy.data.objects.new("Lantern", bpy.data.lights.new("Lantern", "POINT"))
bpy.context.scene.collection.objects.link(lantern)
lantern.data.energy = 800.0
lantern.data.color = (1.0, 0.62, 0.3)
lantern.data.shadow_soft_size = 0.0
lantern.location = (0.0, 0.0, -1.2)
lantern.parent = pivot
# The wire across the street.
wire = common.Mesh("WireLine", iron, "posts")
wire.box((0.5, 8.0, 6.42), (11.0, 0.02, 0.02))
wire.finish()
for frame, angle in ((1, 14.0), (13, 0.0), (25, -14.0), (37, 0.0), (49, 14.0)):
    pivot.rotation_euler = (0.0, math.radians(angle), 0.0)
    pivot.keyframe_insert("rotation_euler", frame=frame)
# A pendulum: slow at the ends of the swing, fastest through the bottom.
for fc in pivot.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "SINE"
        k.easing = "EASE_IN" if abs(k.co[1]) > 0.1 else "EASE_OUT"

common.camera([(1, (-1.5, -24.0, 1.7), (0.8, 6.0, 3.6)),
               (48, (-1.2, -22.0, 1.7), (0.8, 6.0, 3.6))], fov_deg=55.0)
common.export(out, (1, 48))
