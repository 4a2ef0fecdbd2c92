"""Point cloud files written by independent libraries, for tandem's reader
(tests/point_cloud_files.rs): PLY by `plyfile` (ASCII, binary little- and
big-endian), PCD by `pypcd4` (ascii, binary, binary_compressed through
python-neo-lzf, i.e. liblzf's own compressor).

Reads one JSON object on stdin: {"dir": PATH, "points": N, "seed": S}.
Writes, in DIR, a cloud of N seeded random points (float32 x, y, z in
[-2, 2] m; every 17th point NaN, as a depth camera's missing pixel; an
extra uint8 or float field beside them) in each format, and prints one
JSON object: {"files": {name: path}, "points": [[x, y, z], ...] (the
float32 values written, as float64, NaN as null)}.

With {"points": [[x, y, z], ...], "queries": [[x, y, z], ...]} instead, it
answers nearest-point queries with SciPy's cKDTree (exact Euclidean
nearest neighbours): {"distances": [...], "indices": [...],
"scipy_version": str}, for tests/point_cloud_collision.rs.
"""
import json
import os
import sys

import numpy as np
import plyfile
import pypcd4

request = json.load(sys.stdin)
if "queries" in request:
    import scipy
    from scipy.spatial import cKDTree

    tree = cKDTree(np.asarray(request["points"], dtype=float))
    distances, indices = tree.query(np.asarray(request["queries"], dtype=float), k=1)
    json.dump(
        {"distances": distances.tolist(), "indices": indices.tolist(), "scipy_version": scipy.__version__},
        sys.stdout,
    )
    sys.exit(0)
rng = np.random.default_rng(request["seed"])
n = request["points"]
xyz = rng.uniform(-2.0, 2.0, size=(n, 3)).astype(np.float32)
xyz[::17] = np.nan
label = rng.integers(0, 255, size=n).astype(np.uint8)
intensity = rng.uniform(0.0, 1.0, size=n).astype(np.float32)
out = request["dir"]
files = {}

vertex = np.empty(n, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("label", "u1")])
vertex["x"], vertex["y"], vertex["z"], vertex["label"] = xyz[:, 0], xyz[:, 1], xyz[:, 2], label
faces = np.empty(2, dtype=[("vertex_indices", "i4", (3,))])
faces["vertex_indices"] = [[0, 1, 2], [1, 2, 3]]
for name, text, order in (("ascii.ply", True, "="), ("little.ply", False, "<"), ("big.ply", False, ">")):
    data = plyfile.PlyData(
        [plyfile.PlyElement.describe(vertex, "vertex"), plyfile.PlyElement.describe(faces, "face")],
        text=text,
        byte_order=order,
        comments=["written by plyfile for tandem's tests"],
    )
    files[name] = os.path.join(out, name)
    data.write(files[name])

cloud = pypcd4.PointCloud.from_points(
    [xyz[:, 0], xyz[:, 1], xyz[:, 2], intensity], ("x", "y", "z", "intensity"), (np.float32,) * 4
)
for name, encoding in (
    ("ascii.pcd", pypcd4.Encoding.ASCII),
    ("binary.pcd", pypcd4.Encoding.BINARY),
    ("compressed.pcd", pypcd4.Encoding.BINARY_COMPRESSED),
):
    files[name] = os.path.join(out, name)
    cloud.save(files[name], encoding=encoding)

points = [[None if np.isnan(v) else float(v) for v in p] for p in xyz]
print(json.dumps({"files": files, "points": points}))
