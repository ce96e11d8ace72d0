"""A glory: the observer's shadow on a fog bank (issue #46, item 3):

    blender -b --factory-startup --python scripts/scenes/glory.py -- scenes/glory.glb

A figure stands 3 m from the edge of a ridge 100 m high, over a fog bank (the medium box, tagged:
up to 0.5 m below the ridge's top, 200 m ahead and 240 m wide: with σt = 0.06/m its far sides are 95% extinct) with the sun 20° up behind it. The camera is the
figure's eye (just in front of its face) looking down at the antisolar point, 20° below the
horizon, so the figure itself is behind it and out of frame: the
figure's shadow, a dark column through the fog, runs towards that point from every camera
position (parallel lines meet at their vanishing point), and the fog's backscatter puts the
glory's coloured rings around its head. Rocks on the ridge, drawn from a fixed seed.

Tags: `ground` (the ridge), `rock`, `figure`."""

import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

common.clear()
out = common.out_path("glory.glb")
rng = random.Random(4602)

stone = common.material("Ridge", (0.12, 0.11, 0.1))
rock_mat = common.material("Rock", (0.09, 0.085, 0.08))
cloth = common.material("Cloth", (0.15, 0.05, 0.04))

ridge = common.Mesh("Ridge", stone, "ground")
ridge.box((0, -30.0, 50.0), (240.0, 60.0, 100.0))
ridge.finish()

# No valley floor under the fog: the figure's and the ridge's shadows fall through the whole
# fog bank from the occluders alone (an occluder shadows everything behind it, issue #60).

rocks = common.Mesh("Rocks", rock_mat, "rock")
for _ in range(18):
    x, y = rng.uniform(-25, 25), rng.uniform(-30, -1.5)
    if abs(x) < 3 and y > -10:
        continue
    s = rng.uniform(0.4, 1.6)
    rocks.box((x, y, 100.0 + s * 0.3), (s, s * rng.uniform(0.7, 1.3), s * 0.8),
              rot_z=rng.uniform(0, 3.1))
rocks.finish()

figure = common.Mesh("Figure", cloth, "figure")
fx, fy = 0.0, -3.0
figure.cylinder((fx - 0.12, fy, 100.0), 0.09, 0.85, segments=10)  # legs
figure.cylinder((fx + 0.12, fy, 100.0), 0.09, 0.85, segments=10)
figure.cylinder((fx, fy, 100.85), 0.2, 0.6, segments=12)  # body
figure.box((fx - 0.3, fy, 101.05), (0.1, 0.12, 0.6), rot_x=0.0)  # arms
figure.box((fx + 0.3, fy, 101.05), (0.1, 0.12, 0.6))
figure.cylinder((fx, fy, 101.45), 0.05, 0.1, segments=8)  # neck
figure.cylinder((fx, fy, 101.55), 0.12, 0.25, segments=12, radius_top=0.1)  # head
figure.finish()

common.medium_box((-120.0, 0.0, 0.0), (120.0, 200.0, 99.5))
# The eye: 0.2 m from the head's centre along the sunlight, so the view ray to the antisolar
# point runs down the middle of the head's shadow.
eye = (0.0, -3.0 + 0.2 * 0.9397, 101.675 - 0.2 * 0.3420)
common.camera([(1, eye, (eye[0], eye[1] + 100.0, eye[2] - 36.397))], fov_deg=60.0,
              clip_end=5000.0)
common.sun([(1, 20.0, 180.0)], strength=4.0, colour=(1.0, 0.92, 0.8))
common.export(out, (1, 1))
