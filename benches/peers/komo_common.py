"""Shared pieces of the trajectory-optimization peers (rai_komo.py, casadi_komo.py).

Both read the problem that `examples/komo_seeds.rs --export FILE` writes for
one problem file at one horizon T: the optimizer's collision model in the
collision scene exchange format (the robot's URDF collision spheres by link
and element index, obstacles by shape and world pose, every checked pair; no
padding), the start, joint names and limits, T, the order k, the duration,
every objective resolved by tandem (feature, frames, axes, kind, scale,
target, order, slices first..=last, margin) and the initialisations
(q_1..q_T, the resampled RRT-Connect paths) with tandem's measures of them.

Both print one JSON object {"solver", "problem", "horizon", "runs": [{"init",
"times_ms", "median_ms", "converged", "status", "trajectory", "own"}]}, which
`komo_seeds --measure` completes with tandem's measures of every trajectory.
"""

import json

from planning_common import emit, median, read_urdf, rpy_quaternion  # noqa: F401 (re-exported)

AXES = "xyz"


def load_problem(path):
    with open(path) as f:
        problem = json.load(f)
    for key in ("exchange", "start", "joints", "joint_limits", "horizon", "order", "duration", "objectives", "inits"):
        if key not in problem:
            raise SystemExit(f"{path}: missing key {key!r} (write it with examples/komo_seeds.rs --export)")
    if problem["order"] != 2:
        raise SystemExit(f"{path}: only order-2 problems are mapped (k = {problem['order']})")
    return problem


def collision_margin(problem):
    """The margin of the (single) collision objective, or None."""
    margins = {o["margin"] for o in problem["objectives"] if o["feature"] == "collision"}
    if len(margins) > 1:
        raise SystemExit(f"collision objectives with different margins {sorted(margins)} are not mapped")
    return margins.pop() if margins else None


def frame_label(frame):
    """A robot frame's name, or a fixed frame's name as tandem's problem file gives it."""
    return frame["robot"] if "robot" in frame else frame["fixed"]


def is_world(frame):
    """A fixed frame at the identity pose."""
    if "fixed" not in frame:
        return False
    identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    return (all(abs(v) < 1e-12 for v in frame["translation"])
            and all(abs(frame["rotation"][i][j] - identity[i][j]) < 1e-12 for i in range(3) for j in range(3)))


def result(problem, solver, runs, extra):
    """The JSON object a peer prints; runs: dicts with init, times_ms, converged, status, trajectory, own."""
    all_ms = [t for r in runs for t in r["times_ms"]]
    all_cpu = [t for r in runs for t in r.get("cpu_ms", [])]
    for r in runs:
        r["median_ms"] = median(r["times_ms"])
        if r.get("cpu_ms"):
            r["median_cpu_ms"] = median(r["cpu_ms"])
    out = {
        "solver": solver,
        "problem": problem["problem"],
        "horizon": problem["horizon"],
        "duration": problem["duration"],
        "inits": len({r["init"] for r in runs}),
        "reps": max((len(r["times_ms"]) for r in runs), default=0),
        "median_ms": median(all_ms),
        "median_cpu_ms": median(all_cpu) if all_cpu else None,
        "runs": runs,
    }
    out.update(extra)
    return out


def version_of(package):
    try:
        from importlib.metadata import version

        return version(package)
    except Exception:  # noqa: BLE001 - metadata is best effort
        return None
