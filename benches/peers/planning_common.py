"""Shared pieces of the planning peers (rai_plan.py, ompl_plan.py).

Both read the peer scene that `examples/plan_seeds.rs --scene FILE` writes
for one problem: the search's collision model in the "collision scene
exchange" format (the robot's URDF collision spheres by link and element
index, obstacles by shape and world pose, every checked pair), the padding
the search adds to the robot spheres, the start, the joint goals tandem aims
at, the joint limits, tandem's planner settings, and random configurations
with tandem's collision verdicts. Both print one JSON object with the keys
of plan_seeds (median_ms, mean_ms, p95_ms, ...).
"""

import json
import math
import os
import xml.etree.ElementTree as ET


def load_scene(path):
    with open(path) as f:
        scene = json.load(f)
    for key in ("exchange", "start", "goals", "joint_limits", "planner", "padding", "free"):
        if key not in scene:
            raise SystemExit(f"{path}: missing key {key!r} (write it with examples/plan_seeds.rs --scene)")
    return scene


def rpy_quaternion(roll, pitch, yaw):
    """URDF fixed-axis roll-pitch-yaw as a quaternion (w, x, y, z)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]


def _origin(element):
    o = element.find("origin")
    xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
    rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
    return xyz, rpy


def read_urdf(path):
    """The kinematic tree and the collision spheres of a URDF.

    Returns (root link, joints in parent-before-child order, spheres): each
    joint a dict {name, type, parent, child, xyz, rpy, axis, limits}; spheres
    maps a link name to its <collision> elements, in file order, as
    (xyz, radius) or None for a non-sphere element.
    """
    root = ET.parse(path).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    raw = root.findall("joint")
    children = {j.find("child").get("link") for j in raw}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise SystemExit(f"{path}: expected one root link, found {roots}")
    joints, placed, pending = [], {roots[0]}, list(raw)
    while pending:
        ready = [j for j in pending if j.find("parent").get("link") in placed]
        if not ready:
            raise SystemExit(f"{path}: joints not connected to the root: {[j.get('name') for j in pending]}")
        for j in ready:
            pending.remove(j)
            xyz, rpy = _origin(j)
            axis = j.find("axis")
            limit = j.find("limit")
            joints.append({
                "name": j.get("name"),
                "type": j.get("type"),
                "parent": j.find("parent").get("link"),
                "child": j.find("child").get("link"),
                "xyz": xyz,
                "rpy": rpy,
                "axis": [float(v) for v in (axis.get("xyz") if axis is not None else "1 0 0").split()],
                "limits": None if limit is None else (float(limit.get("lower", 0)), float(limit.get("upper", 0))),
            })
            placed.add(j.find("child").get("link"))
    spheres = {}
    for name, link in links.items():
        elements = []
        for c in link.findall("collision"):
            s = c.find("geometry/sphere")
            elements.append(None if s is None else (_origin(c)[0], float(s.get("radius"))))
        spheres[name] = elements
    return roots[0], joints, spheres


def element_names(scene):
    """Names of the exchange's collision objects: robot elements `link_index`, then obstacles."""
    e = scene["exchange"]
    return [f"{r['link']}_{r['index']}" for r in e["robot_elements"]] + [o["name"] for o in e["obstacles"]]


def median(values):
    v = sorted(values)
    if not v:
        return None
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def percentile(values, p):
    """Nearest-rank percentile, as plan_seeds."""
    v = sorted(values)
    if not v:
        return None
    rank = math.ceil(p * len(v))
    return v[min(max(rank, 1), len(v)) - 1]


def summary(scene, planner, total_ms, planning_ms, simplify_ms, solved, simplified, cpu_ms, extra):
    """The JSON object every planning runner prints (the keys of plan_seeds);
    cpu_ms: process CPU time of each run."""
    out = {
        "problem": scene.get("problem"),
        "planner": planner,
        "seeds": len(total_ms),
        "solved": solved,
        "median_ms": median(total_ms),
        "mean_ms": sum(total_ms) / len(total_ms) if total_ms else None,
        "p95_ms": percentile(total_ms, 0.95),
        "median_planning_ms": median(planning_ms),
        "median_simplify_ms": median(simplify_ms) if simplified else None,
        "median_cpu_ms": median(cpu_ms),
        "simplified": simplified,
    }
    out.update(extra)
    return out


def emit(obj):
    """Print the result and leave at once (the nanobind/pybind extension
    modules print reference-leak noise at interpreter shutdown)."""
    print(json.dumps(obj), flush=True)
    os._exit(0)


class CaptureStdout:
    """Redirects the process's file descriptor 1 (C++ std::cout) to a
    temporary file while active; `text` holds what was written."""

    def __enter__(self):
        import sys
        import tempfile

        sys.stdout.flush()
        self._tmp = tempfile.TemporaryFile()
        self._saved = os.dup(1)
        os.dup2(self._tmp.fileno(), 1)
        return self

    def __exit__(self, *exc):
        import ctypes

        ctypes.CDLL(None).fflush(None)  # C stdio buffers, which std::cout syncs with
        os.dup2(self._saved, 1)
        os.close(self._saved)
        self._tmp.seek(0)
        self.text = self._tmp.read().decode(errors="replace")
        self._tmp.close()
        return False
