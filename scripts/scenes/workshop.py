"""A workshop under skylights, dusty air (issue #27, item 1):

    blender -b --factory-startup --python scripts/scenes/workshop.py -- scenes/workshop.glb

A hall 12 m wide, 22 m long and 7 m high whose roof has three skylights, each a grid of 4 × 3
panes between mullions; a high sun falls through them in slanting gridded shafts onto
workbenches, shelving and a hanging chain hoist. The camera stands at one end at eye height and
pans slowly across the hall while the sun moves 12° (frames 1–96, 4 s at 24 fps).

Tags: `floor`, `wall` (walls and roof), `skylight` (the mullions), `props` (benches, shelves,
hoist); the medium fills the hall."""

import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("workshop.glb")
rng = random.Random(3)

brick = common.material("Brick", (0.13, 0.08, 0.06))
concrete = common.material("Concrete", (0.12, 0.12, 0.11))
steel = common.material("Steel", (0.05, 0.05, 0.055))
wood = common.material("Wood", (0.16, 0.10, 0.05))

W, L, H = 12.0, 22.0, 7.0
T = 0.4
y0, y1 = -L / 2, L / 2

floor = common.Mesh("Floor", concrete, "floor")
floor.box((0, 0, -0.1), (W + 10, L + 10, 0.2))
floor.finish()

walls = common.Mesh("Walls", brick, "wall")
for sx in (-1, 1):
    walls.box((sx * (W / 2 + T / 2), 0, H / 2), (T, L + 2 * T, H))
for sy in (-1, 1):
    walls.box((0, sy * (L / 2 + T / 2), H / 2), (W, T, H))
# The roof with three skylight openings (3.6 m across x, 2.8 m along y), centred on the axis.
sky_x, sky_y = 3.6, 2.8
centres = [-6.0, 0.0, 6.0]
zr = H + T / 2
walls.box((-(W / 2 + sky_x / 2) / 2, 0, zr), (W / 2 - sky_x / 2, L, T))
walls.box(((W / 2 + sky_x / 2) / 2, 0, zr), (W / 2 - sky_x / 2, L, T))
edges = [y0] + [e for c in centres for e in (c - sky_y / 2, c + sky_y / 2)] + [y1]
for a, b in zip(edges[0::2], edges[1::2]):
    walls.box((0, (a + b) / 2, zr), (sky_x, b - a, T))
walls.finish()

frames = common.Mesh("Mullions", steel, "skylight")
for c in centres:
    for i in range(1, 4):
        frames.box((-sky_x / 2 + i * sky_x / 4, c, zr), (0.1, sky_y, T + 0.05))
    for j in range(1, 3):
        frames.box((0, c - sky_y / 2 + j * sky_y / 3, zr), (sky_x, 0.1, T + 0.05))
    # Roof trusses under each skylight's edge.
    for sy in (-1, 1):
        frames.box((0, c + sy * (sky_y / 2 + 0.15), H - 0.35), (W, 0.18, 0.5))
frames.finish()

props = common.Mesh("Props", wood, "props")
for i, y in enumerate((-7.0, -2.5, 2.0, 6.5)):
    x = -2.2 if i % 2 == 0 else 2.4
    props.box((x, y, 0.9), (2.4, 1.0, 0.08))
    for dx in (-1.1, 1.1):
        for dy in (-0.42, 0.42):
            props.box((x + dx, y + dy, 0.45), (0.08, 0.08, 0.9))
    # Clutter on the bench.
    for _ in range(5):
        props.box((x + rng.uniform(-1.0, 1.0), y + rng.uniform(-0.3, 0.3), 0.94 + 0.12),
                  (rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.3), rng.uniform(0.1, 0.3)),
                  rot_z=rng.uniform(0, 3.1))
# Shelving along the right wall: uprights and five boards.
for y in (-9.0, -5.0, -1.0, 3.0, 7.0):
    for dy in (-1.6, 1.6):
        props.box((W / 2 - 0.5, y + dy, 1.6), (0.6, 0.06, 3.2))
    for z in (0.3, 1.0, 1.7, 2.4, 3.1):
        props.box((W / 2 - 0.5, y, z), (0.6, 3.3, 0.04))
# A chain hoist hanging from the middle truss: a rail, the chain as links, a hook block.
props.box((0, 0.0, H - 0.7), (0.2, 14.0, 0.25))
for k in range(14):
    props.box((0.0, 0.0, H - 1.0 - 0.22 * k), (0.05, 0.12 if k % 2 else 0.05, 0.2))
props.box((0, 0, H - 4.3), (0.35, 0.25, 0.4))
props.finish()

common.medium_box((-W / 2, y0, 0.0), (W / 2, y1, H))
common.camera([(1, (-4.6, y0 + 1.0, 1.7), (1.0, 4.0, 3.0)),
               (96, (-4.2, y0 + 1.5, 1.7), (3.0, 3.0, 3.2))], fov_deg=64.0)
common.sun([(1, 58.0, 70.0), (96, 62.0, 82.0)], strength=7.0, colour=(1.0, 0.93, 0.8))
common.export(out, (1, 96))
