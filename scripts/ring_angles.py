#!/usr/bin/env python3
"""Angles of the rings in the atmospheric-optics pictures (issue #46, item 3), measured on the
rendered PNGs from the presets' cameras:

    python3 scripts/ring_angles.py            # reads docs/atmosphere/{rainbow,glory,halo}.png

Each pixel's view direction comes from its camera (position, target, vertical field of view:
the values in scenes/*.glb and graphs/atmosphere/halo.ron), and its angle from the centre of
the phenomenon (the antisolar point for bows and glories, the sun for halos and coronas); the
pixels of the sky and medium (rows above the ground, or above the ridge's shadow for the glory) are averaged in 0.05° rings per channel, and
each feature is read off that profile: a bow's or glory ring's brightest ring, a halo's inner
edge (steepest rise), a corona's first dark ring. Needs numpy and Pillow."""

import math
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


def towards(elevation, azimuth_from_minus_z):
    """The unit vector `elevation`° up, turned `azimuth`° from −z (the scenes' forward)."""
    e, a = math.radians(elevation), math.radians(azimuth_from_minus_z)
    return np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])


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
    rgb = ("R", "G", "B")
    # Rainbow (the left, physical half): scenes/rainbow.glb's camera (Blender (0, −20, 2) → (0, 100, 27), 100° wide at
    # 16:9: yfov 67.67°), antisolar point 9° below the horizon ahead.
    img = load("docs/atmosphere/rainbow.png")
    h, w = img.shape[:2]
    left = img[:, : w // 2]  # the physical half
    d = directions(w // 2, h, (0, 2, 20), (0, 27, -100), 67.67)
    a, p, _ = profile(left, d, towards(-9, 0), int(h * 0.62))
    print("rainbow (from the antisolar point): primary",
          " / ".join(f"{brightest(a, p, c, 38, 45):.2f}°" for c in range(3)), "; secondary",
          " / ".join(f"{brightest(a, p, c, 48, 56):.2f}°" for c in range(3)), "(R / G / B)")
    # Glory: the right half; scenes/glory.glb's camera looks at the antisolar point (20° down),
    # 60° wide at 16:9 (yfov 36.0°).
    img = load("docs/atmosphere/glory.png")
    h, w = img.shape[:2]
    half = img[:, w // 2:]
    d = directions(w // 2, h, (0, 0, 0), (0, -math.tan(math.radians(20)), -1), 35.98)
    a, p, _ = profile(half, d, towards(-20, 0), h // 2 - 2)
    print("glory (from the antisolar point): first bright ring",
          " / ".join(f"{brightest(a, p, c, 1.0, 6.0):.2f}°" for c in range(3)), "(R / G / B)")
    # Halo: left, the corona (custom camera on the sun, yfov 12°); right, scenes/halo.glb's
    # camera ((0, −20, 2) → (0, 100, 30), yfov 67.67°), the sun 14° up ahead.
    img = load("docs/atmosphere/halo.png")
    h, w = img.shape[:2]
    left, right = img[:, : w // 2], img[:, w // 2:]
    d = directions(w // 2, h, (0, 2, 20), (0, 26.93, -80), 12.0)
    a, p, _ = profile(left, d, towards(14, 0), h, step=0.05, upto=8)
    print("corona (from the sun): first dark ring",
          " / ".join(f"{first_min(a, p, c, 1.0, 6.0):.2f}°" for c in range(3)), "(R / G / B)")
    d = directions(w // 2, h, (0, 2, 20), (0, 30, -100), 67.67)
    a, p, _ = profile(right, d, towards(14, 0), int(h * 0.62))
    print("halo (from the sun): 22° inner edge",
          " / ".join(f"{edge(a, p, c, 19, 25):.2f}°" for c in range(3)), "; 46° inner edge",
          " / ".join(f"{edge(a, p, c, 43, 50):.2f}°" for c in range(3)), "(R / G / B)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
