#!/usr/bin/env python3
"""Angles of the rings in the atmospheric-optics pictures (issue #46, item 3), measured on the
rendered PNGs from the presets' cameras:

    python3 scripts/ring_angles.py            # reads docs/atmosphere/{rainbow,glory,halo}.png

Each pixel's view direction comes from its camera (read from scenes/*.glb, and the corona's
custom camera from graphs/atmosphere/halo.ron), and its angle from the centre of the phenomenon
(the antisolar point for bows and glories, the sun for halos and coronas: the glTF's sun); the
pixels of the sky and medium (rows above the ground, or above the ridge's shadow for the glory)
are averaged in 0.05° rings per channel, and each feature is read off that profile: a bow's or glory ring's brightest ring, a halo's inner
edge (steepest rise), a corona's first dark ring. Needs numpy and Pillow."""

import json
import math
import re
import struct
import sys

import numpy as np
from PIL import Image


def directions(w, h, eye, target, yfov_deg):
    """Unit view directions (h, w, 3) of a pinhole camera with no roll, y up."""
    f = np.subtract(target, eye, dtype=float)
    f /= np.linalg.norm(f)
    r = np.cross(f, [0.0, 1.0, 0.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    t = math.tan(math.radians(yfov_deg) / 2)
    xs = ((np.arange(w) + 0.5) / w * 2 - 1) * t * w / h
    ys = (1 - (np.arange(h) + 0.5) / h * 2) * t
    d = f + xs[None, :, None] * r + ys[:, None, None] * u
    return d / np.linalg.norm(d, axis=2, keepdims=True)


def _glb(path):
    with open(path, "rb") as f:
        data = f.read()
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n])


def _forward(node):
    """The node's −z axis in the world (cameras look, lights shine along it)."""
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    q, v = np.array([x, y, z]), np.array([0.0, 0.0, -1.0])
    t = 2 * np.cross(q, v)  # v + w t + q × t rotates v by the unit quaternion
    return v + w * t + np.cross(q, t)


def glb_camera(path):
    """(eye, forward, yfov°) of the first camera node of a binary glTF (y up, no roll)."""
    gltf = _glb(path)
    node = next(nd for nd in gltf["nodes"] if "camera" in nd)
    yfov = math.degrees(gltf["cameras"][node["camera"]]["perspective"]["yfov"])
    return np.array(node.get("translation", [0, 0, 0]), dtype=float), _forward(node), yfov


def glb_sunlight(path):
    """The direction the glTF's first light shines along: towards the antisolar point."""
    node = next(nd for nd in _glb(path)["nodes"] if "KHR_lights_punctual" in nd.get("extensions", {}))
    return _forward(node)


def ron_custom_camera(path, node):
    """(eye, target, fov°) of a `Scene` node with camera = custom in a graph file."""
    text = open(path).read()
    line = next(l for l in text.splitlines() if f'"{node}":' in l)
    get = lambda k: float(re.search(rf'"{k}": (-?[0-9.]+)', line).group(1))  # noqa: E731
    return ((get("cam_x"), get("cam_y"), get("cam_z")),
            (get("target_x"), get("target_y"), get("target_z")), get("fov"))


def profile(img, dirs, centre, below, step=0.05, upto=60.0):
    """Mean of each channel over rings of `step`° around `centre`, rows above `below`."""
    ang = np.degrees(np.arccos(np.clip(dirs @ centre, -1, 1)))[:below]
    px = img[:below].reshape(-1, 3)
    k = (ang.reshape(-1) / step).astype(int)
    n = int(upto / step)
    keep = k < n
    counts = np.bincount(k[keep], minlength=n)
    out = np.stack([np.bincount(k[keep], weights=px[keep, c], minlength=n) for c in range(3)], 1)
    with np.errstate(invalid="ignore"):
        prof = out / counts[:, None]
    return (np.arange(n) + 0.5) * step, prof, counts


def brightest(a, p, c, lo, hi):
    m = (a > lo) & (a < hi) & ~np.isnan(p[:, c])
    return a[m][np.nanargmax(p[m, c])]


def edge(a, p, c, lo, hi):
    """Angle of the steepest rise of channel c in lo..hi (smoothed over 0.15°)."""
    m = (a > lo) & (a < hi)
    q = np.convolve(np.nan_to_num(p[:, c]), np.ones(3) / 3, mode="same")
    g = np.gradient(q)
    return a[m][np.argmax(g[m])]


def first_min(a, p, c, lo, hi):
    m = np.where((a > lo) & (a < hi))[0]
    q = np.convolve(np.nan_to_num(p[:, c]), np.ones(5) / 5, mode="same")
    for i in m[2:-2]:
        if q[i] < q[i - 2] and q[i] <= q[i + 2]:
            return a[i]
    return float("nan")


def load(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=float)


def main():
    # Rainbow (the left, physical half): scenes/rainbow.glb's camera and sun; rows above the
    # valley floor.
    img = load("docs/atmosphere/rainbow.png")
    h, w = img.shape[:2]
    eye, fwd, yfov = glb_camera("scenes/rainbow.glb")
    d = directions(w // 2, h, eye, eye + fwd, yfov)
    a, p, _ = profile(img[:, : w // 2], d, glb_sunlight("scenes/rainbow.glb"), int(h * 0.62))
    print("rainbow (from the antisolar point): primary",
          " / ".join(f"{brightest(a, p, c, 38, 45):.2f}°" for c in range(3)), "; secondary",
          " / ".join(f"{brightest(a, p, c, 48, 56):.2f}°" for c in range(3)), "(R / G / B)")
    # Glory (the right half): scenes/glory.glb's camera looks at the antisolar point; rows
    # above the ridge's shadow, which starts there.
    img = load("docs/atmosphere/glory.png")
    h, w = img.shape[:2]
    eye, fwd, yfov = glb_camera("scenes/glory.glb")
    d = directions(w // 2, h, eye, eye + fwd, yfov)
    a, p, _ = profile(img[:, w // 2:], d, glb_sunlight("scenes/glory.glb"), h // 2 - 2)
    print("glory (from the antisolar point): first bright ring",
          " / ".join(f"{brightest(a, p, c, 1.0, 6.0):.2f}°" for c in range(3)), "(R / G / B)")
    # Halo: left, the corona (scene_sun's custom camera in graphs/atmosphere/halo.ron); right,
    # scenes/halo.glb's camera, rows above the hills. Angles from the sun.
    img = load("docs/atmosphere/halo.png")
    h, w = img.shape[:2]
    sun = -glb_sunlight("scenes/halo.glb")
    eye, target, fov = ron_custom_camera("graphs/atmosphere/halo.ron", "scene_sun")
    d = directions(w // 2, h, eye, target, fov)
    a, p, _ = profile(img[:, : w // 2], d, sun, h, step=0.05, upto=8)
    print("corona (from the sun): first dark ring",
          " / ".join(f"{first_min(a, p, c, 1.0, 6.0):.2f}°" for c in range(3)), "(R / G / B)")
    eye, fwd, yfov = glb_camera("scenes/halo.glb")
    d = directions(w // 2, h, eye, eye + fwd, yfov)
    a, p, _ = profile(img[:, w // 2:], d, sun, int(h * 0.62))
    print("halo (from the sun): 22° inner edge",
          " / ".join(f"{edge(a, p, c, 19, 25):.2f}°" for c in range(3)), "; 46° inner edge",
          " / ".join(f"{edge(a, p, c, 43, 50):.2f}°" for c in range(3)), "(R / G / B)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
