#!/usr/bin/python3
"""The forest plume in a large box, for the empty-space skipping measurement in BENCHMARKS.md
(issue #61, item 3): the plume's `density` grid (scenes/smoke/forest_plume_0090.vdb) with one
more active voxel, of density 0, 180 voxels beyond its far corner. The active box — what
VdbVolume densifies and SingleScattering marches — grows from 36 × 29 × 30 voxels to
181 × 181 × 181 (39.6 m on a side); the smoke stays in one corner, ~0.5 % of it.

    /usr/bin/python3 scripts/make_sparse_plume.py /tmp/sparse_plume.vdb
"""
import os
import sys

import pyopenvdb as vdb

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
out = sys.argv[1] if len(sys.argv) > 1 else "/tmp/sparse_plume.vdb"
grids, _ = vdb.readAll(os.path.join(ROOT, "scenes", "smoke", "forest_plume_0090.vdb"))
density = next(g for g in grids if g.name == "density")
lo, hi = density.evalActiveVoxelBoundingBox()
density.getAccessor().setValueOn(tuple(v + 180 for v in lo), 0.0)
print(f"{out}: active box {density.evalActiveVoxelBoundingBox()} (was {(lo, hi)})")
vdb.write(out, grids=[density])
