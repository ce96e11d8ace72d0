#!/usr/bin/python3
"""A 256³ float grid `density` saved as half floats with Blosc (python3-openvdb's defaults), for
the loading measurement of examples/vdb_load.rs:

    /usr/bin/python3 scripts/make_vdb_256.py /tmp/big256.vdb
"""
import sys

import numpy as np
import pyopenvdb as vdb

n = 256
x = np.linspace(0.0, 1.0, n, dtype=np.float32)
X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
a = (0.5 + 0.5 * np.sin(13 * X) * np.cos(7 * Y) * np.sin(5 * Z + 1)).astype(np.float32)
g = vdb.FloatGrid()
g.name = "density"
g.copyFromArray(a, tolerance=0.0)
g.saveFloatAsHalf = True
g.transform = vdb.createLinearTransform(voxelSize=0.05)
vdb.write(sys.argv[1] if len(sys.argv) > 1 else "big256.vdb", grids=[g])
print(g.activeVoxelCount(), "active voxels")
