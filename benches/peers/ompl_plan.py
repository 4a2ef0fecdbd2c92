"""OMPL's RRTConnect (PyPI `ompl`) on a tandem problem, for many seeds.

    python ompl_plan.py SCENE.json [--seeds 50] [--first 0] [--edge max|native] [--simplify max|none]

SCENE.json comes from `examples/plan_seeds.rs --scene`. The state validity
checker is coal through Pinocchio (PyPI `pin`): the problem's URDF with its
collision spheres padded like tandem's search, the obstacles as coal boxes,
exactly tandem's list of checked pairs, and
`pinocchio.computeCollisions` over a BroadPhaseManager (coal's dynamic AABB
tree, which keeps to the model's collision pairs), stopping at the first
collision. `agreement` says how many of the scene's random configurations it
judges as tandem does.

Space: RealVectorStateSpace over the joint limits; planner: RRTConnect with
range = tandem's step; goal: all of tandem's goal configurations
(GoalStates). Edges (`--edge`):
  max     a MotionValidator that checks like tandem: configurations at most
          `resolution` apart in every joint, the end first, then bisection
          order (default);
  native  OMPL's DiscreteMotionValidator with longest valid segment =
          resolution in OMPL's (Euclidean) distance.
Time budget: tandem's time_limit. OMPL's RNG is seeded once with --first:
run i then uses the i-th planner of that seeded stream (OMPL seeds each
sampler from one generator), so a whole run is reproducible.

Timing: `median_planning_ms` is RRTConnect's solve. `--simplify shortcut`
(default) then shortens the path with PathSimplifier.reduceVertices until it
finds nothing more (OMPL's vertex shortcutting, the first stage of its
simplify(); the closest match to tandem's greedy + random shortcuts), and
`median_ms` is solve + shortcutting, like tandem's solve + shortcutting +
certification. `--simplify max` uses PathSimplifier.simplifyMax instead
(SimpleSetup.simplifySolution()'s default: vertex reduction, shortcuts,
B-spline smoothing and repair until nothing improves); `--also-max` times
simplifyMax on a copy of each raw path as well (`median_simplify_max_ms`).

Prints one JSON object (keys of plan_seeds) on stdout.
"""

import argparse
import math
import sys
import time

import coal
import numpy as np
import pinocchio as pin
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from planning_common import emit, load_scene, median, summary


class Checker:
    """tandem's search geometry in coal: `free(q)` for the active joints q."""

    def __init__(self, scene):
        e = scene["exchange"]
        pad = scene["padding"]
        self.model = pin.buildModelFromUrdf(e["urdf"])
        gm = pin.buildGeomFromUrdf(self.model, e["urdf"], pin.COLLISION)
        ids = []
        for r in e["robot_elements"]:
            name = f"{r['link']}_{r['index']}"
            gid = gm.getGeometryId(name)
            if gid >= len(gm.geometryObjects):
                raise SystemExit(f"no collision geometry {name} in {e['urdf']}")
            g = gm.geometryObjects[gid]
            if not isinstance(g.geometry, coal.Sphere):
                raise SystemExit(f"{name}: only spheres are mapped")
            g.geometry = coal.Sphere(g.geometry.radius + pad)
            ids.append(gid)
        for o in e["obstacles"]:
            if o["shape"] != "box":
                raise SystemExit(f"obstacle {o['name']}: only boxes are mapped, got {o['shape']}")
            placement = pin.SE3(np.array(o["rotation"], dtype=float), np.array(o["translation"], dtype=float))
            box = coal.Box(*[2.0 * h for h in o["half_extents"]])
            ids.append(gm.addGeometryObject(pin.GeometryObject(o["name"], 0, 0, placement, box)))
        gm.removeAllCollisionPairs()
        for a, b in e["pairs"]:
            gm.addCollisionPair(pin.CollisionPair(ids[a], ids[b]))
        self.geometry = gm
        self.data = self.model.createData()
        self.geometry_data = pin.GeometryData(gm)
        self.broad_phase = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager(
            self.model, gm, self.geometry_data)
        self.q = pin.neutral(self.model)
        for name, value in e.get("held", {}).items():
            self.q[self.model.joints[self.model.getJointId(name)].idx_q] = value
        self.active = [self.model.joints[self.model.getJointId(n)].idx_q for n in e["joints"]]
        self.calls = 0

    def free(self, q):
        self.calls += 1
        self.q[self.active] = q
        return not pin.computeCollisions(self.model, self.data, self.broad_phase, self.q, True)


class MaxNormMotionValidator(ob.MotionValidator):
    """Edges checked as tandem checks them (plan::EdgeCheck::Resolution):
    configurations at most `resolution` apart in every joint; the end first
    (the start is a tree node, already valid), then bisection order."""

    def __init__(self, si, checker, dim, resolution):
        super().__init__(si)
        self.checker, self.dim, self.resolution = checker, dim, resolution

    def checkMotion(self, s1, s2):  # noqa: N802 - OMPL's name
        a = np.fromiter((s1[i] for i in range(self.dim)), float, self.dim)
        b = np.fromiter((s2[i] for i in range(self.dim)), float, self.dim)
        d = b - a
        steps = max(1, math.ceil(float(np.max(np.abs(d))) / self.resolution))
        if not self.checker.free(b):
            return False
        stride = 1 << (steps - 1).bit_length()
        while stride > 1:
            half = stride // 2
            for k in range(half, steps, stride):
                if not self.checker.free(a + d * (k / steps)):
                    return False
            stride = half
        return True


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--edge", choices=["max", "native"], default="max")
    ap.add_argument("--simplify", choices=["shortcut", "max", "none"], default="shortcut")
    ap.add_argument("--also-max", action="store_true", help="also time simplifyMax on a copy of each raw path")
    args = ap.parse_args()
    scene = load_scene(args.scene)
    planner = scene["planner"]
    ou.setLogLevel(ou.LOG_WARN)
    ou.RNG.setSeed(args.first + 1)  # OMPL refuses seed 0

    checker = Checker(scene)
    configs = scene["exchange"]["configurations"]
    arrays = [np.asarray(q, dtype=float) for q in configs]
    began = time.perf_counter()
    verdicts = [checker.free(q) for q in arrays]
    check_us = (time.perf_counter() - began) / max(len(arrays), 1) * 1e6
    agreement = sum(a == b for a, b in zip(verdicts, scene["free"]))

    limits = scene["joint_limits"]
    dim = len(limits)
    space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for i, (lo, hi) in enumerate(limits):
        bounds.setLow(i, lo)
        bounds.setHigh(i, hi)
    space.setBounds(bounds)

    def state(values):
        s = space.allocState()
        for i, v in enumerate(values):
            s[i] = float(v)
        return s

    def valid(s):
        return checker.free(np.fromiter((s[i] for i in range(dim)), float, dim))

    total, cpu, planning, simplify, simplify_max, calls, waypoints, solved = [], [], [], [], [], [], [], 0
    start = state(scene["start"])
    for _ in range(args.seeds):
        si = ob.SpaceInformation(space)
        si.setStateValidityChecker(valid)
        if args.edge == "max":
            validator = MaxNormMotionValidator(si, checker, dim, planner["resolution"])
            si.setMotionValidator(validator)
        else:
            si.setStateValidityCheckingResolution(planner["resolution"] / si.getMaximumExtent())
        si.setup()
        goal = ob.GoalStates(si)
        for g in scene["goals"]:
            goal.addState(state(g))
        pdef = ob.ProblemDefinition(si)
        pdef.addStartState(start)
        pdef.setGoal(goal)
        rrt = og.RRTConnect(si)
        rrt.setRange(planner["step"])
        rrt.setProblemDefinition(pdef)
        rrt.setup()
        checker.calls = 0
        began, cpu_began = time.perf_counter(), time.process_time()
        status = rrt.solve(planner["time_limit"])
        planned = time.perf_counter()
        calls.append(checker.calls)
        ok = pdef.hasExactSolution()
        if ok:
            raw = pdef.getSolutionPath()
            path = og.PathGeometric(raw) if args.also_max else raw
            simplifier = og.PathSimplifier(si)
            if args.simplify == "shortcut":
                for _ in range(1000):
                    if not simplifier.reduceVertices(path):
                        break
            elif args.simplify == "max":
                simplifier.simplifyMax(path)
        done, cpu_done = time.perf_counter(), time.process_time()
        cpu.append((cpu_done - cpu_began) * 1e3)
        if ok and args.also_max:
            copy = og.PathGeometric(raw)
            t = time.perf_counter()
            og.PathSimplifier(si).simplifyMax(copy)
            simplify_max.append((time.perf_counter() - t) * 1e3)
        planning.append((planned - began) * 1e3)
        simplify.append((done - planned) * 1e3)
        total.append((done - began) * 1e3)
        if ok:
            solved += 1
            waypoints.append(path.getStateCount())
        else:
            print(f"ompl_plan: run {len(total) - 1}: {status}", file=sys.stderr)
    per_check = [t * 1e3 / c for t, c in zip(planning, calls) if c]
    emit(summary(scene, f"OMPL RRTConnect (ompl {_version('ompl')})", total, planning, simplify, solved,
                 args.simplify != "none", cpu, {
                     "seeding": f"ompl.util.RNG.setSeed({args.first + 1}) once",
                     "goals": len(scene["goals"]),
                     "range": planner["step"],
                     "resolution": planner["resolution"],
                     "resolution_norm": "max" if args.edge == "max" else "euclidean",
                     "edge": args.edge,
                     "simplifier": {"shortcut": "reduceVertices", "max": "simplifyMax"}.get(args.simplify),
                     "median_simplify_max_ms": median(simplify_max),
                     "median_checks": median(calls),
                     "median_waypoints": median(waypoints),
                     "check_us": check_us,
                     "check_us_in_planner": median(per_check),
                     "agreement": [agreement, len(configs)],
                     "pairs": len(scene["exchange"]["pairs"]),
                     "pin_version": pin.__version__,
                     "coal_version": getattr(coal, "__version__", None),
                 }))


def _version(name):
    try:
        from importlib.metadata import version

        return version(name)
    except Exception:  # noqa: BLE001 - metadata is best effort
        return "?"


if __name__ == "__main__":
    main()
