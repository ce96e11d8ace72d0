"""A low sun through a high thin layer (issue #46, item 3):

    blender -b --factory-startup --python scripts/scenes/halo.py -- scenes/halo.glb

An open plain with a line of low hills and a few trees ahead, the sun 14° above the horizon
beyond them. The medium box (tagged) is a layer 60–110 m up reaching 6 km ahead and 3 km to each
side, so every view ray above the horizon crosses it: with ice crystals it is a cirrus veil
(the 22° and 46° halos around the sun), with small water droplets a thin cloud (the corona). The
camera stands 2 m above the plain looking towards the sun; the presets frame it themselves
(Scene's custom camera). Everything is drawn from a fixed seed.

Tags: `ground`, `hill`, `tree`."""

import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("halo.glb")
rng = random.Random(4622)

grass = common.material("Grass", (0.07, 0.08, 0.04))
hill_mat = common.material("Hills", (0.04, 0.05, 0.035))
bark = common.material("Bark", (0.06, 0.045, 0.03))
leaves = common.material("Leaves", (0.02, 0.04, 0.015))

ground = common.Mesh("Ground", grass, "ground")
ground.box((0, 2500, -0.5), (12000, 12000, 1.0))
ground.finish()

hills = common.Mesh("Hills", hill_mat, "hill")
for k in range(14):
    x = -1300 + 200 * k + rng.uniform(-60, 60)
    hills.cylinder((x, rng.uniform(900, 1100), 0.0), rng.uniform(140, 220), rng.uniform(25, 55),
                   segments=24, radius_top=rng.uniform(10, 40))
hills.finish()

trunks = common.Mesh("Trunks", bark, "tree")
crowns = common.Mesh("Crowns", leaves, "tree")
for _ in range(10):
    x, y = rng.uniform(-90, 90), rng.uniform(40, 160)
    h = rng.uniform(7, 12)
    common.conifer(trunks, crowns, x, y, h)
trunks.finish()
crowns.finish()

common.medium_box((-3000.0, -200.0, 60.0), (3000.0, 6000.0, 110.0))
common.camera([(1, (0.0, -20.0, 2.0), (0.0, 100.0, 30.0))], fov_deg=100.0, clip_end=15000.0)
common.sun([(1, 14.0, 0.0)], strength=4.0, colour=(1.0, 0.93, 0.82))
common.export(out, (1, 1))
