"""Writes pillar.ply: what a depth camera all around would see of a
10 x 10 x 60 cm pillar standing on the table at (0.6, 0.12), beside the
way from the Panda's ready pose to panda_reach's goal — points on a 1 cm grid over its five visible
faces (the bottom stands on the table), with 1 mm Gaussian noise (seed 0),
as binary little-endian float32 PLY written by plyfile.

  python_ref/.venv/bin/python problems/clouds/make_pillar.py
"""
import os

import numpy as np
import plyfile

rng = np.random.default_rng(0)
centre = np.array([0.6, 0.12, 0.3])
half = np.array([0.05, 0.05, 0.3])
step = 0.01
points = []
for axis in range(3):
    u, v = (axis + 1) % 3, (axis + 2) % 3
    nu, nv = int(round(2 * half[u] / step)), int(round(2 * half[v] / step))
    for sign in (-1.0, 1.0):
        if axis == 2 and sign < 0:
            continue  # the face on the table is not seen
        for i in range(nu):
            for j in range(nv):
                p = np.zeros(3)
                p[axis] = sign * half[axis]
                p[u] = -half[u] + (i + 0.5) * step
                p[v] = -half[v] + (j + 0.5) * step
                points.append(centre + p)
xyz = np.array(points) + rng.normal(0.0, 0.001, size=(len(points), 3))
vertex = np.array([tuple(p) for p in xyz.astype(np.float32)], dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pillar.ply")
plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex")], byte_order="<").write(out)
print(f"{out}: {len(vertex)} points")
