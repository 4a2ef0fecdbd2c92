"""Times pycpd's rigid CPD and small_gicp's point-to-plane ICP on the
registration problems benches/perception.rs writes (--cases FILE), for
benches/peers/compare_registration.sh.

    registration_peers.py CASES.json RUNS  → JSON on stdout:
    {"pycpd_version", "small_gicp_version", "cases": [{"object", "cpd_ms", "icp_ms"}]}

Each figure is the median of RUNS runs of the registration call alone
(small_gicp's normals and k-d tree are built before the clock starts, as
tandem's surface model is built before its).
"""
import importlib.metadata
import json
import statistics
import sys
import time

import numpy as np
import small_gicp
from pycpd import RigidRegistration

cases = json.load(open(sys.argv[1]))
runs = int(sys.argv[2])
out = []
for case in cases:
    c = case["cpd"]
    times = []
    # pycpd takes only a positive semi-definite start rotation: the model
    # is moved to the start instead (CPD's steps do not depend on where the
    # model's frame is), the same problem.
    r0 = np.asarray(c["rotation"], dtype=float)
    moved = np.asarray(c["moving"], dtype=float) @ r0.T + np.asarray(c["translation"], dtype=float)
    for _ in range(runs):
        reg = RigidRegistration(
            X=np.asarray(c["fixed"], dtype=float),
            Y=moved,
            s=1.0,
            w=c["w"],
            max_iterations=c["max_iterations"],
            tolerance=c["tolerance"],
        )
        start = time.perf_counter()
        reg.register()
        times.append((time.perf_counter() - start) * 1e3)
    cpd_ms = statistics.median(times)
    i = case["icp"]
    model = small_gicp.PointCloud(np.asarray(i["model"], dtype=float))
    tree = small_gicp.KdTree(model)
    small_gicp.estimate_normals(model, tree, num_neighbors=i["neighbors"])
    points = small_gicp.PointCloud(np.asarray(i["points"], dtype=float))
    init = np.linalg.inv(np.asarray(i["pose"], dtype=float))
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        small_gicp.align(model, points, tree, init_T_target_source=init, registration_type="PLANE_ICP",
                         max_correspondence_distance=i["max_correspondence_distance"], num_threads=1,
                         max_iterations=i["max_iterations"], rotation_epsilon=i["tolerance"],
                         translation_epsilon=i["tolerance"])
        times.append((time.perf_counter() - start) * 1e3)
    out.append({"object": case["object"], "cpd_ms": cpd_ms, "icp_ms": statistics.median(times),
                "tandem_cpd_ms": c["tandem_ms"], "tandem_icp_ms": i["tandem_ms"]})
json.dump({"pycpd_version": importlib.metadata.version("pycpd"),
           "small_gicp_version": importlib.metadata.version("small_gicp"), "cases": out}, sys.stdout)
