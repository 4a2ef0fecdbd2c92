"""RAI's RRT_PathFinder (PyPI `robotic`) on a tandem problem, for many seeds.

    python rai_plan.py SCENE.json [--seeds 50] [--first 0] [--stepsize S] [--subsamples N]

SCENE.json comes from `examples/plan_seeds.rs --scene`. The configuration
is built here frame by frame from the problem's URDF (joint origins, hinge
joints with their limits, held joints fixed at their values) with one sphere
frame per URDF collision sphere, padded like tandem's search, and the
obstacles as RAI shapes (box, sphere, capsule, cylinder: set_obstacle_shape).
RAI decides which shape pairs it checks from the frame tree and the shapes'
`contact` flags; they are set so that its pairs equal
tandem's (robot spheres: contact -1, no collision with the parent link;
obstacles: children of the base, the table with contact -1, so it is not
checked against the base link). Pairs RAI cannot express (the grasp
target's allowed contact with the links rigidly attached to the gripper) are
handled by leaving that obstacle out of RAI's collision checks; the printed
`pairs` report says exactly which pairs differ from tandem's, and
`agreement` how many of the scene's random configurations RAI judges as
tandem does.

RRT_PathFinder is a bidirectional RRT: each iteration grows each tree by one
step of at most `stepsize` (Euclidean) towards a uniform sample or, with
probability p_connect, towards a random node of the other tree; a step is
checked at its end and at `subsamples - 1` interior points (van der Corput
order, evenly spaced when `subsamples` is a power of two), so the
edge-validation resolution is stepsize / subsamples in the Euclidean norm.
It takes one goal configuration (the one of tandem's goals nearest to the
start, unless --goal), has no time budget (only maxIters) and returns the raw
tree path: no shortcutting.

Prints one JSON object (keys of plan_seeds) on stdout.
"""

import argparse
import functools
import math
import os
import re
import sys
import time

import numpy as np

from planning_common import (CaptureStdout, element_names, emit, load_scene, median, read_urdf, rpy_quaternion,
                             summary)

ry = None  # the robotic module, imported in main() (after the chdir)


def build_config(scene, robot=None, sweep=0.0, report=True):
    """The robot and obstacles as a RAI configuration; returns (C, report of
    the pair mapping, or None without `report`). `robot`: a configuration
    from build_robot(scene) to copy instead of building the robot anew (RAI
    takes milliseconds per sphere shape); `sweep`: grow the obstacles by it
    (set_obstacle_shape)."""
    if robot is None:
        C = build_robot(scene)
    else:
        C = ry.Config()
        C.addConfigurationCopy(robot)
    left_out = add_obstacles(C, scene, sweep)
    return C, pair_report(C, scene, left_out) if report else None


@functools.lru_cache(maxsize=8)
def _urdf(path):
    return read_urdf(path)


def build_robot(scene):
    """The robot alone: its kinematic tree, held joints at their values, one
    sphere frame per URDF collision sphere padded by the scene's padding,
    and an empty rigid `obstacles` link under the base."""
    e = scene["exchange"]
    pad = scene["padding"]
    base, joints, spheres = _urdf(e["urdf"])
    active = {name: i for i, name in enumerate(e["joints"])}
    held = e.get("held", {})
    C = ry.Config()
    C.addFrame("world")
    # A rigid joint makes the base its own link, so that contact -1 on the
    # shapes of link 2 excludes link 1 only (RAI counts joints upwards).
    C.addFrame(base, "world").setJoint(ry.JT.rigid)
    joint_frames = [None] * len(active)
    hinge = {(1.0, 0.0, 0.0): ry.JT.hingeX, (0.0, 1.0, 0.0): ry.JT.hingeY, (0.0, 0.0, 1.0): ry.JT.hingeZ}
    for j in joints:
        C.addFrame(j["name"] + "_origin", j["parent"]).setRelativePosition(j["xyz"]).setRelativeQuaternion(
            rpy_quaternion(*j["rpy"]))
        f = C.addFrame(j["child"], j["name"] + "_origin")
        axis = tuple(float(a) for a in j["axis"])
        if j["name"] in active:
            if j["type"] not in ("revolute", "continuous") or axis not in hinge:
                raise SystemExit(f"joint {j['name']}: only revolute joints about x, y or z are mapped ({j['type']}, {axis})")
            lo, hi = j["limits"] if j["limits"] else (-math.pi, math.pi)
            f.setJoint(hinge[axis], [lo, hi])
            joint_frames[active[j["name"]]] = j["child"]
        elif j["name"] in held:
            v = float(held[j["name"]])
            if j["type"] == "prismatic":
                f.setRelativePosition([a * v for a in axis])
            elif j["type"] in ("revolute", "continuous"):
                n = math.sqrt(sum(a * a for a in axis))
                f.setRelativeQuaternion([math.cos(v / 2)] + [a / n * math.sin(v / 2) for a in axis])
            else:
                raise SystemExit(f"held joint {j['name']} of type {j['type']}")
    if None in joint_frames:
        raise SystemExit(f"active joints missing from the URDF: {e['joints']}")
    for r in e["robot_elements"]:
        element = spheres[r["link"]][r["index"]]
        if element is None:
            raise SystemExit(f"{r['link']} collision {r['index']}: only spheres are mapped")
        xyz, radius = element
        f = C.addFrame(f"{r['link']}_{r['index']}", r["link"]).setRelativePosition(xyz)
        f.setShape(ry.ST.sphere, [radius + pad]).setContact(-1)
    C.addFrame("obstacles", base).setJoint(ry.JT.rigid)
    if list(C.getJointNames()) != joint_frames:
        raise SystemExit(f"RAI joint order {C.getJointNames()} differs from {joint_frames}")
    return C


def add_obstacles(C, scene, sweep=0.0):
    """The scene's obstacles as frames of the `obstacles` link; returns the
    names of those left out of the collision checks.

    An obstacle tandem does not check against the base link gets contact -1
    (RAI then skips the base); one tandem does not check against other
    robot elements (an allowed grasp contact) cannot be expressed and is
    left out (contact 0)."""
    e = scene["exchange"]
    base = _urdf(e["urdf"])[0]
    names = element_names(scene)
    n_robot = len(e["robot_elements"])
    checked = {k: set() for k in range(n_robot, len(names))}
    for a, b in e["pairs"]:
        if b >= n_robot and a < n_robot:
            checked[b].add(a)
    base_elements = {k for k, r in enumerate(e["robot_elements"]) if r["link"] == base}
    left_out = []
    for k, o in enumerate(e["obstacles"], start=n_robot):
        missing = set(range(n_robot)) - checked[k]
        if not missing:
            contact = 1
        elif missing == base_elements:
            contact = -1
        else:
            contact = 0
            left_out.append(o["name"])
        f = C.addFrame(o["name"], "obstacles").setPosition(o["translation"]).setRotationMatrix(np.array(o["rotation"]))
        set_obstacle_shape(f, o, sweep)
        f.setContact(contact)
    return left_out


def set_obstacle_shape(frame, o, sweep=0.0):
    """An exchange obstacle's shape on a RAI frame, grown by `sweep` (m):
    the shape swept by a ball of that radius, so every distance to it drops
    by exactly `sweep` (box: ssBox; sphere, capsule: radius + sweep;
    cylinder: ssCylinder). RAI's cylinder and capsule run along z, as
    tandem's; sizes [length, radius] (ss: total extents, then the sweep)."""
    shape, r = o["shape"], sweep
    if shape == "box":
        size = [2 * h + 2 * r for h in o["half_extents"]]
        frame.setShape(ry.ST.ssBox, size + [r]) if r else frame.setShape(ry.ST.box, size)
    elif shape == "sphere":
        frame.setShape(ry.ST.sphere, [o["radius"] + r])
    elif shape == "capsule":
        frame.setShape(ry.ST.capsule, [o["length"], o["radius"] + r])
    elif shape == "cylinder":
        size = [o["length"] + 2 * r, o["radius"] + r]
        frame.setShape(ry.ST.ssCylinder, size + [r]) if r else frame.setShape(ry.ST.cylinder, size)
    else:
        raise SystemExit(f"obstacle {o['name']}: shape {shape} is not mapped to RAI")


def pair_report(C, scene, left_out):
    """How RAI's collidable shape pairs compare with tandem's."""
    names = element_names(scene)
    ours = {tuple(sorted((names[a], names[b]))) for a, b in scene["exchange"]["pairs"]}
    flat = list(C.getCollidablePairs())
    theirs = {tuple(sorted(flat[i:i + 2])) for i in range(0, len(flat), 2)}

    def groups(pairs):
        out = {}
        for a, b in pairs:
            key = " - ".join(sorted(n.rsplit("_", 1)[0] if n.startswith("panda_") else n for n in (a, b)))
            out[key] = out.get(key, 0) + 1
        return out

    return {
        "tandem": len(ours),
        "rai": len(theirs),
        "only_tandem": groups(ours - theirs),
        "only_rai": groups(theirs - ours),
        "left_out_obstacles": left_out,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--stepsize", type=float, default=None, help="default: 64 x tandem's resolution")
    ap.add_argument("--subsamples", type=int, default=64, help="checks per step (a power of two)")
    ap.add_argument("--max-iters", type=int, default=None, help="default: tandem's max_iterations")
    ap.add_argument("--goal", type=int, default=None, help="index of tandem's goal to use (default: nearest)")
    ap.add_argument("--tolerance", type=float, default=1e-9, help="RAI collisionTolerance (total penetration, m)")
    args = ap.parse_args()
    scene = load_scene(args.scene)
    # RAI writes its log (z.log.global) into the working directory: keep it
    # next to the scene file.
    os.chdir(os.path.dirname(os.path.abspath(args.scene)))
    global ry
    import robotic as ry

    planner = scene["planner"]
    if args.subsamples < 1 or args.subsamples & (args.subsamples - 1):
        raise SystemExit("--subsamples must be a power of two (RAI checks the step in van der Corput order)")
    stepsize = args.stepsize if args.stepsize is not None else args.subsamples * planner["resolution"]
    max_iters = args.max_iters if args.max_iters is not None else planner["max_iterations"]

    C, pairs = build_config(scene)
    start = np.array(scene["start"], dtype=float)
    goals = [np.array(g, dtype=float) for g in scene["goals"]]
    goal_index = args.goal if args.goal is not None else min(
        range(len(goals)), key=lambda i: float(np.linalg.norm(goals[i] - start)))
    goal = goals[goal_index]

    # Validity check outside the planner: agreement with tandem and the cost
    # of one check through the Python API (setJointState + totalViolation).
    configs = scene["exchange"]["configurations"]
    verdicts = []
    began = time.perf_counter()
    for q in configs:
        C.setJointState(np.asarray(q, dtype=float))
        verdicts.append(C.coll_totalViolation() < args.tolerance)
    check_us = (time.perf_counter() - began) / max(len(configs), 1) * 1e6
    agreement = sum(a == b for a, b in zip(verdicts, scene["free"]))
    for name, q in (("start", start), ("goal", goal)):
        C.setJointState(q)
        if C.coll_totalViolation() >= args.tolerance:
            print(f"rai_plan: warning: the {name} is in collision for RAI", file=sys.stderr)
    C.setJointState(start)

    total, cpu, queries, iterations, waypoints, solved = [], [], [], [], [], 0
    for seed in range(args.first, args.first + args.seeds):
        rrt = ry.RRT_PathFinder()
        rrt.setOptions(verbose=1, stepsize=stepsize, subsamples=args.subsamples, maxIters=max_iters,
                       p_connect=0.5, collisionTolerance=args.tolerance, useBroadCollisions=True)
        rrt.setProblem(C)
        with CaptureStdout():
            rrt.setStartGoal(start, goal)
        ry.rnd_seed(seed)
        with CaptureStdout() as out:
            began, cpu_began = time.perf_counter(), time.process_time()
            ret = rrt.solve(0)
            elapsed, cpu_elapsed = time.perf_counter() - began, time.process_time() - cpu_began
        total.append(elapsed * 1e3)
        cpu.append(cpu_elapsed * 1e3)
        iterations.append(ret.evals)
        # verbose=1 reports the collision queries of a successful search.
        found = re.findall(r"queries: (\d+)", out.text)
        if ret.feasible:
            solved += 1
            waypoints.append(len(ret.x))
            if found:
                queries.append((int(found[-1]), elapsed))
    per_query = [t / n * 1e6 for n, t in queries if n]
    emit(summary(scene, "RAI RRT_PathFinder (robotic)", total, total, [], solved, False, cpu, {
        "goal": goal_index,
        "goals_available": len(goals),
        "stepsize": stepsize,
        "subsamples": args.subsamples,
        "resolution": stepsize / args.subsamples,
        "resolution_norm": "euclidean",
        "max_iters": max_iters,
        "median_iterations": median(iterations),
        "median_queries": median([n for n, _ in queries]),
        "median_waypoints": median(waypoints),
        "check_us": check_us,
        "check_us_in_planner": median(per_query),
        "agreement": [agreement, len(configs)],
        "pairs": pairs,
        "robotic_version": getattr(ry, "__version__", None) or _version(),
    }))


def _version():
    try:
        from importlib.metadata import version

        return version("robotic")
    except Exception:  # noqa: BLE001 - metadata is best effort
        return None


if __name__ == "__main__":
    main()
