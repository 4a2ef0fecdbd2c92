"""Point set registration by independent libraries, for tandem's CPD and
ICP (tests/perception_registration.rs).

Reads one JSON object on stdin and prints one:

- {"method": "cpd", "fixed": [[x, y, z], ...], "moving": [...],
  "rotation": 3x3 (column convention, T(y) = s R y + t), "translation": [3],
  "scale": s, "w": w, "max_iterations": K, "tolerance": tol,
  "sigma2": initial σ² (optional; pycpd's own start is from the unmoved Y)}
  → pycpd's RigidRegistration (it always estimates the scale):
  {"rotation", "translation", "scale", "variance", "iterations", "seconds",
  "pycpd_version"} in the same column convention.
- {"method": "icp", "model": [[x, y, z], ...], "points": [...],
  "pose": 4x4 (object in world), "max_correspondence_distance": d,
  "max_iterations": K, "neighbors": k}
  → small_gicp's point-to-plane ICP: the model's normals estimated by
  small_gicp from k neighbours ("normals", returned so that tandem pairs
  the same planes), then its alignment of the measured points to the model
  from the initial pose: {"pose": 4x4 (object in world), "normals",
  "converged", "iterations", "seconds", "small_gicp_version"}.
"""
import importlib.metadata
import json
import sys
import time

import numpy as np

request = json.load(sys.stdin)
if request["method"] == "cpd":
    from pycpd import RigidRegistration

    r0 = np.asarray(request["rotation"], dtype=float)
    reg = RigidRegistration(
        X=np.asarray(request["fixed"], dtype=float),
        Y=np.asarray(request["moving"], dtype=float),
        # pycpd maps a row y to s·y·R + t: its R is the transpose.
        R=r0.T.copy(),
        t=np.asarray(request["translation"], dtype=float).reshape(1, 3),
        s=float(request["scale"]),
        w=float(request["w"]),
        max_iterations=int(request["max_iterations"]),
        tolerance=float(request["tolerance"]),
        sigma2=request.get("sigma2"),
    )
    start = time.perf_counter()
    reg.register()
    seconds = time.perf_counter() - start
    s, r, t = reg.get_registration_parameters()
    json.dump(
        {
            "rotation": r.T.tolist(),
            "translation": np.asarray(t).reshape(3).tolist(),
            "scale": float(s),
            "variance": float(reg.sigma2),
            "iterations": int(reg.iteration),
            "seconds": seconds,
            "pycpd_version": importlib.metadata.version("pycpd"),
        },
        sys.stdout,
    )
elif request["method"] == "icp":
    import small_gicp

    model = small_gicp.PointCloud(np.asarray(request["model"], dtype=float))
    tree = small_gicp.KdTree(model)
    small_gicp.estimate_normals(model, tree, num_neighbors=int(request["neighbors"]))
    normals = model.normals()[:, :3]
    points = small_gicp.PointCloud(np.asarray(request["points"], dtype=float))
    pose = np.asarray(request["pose"], dtype=float)
    start = time.perf_counter()
    # small_gicp aligns the source (measured, world) to the target (model,
    # object frame): T_target_source is the inverse of the object's pose.
    result = small_gicp.align(
        model,
        points,
        tree,
        init_T_target_source=np.linalg.inv(pose),
        registration_type="PLANE_ICP",
        max_correspondence_distance=float(request["max_correspondence_distance"]),
        num_threads=1,
        max_iterations=int(request["max_iterations"]),
        rotation_epsilon=1e-12,
        translation_epsilon=1e-12,
    )
    seconds = time.perf_counter() - start
    json.dump(
        {
            "pose": np.linalg.inv(result.T_target_source).tolist(),
            "normals": normals.tolist(),
            "converged": bool(result.converged),
            "iterations": int(result.iterations),
            "seconds": seconds,
            "small_gicp_version": importlib.metadata.version("small_gicp"),
        },
        sys.stdout,
    )
else:
    sys.exit(f"unknown method {request['method']!r}")
