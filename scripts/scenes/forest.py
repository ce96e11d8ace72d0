"""A forest clearing (issue #27, item 1):

    blender -b --factory-startup --python scripts/scenes/forest.py -- scenes/forest.glb

Sixty-four trees stand on a ring 6–25 m around an open clearing. Each crown is a dozen clumps
of leaves inside an ellipsoid, so the canopy has gaps of every size: wide ones between clumps
and crowns, narrow ones between the leaves of a clump — what hole filling closes and Perlin
holes open. A sun 34° up shines from beyond the far side of the clearing through the crowns
towards the camera, which walks 7 m out of the trees towards the clearing over the shot while the sun swings 10°
(frames 1–96, 4 s at 24 fps). The leaves, the trunks and the ground are drawn from a fixed seed.

Tags: `foliage` (every leaf), `trunk`, `ground`; the medium is a box over the forest up to the
crowns' middle (10 m), so the lit air above the canopy does not veil the shafts."""

import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("forest.glb")
rng = random.Random(27)

leaf_mat = common.material("Leaves", (0.05, 0.09, 0.03))
bark = common.material("Bark", (0.07, 0.05, 0.04))
soil = common.material("Ground", (0.06, 0.06, 0.04))

ground = common.Mesh("Ground", soil, "ground")
ground.box((0, 0, -0.1), (90, 90, 0.2))
ground.finish()

trunks = common.Mesh("Trunks", bark, "trunk")
leaves = common.Mesh("Leaves", leaf_mat, "foliage")


def leaf(centre, size):
    """One leaf: a square quad of side `size`, turned at random."""
    a, b = rng.uniform(0, math.pi), rng.uniform(-1.2, 1.2)
    u = (math.cos(a), math.sin(a), 0.0)
    v = (-math.sin(a) * math.cos(b), math.cos(a) * math.cos(b), math.sin(b))
    h = size / 2
    leaves.quad([tuple(c + h * (su * ui + sv * vi) for c, ui, vi in zip(centre, u, v))
                 for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


placed = []
while len(placed) < 64:
    r, a = rng.uniform(6.0, 25.0), rng.uniform(0, 2 * math.pi)
    x, y = r * math.cos(a), r * math.sin(a)
    # Keep the camera's walk clear (it comes in from −Y) and the trees apart.
    if abs(x) < 1.4 and y < -4.0:
        continue
    if any(math.hypot(x - px, y - py) < 2.7 for px, py in placed):
        continue
    placed.append((x, y))
for x, y in placed:
    height = rng.uniform(9.0, 15.0)
    base_r = rng.uniform(0.18, 0.35)
    trunks.cylinder((x, y, 0.0), base_r, height * 0.85, segments=10, radius_top=base_r * 0.5)
    # The crown: an ellipsoid from 45 % of the height to the top, clumps inside it.
    cz, rz = height * 0.7, height * 0.3
    rxy = rng.uniform(2.6, 4.0)
    for _ in range(rng.randint(10, 15)):
        while True:
            p = [rng.uniform(-1, 1) for _ in range(3)]
            if sum(q * q for q in p) <= 1.0:
                break
        clump = (x + p[0] * rxy, y + p[1] * rxy, cz + p[2] * rz)
        cr = rng.uniform(0.6, 1.5)
        for _ in range(int(16 * cr * cr) + 5):
            while True:
                q = [rng.uniform(-1, 1) for _ in range(3)]
                if sum(t * t for t in q) <= 1.0:
                    break
            leaf(tuple(c + cr * t for c, t in zip(clump, q)), rng.uniform(0.35, 0.7))
trunks.finish()
leaves.finish()

common.medium_box((-28.0, -28.0, 0.0), (28.0, 28.0, 10.0))
common.camera([(1, (0.3, -17.0, 1.6), (0.0, 10.0, 5.0)),
               (96, (0.0, -10.0, 1.7), (-0.8, 10.0, 5.5))], fov_deg=65.0)
common.sun([(1, 34.0, 8.0), (96, 34.0, -2.0)], strength=5.0, colour=(1.0, 0.9, 0.72))
common.export(out, (1, 96))
