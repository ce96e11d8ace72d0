"""The cathedral's stained glass as a light map (graphs/color/cathedral_stained_glass.ron):

    python3 scripts/scenes/stained_glass.py scenes/stained_glass.png

A 512 × 512 sRGB PNG in light space (LightMap places it over the shadow map's extent): Voronoi
cells of ruby, cobalt, amber, emerald and violet glass from a fixed seed, about 12 texels
across, so each window's shaft carries a few panes, separated by dark lead lines 2 texels wide.
Pure Python (zlib for the PNG), so the file is the same byte for byte on any machine."""

import random
import struct
import sys
import zlib

N = 512
CELLS = 1800
rng = random.Random(1227)
GLASS = [(0.80, 0.05, 0.08), (0.08, 0.18, 0.85), (0.95, 0.62, 0.08), (0.06, 0.62, 0.22),
         (0.50, 0.10, 0.75), (0.95, 0.85, 0.55)]
sites = [(rng.uniform(0, N), rng.uniform(0, N), rng.choice(GLASS)) for _ in range(CELLS)]

# A grid of buckets so each texel looks at nearby sites only.
B = 16
buckets = {}
for i, (x, y, _) in enumerate(sites):
    buckets.setdefault((int(x) // B, int(y) // B), []).append(i)


def nearest_two(px, py):
    best = [(1e18, -1), (1e18, -1)]
    bx, by = int(px) // B, int(py) // B
    for dx in (-2, -1, 0, 1, 2):
        for dy in (-2, -1, 0, 1, 2):
            for i in buckets.get((bx + dx, by + dy), ()):
                x, y, _ = sites[i]
                d = (x - px) ** 2 + (y - py) ** 2
                if d < best[0][0]:
                    best = [(d, i), best[0]]
                elif d < best[1][0]:
                    best[1] = (d, i)
    return best


def srgb(c):
    c = max(0.0, min(1.0, c))
    v = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return int(round(v * 255))


rows = []
for y in range(N):
    row = bytearray([0])  # PNG filter: none
    for x in range(N):
        (d0, i0), (d1, _) = nearest_two(x + 0.5, y + 0.5)
        # Distance to the bisector of the two nearest sites, approximately: the lead line.
        edge = (d1 ** 0.5 - d0 ** 0.5) / 2
        colour = sites[i0][2] if edge > 1.0 else (0.02, 0.02, 0.02)
        row += bytes(srgb(c) for c in colour)
    rows.append(bytes(row))

raw = zlib.compress(b"".join(rows), 9)


def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", N, N, 8, 2, 0, 0, 0))
png += chunk(b"IDAT", raw) + chunk(b"IEND", b"")
out = sys.argv[1] if len(sys.argv) > 1 else "stained_glass.png"
with open(out, "wb") as f:
    f.write(png)
