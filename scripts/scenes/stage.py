"""A theatre stage in haze: spot lights from a truss and a lamp behind the set (issue #44):

    blender -b --factory-startup --python scripts/scenes/stage.py -- scenes/stage.glb

A stage 14 m wide and 9 m deep, raised 1 m above the stalls. At its back a flat painted wall
13 m high is cut by three tall windows with mullions; high behind it a bare lamp (a point light,
12000 W in Blender's units, 955 W/sr, cold white) throws shafts down through the windows onto
the stage. Above the front of the stage a truss carries three spot lights
(3000 W, 239 W/sr; cones of 40° with a soft edge; magenta, cyan and amber) aimed at a figure
standing centre stage, at a chair and at a column. The camera sits in the stalls, eye level,
and drifts slowly sideways (frames 1–48, 2 s at 24 fps).

Also writes the gobo `scenes/gobo_rays.png` beside the scene: a disc broken by twelve radial
slots and a central hole (white passes light, black stops it), 256², for `LightMap.path` on a
spot's map.

Lights, in node order: `Spot_magenta`, `Spot_cyan`, `Spot_amber` (spot), `Backlight`
(point). Tags: `stage` (floor and stalls), `set` (the back wall and its mullions, the column,
the chair), `figure`, `truss`; the medium is a box over the stage and the stalls up to 9 m."""

import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("stage.glb")

boards = common.material("Boards", (0.12, 0.08, 0.05))
black = common.material("Black", (0.02, 0.02, 0.02))
paint = common.material("Paint", (0.3, 0.28, 0.33))
skin = common.material("Figure", (0.4, 0.3, 0.25))

stage = common.Mesh("Stage", boards, "stage")
stage.box((0, 0.5, 0.5), (14.0, 9.0, 1.0))          # the stage, front edge at y = −4
stage.box((0, -12.0, -0.05), (30.0, 16.0, 0.1))     # the stalls' floor
stage.finish()

# The back wall at y = 5, 13 m high and 24 m wide, with three windows 1.6 m wide, 4.5 m high, from 2.5 m up, each with a
# vertical mullion and two transoms.
wall = common.Mesh("Wall", paint, "set")
W, Y, T = 24.0, 5.0, 0.2   # wider and taller than the haze, so the lamp lights it only through the windows
xs = (-4.0, 0.0, 4.0)
win_w, win_lo, win_hi = 1.6, 2.5, 7.0
edges = [-W / 2] + [e for x in xs for e in (x - win_w / 2, x + win_w / 2)] + [W / 2]
for a, b in zip(edges[0::2], edges[1::2]):
    wall.box(((a + b) / 2, Y, 7.5), (b - a, T, 13.0))
for x in xs:
    wall.box((x, Y, (1.0 + win_lo) / 2), (win_w, T, win_lo - 1.0))   # under the window
    wall.box((x, Y, (win_hi + 14.0) / 2), (win_w, T, 14.0 - win_hi))   # over it
    wall.box((x, Y, (win_lo + win_hi) / 2), (0.08, T, win_hi - win_lo))
    for z in (4.0, 5.5):
        wall.box((x, Y, z), (win_w, T, 0.08))
# A column stage left and a chair stage right.
wall.cylinder((-4.5, 1.5, 1.0), 0.35, 5.0, segments=20)
wall.box((4.0, 0.0, 1.45), (0.6, 0.6, 0.06))
for dx in (-0.27, 0.27):
    for dy in (-0.27, 0.27):
        wall.box((4.0 + dx, dy, 1.22), (0.05, 0.05, 0.45))
wall.box((4.0, 0.28, 1.85), (0.6, 0.05, 0.8))
wall.finish()

figure = common.Mesh("Figure", skin, "figure")
figure.cylinder((0.0, 0.5, 1.0), 0.22, 1.45, segments=16, radius_top=0.18)
figure.cylinder((0.0, 0.5, 2.5), 0.12, 0.26, segments=16)
for dx in (-0.3, 0.3):
    figure.box((dx, 0.5, 1.9), (0.1, 0.1, 0.65), rot_x=0.0)
figure.finish()

truss = common.Mesh("Truss", black, "truss")
for dz in (0.0, 0.4):
    truss.box((0.0, -3.0, 7.4 + dz), (12.0, 0.06, 0.06))
    truss.box((0.0, -2.6, 7.4 + dz), (12.0, 0.06, 0.06))
for k in range(-15, 16):
    truss.box((k * 0.4, -2.8, 7.6), (0.03, 0.4, 0.45))
truss.finish()

common.medium_box((-9.0, -16.0, 0.0), (9.0, 4.9, 9.0))


def spot(name, location, target, colour):
    o = bpy.data.objects.new(name, bpy.data.lights.new(name, "SPOT"))
    bpy.context.scene.collection.objects.link(o)
    o.location = location
    o.data.energy = 3000.0
    o.data.color = colour
    o.data.spot_size = math.radians(40.0)
    o.data.spot_blend = 0.25
    o.data.shadow_soft_size = 0.0
    from mathutils import Vector

    d = Vector(target) - Vector(location)
    o.rotation_mode = "QUATERNION"
    o.rotation_quaternion = d.to_track_quat("-Z", "Y")
    return o


spot("Spot_magenta", (-3.0, -3.2, 7.2), (0.0, 0.5, 1.0), (1.0, 0.25, 0.7))
spot("Spot_cyan", (3.0, -3.2, 7.2), (4.0, 0.0, 1.0), (0.25, 0.8, 1.0))
spot("Spot_amber", (-1.0, -3.2, 7.2), (-4.5, 1.5, 2.0), (1.0, 0.6, 0.2))
back = bpy.data.objects.new("Backlight", bpy.data.lights.new("Backlight", "POINT"))
bpy.context.scene.collection.objects.link(back)
back.location = (5.0, 10.0, 12.0)
back.data.energy = 12000.0
back.data.color = (0.8, 0.88, 1.0)
back.data.shadow_soft_size = 0.0

common.camera([(1, (-2.5, -15.0, 2.2), (0.0, 2.0, 3.6)),
               (48, (1.5, -15.0, 2.2), (0.0, 2.0, 3.6))], fov_deg=58.0)
common.export(out, (1, 48))

# The gobo: white passes, black stops; a disc with twelve radial slots and a central hole.
N = 256
img = bpy.data.images.new("gobo_rays", N, N, alpha=False)
px = []
for y in range(N):
    for x in range(N):
        u, v = (x + 0.5) / N * 2 - 1, (y + 0.5) / N * 2 - 1
        r, a = math.hypot(u, v), math.atan2(v, u)
        slot = abs(((a / (2 * math.pi) * 12) % 1.0) - 0.5) < 0.17
        lit = r < 0.16 or (0.28 < r < 0.92 and slot)
        c = 1.0 if lit else 0.0
        px += [c, c, c, 1.0]
img.pixels = px
img.filepath_raw = os.path.join(os.path.dirname(os.path.abspath(out)), "gobo_rays.png")
img.file_format = "PNG"
img.save()
