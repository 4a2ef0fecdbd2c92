"""OctoMap's own octree (PyPI `octomap-python`, the C++ library's
bindings) for tests/moveit_import.rs: a seeded scan inserted by ray casting
(free cells along the rays, occupied at the hits), a solid 40 cm block of
occupied cells (which the library prunes into large leaves) and the
binary stream `writeBinary` writes (what octomap_msgs' `data` carries:
the bytes after the .bt file's `data` line).

Reads {"seed": S, "resolution": R} on stdin; prints {"data": [bytes],
"occupied": [[x, y, z], ...]}: the centres of every occupied cell of the
resolution, pruned leaves expanded into their cells (sorted)."""
import json
import os
import sys
import tempfile

import numpy as np
import octomap

request = json.load(sys.stdin)
rng = np.random.default_rng(request["seed"])
res = float(request["resolution"])
tree = octomap.OcTree(res)
# A camera at (0, 0, 1) seeing a table top and a wall.
hits = np.vstack([
    np.column_stack([rng.uniform(0.3, 0.9, 3000), rng.uniform(-0.4, 0.4, 3000), np.full(3000, 0.4)]),
    np.column_stack([np.full(2000, 1.2), rng.uniform(-0.6, 0.6, 2000), rng.uniform(0.0, 1.0, 2000)]),
])
tree.insertPointCloud(hits, np.array([0.0, 0.0, 1.0]))
# A solid block: every cell occupied, pruned into larger leaves.
n = int(round(0.4 / res))
for i in range(n):
    for j in range(n):
        for k in range(n):
            tree.updateNode(np.array([-0.8 + (i + 0.5) * res, 0.2 + (j + 0.5) * res, (k + 0.5) * res]), True)
tree.updateInnerOccupancy()
# writeBinary makes the tree maximum-likelihood and prunes it first: the
# cells are read from the tree it wrote.
with tempfile.TemporaryDirectory() as folder:
    path = os.path.join(folder, "tree.bt")
    tree.writeBinary(path.encode())
    raw = open(path, "rb").read()
data = raw[raw.index(b"\ndata\n") + len(b"\ndata\n"):]

occupied = []
sizes = set()
for leaf in tree.begin_leafs():
    if not tree.isNodeOccupied(leaf):
        continue
    size = leaf.getSize()
    centre = np.array(leaf.getCoordinate())
    cells = int(round(size / res))
    sizes.add(cells)
    for a in range(cells):
        for b in range(cells):
            for c in range(cells):
                occupied.append((centre - size / 2 + (np.array([a, b, c]) + 0.5) * res).tolist())
print(json.dumps({"data": list(data), "occupied": sorted(occupied), "leaf_sizes": sorted(sizes)}))
