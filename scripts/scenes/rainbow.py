"""A rainbow over a valley (issue #46, item 3):

    blender -b --factory-startup --python scripts/scenes/rainbow.py -- scenes/rainbow.glb

The sun is 9° above the horizon behind the camera, so the antisolar point is 9° below the
horizon straight ahead and the primary bow (42° around it) rises 33° above the valley, the
secondary (51°) 42°. A rain curtain — the medium box, 60–260 m ahead, up to 90 m — hangs over
the valley floor, in front of low hills; the camera (2 m above the ground, 100° wide) sees the
whole arc. Behind and above the camera a broken cloud deck (150 m up, 170–470 m back)
shades the curtain's upper part except where the sun comes through its gaps: shafts that run away from
the sun and converge on the antisolar point, crossing the bow. A few trees stand in the
middle distance. Everything is drawn from a fixed seed.

Tags: `ground`, `hill`, `tree`, `cloud` (the deck, behind the camera: never in frame)."""

import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("rainbow.glb")
rng = random.Random(46)

grass = common.material("Grass", (0.06, 0.09, 0.03))
hill_mat = common.material("Hills", (0.04, 0.06, 0.03))
bark = common.material("Bark", (0.06, 0.045, 0.03))
leaves = common.material("Leaves", (0.015, 0.035, 0.012))
cloud_mat = common.material("Cloud", (0.5, 0.5, 0.5))

ground = common.Mesh("Ground", grass, "ground")
ground.box((0, 150, -0.5), (1400, 1400, 1.0))
ground.finish()

hills = common.Mesh("Hills", hill_mat, "hill")
for k in range(9):
    x = -360 + 90 * k + rng.uniform(-25, 25)
    y = rng.uniform(300, 380)
    hills.cylinder((x, y, 0.0), rng.uniform(70, 110), rng.uniform(18, 34), segments=24,
                   radius_top=rng.uniform(8, 20))
hills.finish()

trunks = common.Mesh("Trunks", bark, "tree")
crowns = common.Mesh("Crowns", leaves, "tree")
for _ in range(14):
    x, y = rng.uniform(-110, 110), rng.uniform(35, 90)
    if abs(x) < 12:
        continue
    h = rng.uniform(6, 11)
    common.conifer(trunks, crowns, x, y, h)
trunks.finish()
crowns.finish()

# The broken deck behind the camera: 40 m cells, one in five missing. Seen from the
# curtain (60–150 m ahead) towards the sun, 150 m up and 170–470 m back covers heights
# 52–110 m: the bows' upper half.
deck = common.Mesh("Deck", cloud_mat, "cloud")
for i in range(-9, 9):
    for j in range(8):
        if rng.random() < 0.2:
            continue
        deck.box((i * 40.0 + 20.0, -190.0 - j * 40.0, 150.0), (40.0, 40.0, 4.0))
deck.finish()

common.medium_box((-320.0, 60.0, 0.0), (320.0, 260.0, 90.0))
common.camera([(1, (0.0, -20.0, 2.0), (0.0, 100.0, 27.0))], fov_deg=100.0, clip_end=2000.0)
common.sun([(1, 9.0, 180.0)], strength=4.0, colour=(1.0, 0.86, 0.68))
common.export(out, (1, 1))
