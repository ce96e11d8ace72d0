"""A cathedral nave, dark stone lit through its windows (issue #27, item 1):

    blender -b --factory-startup --python scripts/scenes/cathedral.py -- scenes/cathedral.glb

The nave runs along +Y (30 m long, 10 m wide, 14 m to the roof). Six tall windows in the left
(−X) wall, each split by a mullion and two transoms, and a rose window of twelve spokes and a
hub in the end wall let in a low sun from beyond the far left corner; two rows of columns cut
the shafts that cross the nave. The camera stands near the entrance and dollies 3 m up the
nave over the shot; the sun sweeps 24° in azimuth and climbs 6° (frames 1–96, 4 s at 24 fps).

Tags: `floor`, `wall` (the walls, roof and end walls), `window` (the side windows' tracery),
`rose` (the rose window's spokes and hub), `column`; the medium fills the nave."""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("cathedral.glb")

stone = common.material("Stone", (0.3, 0.26, 0.21))
pillar = common.material("Pillar", (0.36, 0.32, 0.26))
floor_mat = common.material("Floor", (0.22, 0.2, 0.17))
lead = common.material("Lead", (0.05, 0.05, 0.06))

L, W, H = 30.0, 10.0, 14.0  # nave length (y), width (x), height (z)
T = 0.8  # wall thickness
y0, y1 = -L / 2, L / 2

floor = common.Mesh("Floor", floor_mat, "floor")
floor.box((0, 0, -0.1), (W + 2 * T + 2, L + 2 * T + 2, 0.2))
floor.finish()

walls = common.Mesh("Walls", stone, "wall")
# Left wall (−X) with six window openings: 1.8 m wide, from 3.5 m to 11 m, every 4.2 m.
xw = -W / 2 - T / 2
win_w, win_lo, win_hi = 1.8, 3.5, 11.0
centres = [y0 + 4.0 + 4.4 * i for i in range(6)]
walls.box((xw, 0, win_lo / 2), (T, L + 2 * T, win_lo))
walls.box((xw, 0, (win_hi + H) / 2), (T, L + 2 * T, H - win_hi))
edges = [y0 - T] + [e for c in centres for e in (c - win_w / 2, c + win_w / 2)] + [y1 + T]
for a, b in zip(edges[0::2], edges[1::2]):
    walls.box((xw, (a + b) / 2, (win_lo + win_hi) / 2), (T, b - a, win_hi - win_lo))
# Right wall (+X): solid; roof; entrance wall.
walls.box((W / 2 + T / 2, 0, H / 2), (T, L + 2 * T, H))
# The roof overlaps the walls' tops by 0.2 m, so no seam lets light through.
walls.box((0, 0, H + 0.3), (W + 2 * T, L + 2 * T, 1.0))
walls.box((0, y0 - T / 2, H / 2), (W + 2 * T, T, H))
# End wall (+Y) with the rose window: a disc of radius 3 m centred 9 m up, built from rows of
# blocks 0.25 m tall that leave the disc open.
R, zc, step = 3.0, 9.0, 0.25
ye = y1 + T / 2
walls.box((0, ye, (zc - R) / 2), (W + 2 * T, T, zc - R))
walls.box((0, ye, (zc + R + H) / 2), (W + 2 * T, T, H - zc - R))
z = zc - R
while z < zc + R - 1e-6:
    mid = z + step / 2
    half = math.sqrt(max(R * R - (mid - zc) ** 2, 0.0))
    left, right = -(W / 2 + T), W / 2 + T
    walls.box(((left - half) / 2, ye, mid), (-half - left, T, step))
    walls.box(((right + half) / 2, ye, mid), (right - half, T, step))
    z += step
walls.finish()

tracery = common.Mesh("Tracery", lead, "window")
for c in centres:
    tracery.box((xw, c, (win_lo + win_hi) / 2), (0.2, 0.14, win_hi - win_lo))
    for zt in (6.0, 8.5):
        tracery.box((xw, c, zt), (0.2, win_w, 0.12))
tracery.finish()

rose = common.Mesh("Rose", lead, "rose")
for k in range(12):
    a = math.pi * k / 12
    # A spoke through the centre, turned in the wall's plane (x–z), built from its corners.
    dx, dz = math.cos(a), math.sin(a)
    nx, nz = -dz * 0.07, dx * 0.07
    p = [(-R * dx + nx, -R * dz + nz), (R * dx + nx, R * dz + nz),
         (R * dx - nx, R * dz - nz), (-R * dx - nx, -R * dz - nz)]
    front = [(px, ye - 0.1, zc + pz) for px, pz in p]
    back = [(px, ye + 0.1, zc + pz) for px, pz in p]
    rose.quad(front)
    rose.quad(back)
    for i in range(4):
        j = (i + 1) % 4
        rose.quad([front[i], front[j], back[j], back[i]])
# The hub and a ring at two thirds of the radius, as 24-sided bands.
for rr, width in ((0.55, 0.55), (2.0, 0.12)):
    n = 24
    for i in range(n):
        a0, a1 = 2 * math.pi * i / n, 2 * math.pi * (i + 1) / n
        inner = rr - width if rr > width else 0.0
        q = [(rr * math.cos(a0), rr * math.sin(a0)), (rr * math.cos(a1), rr * math.sin(a1)),
             (inner * math.cos(a1), inner * math.sin(a1)), (inner * math.cos(a0), inner * math.sin(a0))]
        for yy in (ye - 0.1, ye + 0.1):
            rose.quad([(px, yy, zc + pz) for px, pz in q])
rose.finish()

cols = common.Mesh("Columns", pillar, "column")
for side in (-1, 1):
    for i in range(7):
        y = y0 + 3.0 + 4.0 * i
        cols.cylinder((side * 3.0, y, 0.0), 0.45, H - 2.0, segments=20)
        cols.box((side * 3.0, y, H - 1.6), (1.2, 1.2, 0.8))
    # The arcade's beam over the columns, up to the roof.
    cols.box((side * 3.0, 0.0, H - 0.6), (0.9, L, 1.2))
cols.finish()

common.medium_box((-W / 2, y0, 0.0), (W / 2, y1, H))
common.camera([(1, (1.6, y0 + 1.5, 1.7), (-2.2, y1 - 2.0, 6.0)),
               (96, (1.4, y0 + 4.5, 1.8), (-2.2, y1 - 1.0, 6.3))], fov_deg=70.0)
common.sun([(1, 30.0, 302.0), (96, 36.0, 326.0)], strength=6.0, colour=(1.0, 0.86, 0.66))
common.export(out, (1, 96))
