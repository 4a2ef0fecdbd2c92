"""RAI's KOMO (PyPI `robotic`) on a tandem trajectory problem.

    python rai_komo.py PROBLEM.json [--reps 10] [--max-inits K] [--stop-tolerance X] [--check]

PROBLEM.json comes from `examples/komo_seeds.rs --export`. The configuration
is built as the planning peer builds it (rai_plan.build_config): frame by
frame from the problem's URDF, one sphere frame per URDF collision sphere, the
obstacles as boxes, contact flags set so that RAI's collidable pairs equal
tandem's (a pair RAI cannot express — the grasp target's allowed contact with
the links rigidly attached to the gripper — is handled by leaving that
obstacle out of RAI's collision checks; the printed `pairs` says which pairs
differ, and tandem's yardstick still measures them).

The problem: `KOMO(C, 1 phase, T slices, k = 2, collisions on)` with
`setTiming(1, T, duration, 2)`, the start as the k prefix configurations, and
tandem's objectives mapped to RAI features with the same slices (times s/T),
kind, scale, target and order (RAI divides an order-k feature by τ^k as
tandem does):

    joint_state             FS.qItself (order k)
    joint_limits            FS.jointLimits (lower − q, q − upper; margin 0 only)
    position                FS.position
    position_difference     FS.positionDiff
    scalar_product          FS.scalarProductAB (A, B = frame axes)
    vector                  FS.vectorA (frame b = world) or FS.vectorARel
    collision               FS.accumulatedCollisions, kind ineq

RAI's collision feature differs from tandem's: per slice ONE scalar, the sum
over the shape pairs closer than the margin of (margin − d), where tandem has
one inequality per pair. RAI's Python API fixes that margin at 0, so the
margin is built into the geometry instead: every robot sphere is inflated by
margin/2 and every obstacle is swept by a ball of radius margin/2 (a box
becomes an ssBox, a cylinder an ssCylinder, a sphere's radius grows; see
rai_plan.set_obstacle_shape), which lowers every sphere–sphere and
sphere–obstacle distance by exactly the margin. Fixed frames (objects, grasp frames) are added as
world-fixed marker frames at tandem's poses.

The solver is RAI's own NLP_Solver with its augmented Lagrangian
(OptMethod.AugmentedLag) and default options unless --stop-tolerance /
--stop-g-tolerance are given; it starts exactly at tandem's initialisation
(setInitialization: RAI's own initialisation would add 1 cm of noise). The
KOMO is rebuilt before every repetition; only NLP_Solver.solve() is timed.

With --check, prints RAI's cost of each objective at the first
initialisation next to tandem's definitions (computed here), to confirm the
mapping, and exits.
"""

import argparse
import os
import sys
import time

import numpy as np

from komo_common import AXES, collision_margin, emit, is_world, load_problem, result, version_of

ry = None  # the robotic module, imported in main() (after the chdir)


def robot_scene(problem):
    """The scene rai_plan.build_robot / build_config read for the KOMO
    configuration: the spheres grown by the padding plus half the margin."""
    margin = collision_margin(problem) or 0.0
    return {"exchange": problem["exchange"], "padding": problem.get("padding", 0.0) + margin / 2,
            "problem": problem["problem"]}


def build_config(problem, robot=None, report=True):
    """The robot and obstacles as a RAI configuration with the collision
    margin built into the shapes, plus marker frames for the fixed frames;
    returns (C, pair report, marker names by tandem frame name). `robot`: a
    configuration from rai_plan.build_robot(robot_scene(problem)) to copy."""
    import rai_plan

    rai_plan.ry = ry
    margin = collision_margin(problem) or 0.0
    C, pairs = rai_plan.build_config(robot_scene(problem), robot, margin / 2, report)
    markers = {}
    for objective in problem["objectives"]:
        for frame in objective["frames"]:
            if "fixed" in frame and not is_world(frame) and frame["fixed"] not in markers:
                name = "fixed:" + frame["fixed"]
                C.addFrame(name).setPosition(frame["translation"]).setRotationMatrix(np.array(frame["rotation"]))
                markers[frame["fixed"]] = name
    return C, pairs, markers


def frame_name(frame, markers):
    return frame["robot"] if "robot" in frame else markers[frame["fixed"]]


def add_objectives(komo, problem, markers):
    T = problem["horizon"]
    kinds = {"sos": ry.OT.sos, "eq": ry.OT.eq, "ineq": ry.OT.ineq}
    for o in problem["objectives"]:
        first, last = o["slices"]
        times = [first / T, last / T]
        kind, scale, target, order = kinds[o["kind"]], [o["scale"]], o["target"] or [], o["order"]
        feature = o["feature"]
        frames = [frame_name(f, markers) if not is_world(f) else None for f in o["frames"]]
        if feature == "joint_state":
            komo.addObjective(times, ry.FS.qItself, [], kind, scale, target, order)
        elif feature == "joint_limits":
            if o["margin"]:
                raise SystemExit("joint_limits with a margin is not mapped (RAI's feature has none)")
            komo.addObjective(times, ry.FS.jointLimits, [], kind, scale, target, order)
        elif feature == "collision":
            komo.addObjective(times, ry.FS.accumulatedCollisions, [], kind, scale, target, order)
        elif feature == "position":
            komo.addObjective(times, ry.FS.position, frames, kind, scale, target, order)
        elif feature == "position_difference":
            if frames[1] is None:
                komo.addObjective(times, ry.FS.position, frames[:1], kind, scale, target, order)
            else:
                komo.addObjective(times, ry.FS.positionDiff, frames, kind, scale, target, order)
        elif feature == "scalar_product":
            a, b = (AXES[i].upper() for i in o["axes"])
            fa, fb = frames
            if fb is None:
                raise SystemExit("scalar_product with the world frame is not mapped")
            if not hasattr(ry.FS, f"scalarProduct{a}{b}"):
                a, b, fa, fb = b, a, fb, fa  # symmetric: RAI has XY but not YX for some pairs
            komo.addObjective(times, getattr(ry.FS, f"scalarProduct{a}{b}"), [fa, fb], kind, scale, target, order)
        elif feature == "vector":
            axis = AXES[o["axes"][0]].upper()
            if frames[1] is None:
                komo.addObjective(times, getattr(ry.FS, f"vector{axis}"), frames[:1], kind, scale, target, order)
            else:
                komo.addObjective(times, getattr(ry.FS, f"vector{axis}Rel"), frames, kind, scale, target, order)
        else:
            raise SystemExit(f"feature {feature} is not mapped to RAI")


def make_komo(C, problem, markers):
    T = problem["horizon"]
    C.setJointState(np.asarray(problem["start"], dtype=float))
    # The constructor fixes τ = 1/T; the older two-step set-up takes a duration.
    komo = ry.KOMO()
    komo.setTiming(1, T, problem["duration"], problem["order"])
    komo.setConfig(C, True)
    add_objectives(komo, problem, markers)
    return komo


def solve_once(C, problem, markers, init, options):
    komo = make_komo(C, problem, markers)
    x0 = np.asarray(init, dtype=float).reshape(-1)
    komo.initWithPath(np.asarray(init, dtype=float))
    sol = ry.NLP_Solver(komo.nlp(), verbose=0)
    sol.setSolver(ry.OptMethod.AugmentedLag)
    if options:
        sol.setOptions(**options)
    sol.setInitialization(x0)
    began, cpu_began = time.perf_counter(), time.process_time()
    ret = sol.solve()
    elapsed, cpu = time.perf_counter() - began, time.process_time() - cpu_began
    path = np.asarray(komo.getPath(), dtype=float)
    return ret, path, elapsed * 1e3, cpu * 1e3


def check(C, problem, markers):
    """RAI's per-objective values at the first initialisation, next to tandem's measure of it."""
    init = problem["inits"][0]
    komo = make_komo(C, problem, markers)
    komo.initWithPath(np.asarray(init["trajectory"], dtype=float))
    nlp = komo.nlp()
    phi, _ = nlp.evaluate(np.asarray(init["trajectory"], dtype=float).reshape(-1))
    types = nlp.getTypes()
    phi = np.asarray(phi)
    sos = float(sum(p * p for p, t in zip(phi, types) if t == ry.OT.sos))
    eq = max([abs(p) for p, t in zip(phi, types) if t == ry.OT.eq], default=0.0)
    ineq = max([max(p, 0.0) for p, t in zip(phi, types) if t == ry.OT.ineq], default=0.0)
    print(f"RAI at init 0: sos {sos:.10g}  max|eq| {eq:.6g}  max ineq {ineq:.6g}  tau {komo.getPathTau()[:3]}")
    print(f"tandem at init 0: cost {init['cost']:.10g}  eq {init['eq']:.6g}  ineq {init['ineq']:.6g}")
    print(komo.report(False, True, False))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("problem")
    ap.add_argument("--reps", type=int, default=10, help="timed solves per initialisation")
    ap.add_argument("--max-inits", type=int, default=None, help="use only the first K initialisations")
    ap.add_argument("--stop-tolerance", type=float, default=None, help="NLP_Solver stopTolerance (default RAI's)")
    ap.add_argument("--stop-g-tolerance", type=float, default=None, help="NLP_Solver stopGTolerance (default RAI's)")
    ap.add_argument("--label", default="RAI KOMO", help="solver name in the output")
    ap.add_argument("--check", action="store_true", help="compare RAI's objective values with tandem's and exit")
    args = ap.parse_args()
    problem = load_problem(args.problem)
    # RAI writes its log (z.log.global) into the working directory: keep it
    # next to the problem file.
    os.chdir(os.path.dirname(os.path.abspath(args.problem)))
    global ry
    import robotic as ry

    ry.rnd_seed(0)
    C, pairs, markers = build_config(problem)
    if args.check:
        check(C, problem, markers)
        sys.stdout.flush()
        os._exit(0)
    options = {}
    if args.stop_tolerance is not None:
        options["stopTolerance"] = args.stop_tolerance
    if args.stop_g_tolerance is not None:
        options["stopGTolerance"] = args.stop_g_tolerance
    inits = problem["inits"][: args.max_inits] if args.max_inits else problem["inits"]
    # One untimed solve first (lazy initialisation in the library).
    solve_once(C, problem, markers, inits[0]["trajectory"], options)
    runs = []
    for init in inits:
        times, cpu, last = [], [], None
        for _ in range(args.reps):
            ret, path, ms, cpu_ms = solve_once(C, problem, markers, init["trajectory"], options)
            times.append(ms)
            cpu.append(cpu_ms)
            last = (ret, path)
        ret, path = last
        runs.append({
            "init": init["init"],
            "times_ms": times,
            "cpu_ms": cpu,
            "converged": bool(ret.feasible),
            "status": "feasible" if ret.feasible else "infeasible",
            "evaluations": int(ret.evals),
            "own": {"sos": float(ret.sos), "eq": float(ret.eq), "ineq": float(ret.ineq), "f": float(ret.f)},
            "trajectory": path.tolist(),
        })
    emit(result(problem, args.label, runs, {
        "options": {**{k: v for k, v in ry.NLP_SolverOptions().dict().items()}, **options},
        "timed": "NLP_Solver.solve() (AugmentedLag) on a freshly built KOMO",
        "pairs": pairs,
        "collision": "accumulatedCollisions ineq; margin built into the shapes (spheres + m/2, boxes as ssBox m/2)",
        "robotic_version": version_of("robotic"),
    }))


if __name__ == "__main__":
    main()
