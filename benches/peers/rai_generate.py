"""RAI (PyPI `robotic`) as a bulk trajectory generator: IK, RRT_PathFinder,
then KOMO, on the samples of a tandem problem family.

    python rai_generate.py SAMPLES_DIR [--count N] [--goals rai-ik|tandem] [--komo-option NAME=VALUE]
                           [--no-warmup]

SAMPLES_DIR holds sample_NNNNN.json from `examples/family_export.rs`: each
sampled problem of the family (the same (seed, id) `tandem generate`
samples) in the exchange format of `examples/komo_seeds.rs --export`, plus
tandem's planner settings, the goal and tandem's IK goal configurations.
For every sample, timed:

1. scene: two RAI configurations, as the planning and KOMO peers build them
   (rai_plan.build_config, rai_komo.build_config): the Panda's URDF
   collision spheres, the obstacles (box, sphere, cylinder), the same
   checked pairs except the grasp target's (left out of RAI's checks: RAI
   cannot allow its contact with the gripper links only). The planning one
   pads the spheres by tandem's search padding (the planner clearance); the
   KOMO one builds the collision margin into the shapes. The robot part of
   each (RAI takes ~7 ms per sphere shape) is built once per run and copied
   per sample (`setup_ms`, added to the total time, not to any sample);
   per sample: the copy, the obstacles and the fixed marker frames.
2. goal: with `--goals rai-ik` (default) RAI's own IK — a one-slice KOMO
   with the problem's equality/inequality objectives of order 0 active at
   the last slice (grasp position, gripper axis, finger direction, joint
   limits, collisions with the margin) and q pulled towards the start
   (sos 0.1), solved by NLP_Solver (AugmentedLag, default options); if the
   solution is infeasible or collides in the planning configuration, up to
   3 more tries from random configurations. tandem's IK (4 solutions, full
   grasp-frame orientation) runs inside its own timed generation. With
   `--goals tandem` RAI takes the exported tandem IK solution nearest to
   the start instead (RAI then gets IK for free; not timed).
3. rrt: RRT_PathFinder from the start to that one goal, as
   benches/peers/rai_plan.py runs it: stepsize 64 × tandem's planner
   resolution, 64 subsamples per step, p_connect 0.5, maxIters = tandem's
   max_iterations, seed = sample id. tandem's RRT-Connect aims at all its IK
   goals at once, shortcuts and certifies its path; RAI returns the raw
   tree path.
4. komo: the path resampled to q_1 … q_T by arc length (tandem's resample;
   the straight line to the goal when RRT fails, as tandem does), then KOMO
   as rai_komo.py poses it (same objectives, slices, horizon, duration,
   accumulatedCollisions with the margin built into the shapes) and solves
   it (NLP_Solver, AugmentedLag, default options), one solve. tandem
   re-solves with collision rows between slices when its result collides
   between slices; RAI's pipeline has no such step.

A sample's time is the sum of the four (wall clock; the process CPU time
too); `--count` samples are run in order, single-threaded. One untimed
warm-up pass over the first sample comes first (library initialisation)
unless --no-warmup. `--komo-option NAME=VALUE` sets an NLP_Solver option of
step 4 (RAI's defaults stop at eq ≈ 3–6e-4 here, above the yardstick's
1e-4; stopTolerance=1e-4 gets closer, at about 3x the time). Not timed: loading the JSON, Python's start and import.

Prints one JSON object {"solver", "samples": [{"id", "trajectory",
"converged", "status", "times_ms", "cpu_ms", ...}], ...} which
`family_export --measure` completes with tandem's verdict (measure,
validate at 2 mrad between slices, limits, eq/ineq ≤ 1e-4, goal reached).
"""

import argparse
import glob
import json
import os
import time

import numpy as np

import rai_komo
import rai_plan
from komo_common import emit, load_problem, version_of
from planning_common import CaptureStdout

ry = None  # the robotic module, imported in main() (after the chdir)

STATIC_FEATURES = ("position", "position_difference", "scalar_product", "vector", "joint_limits", "collision")


def load_sample(path):
    problem = load_problem(path)
    for key in ("id", "planner", "goal", "tandem_goals"):
        if key not in problem:
            raise SystemExit(f"{path}: missing key {key!r} (write it with examples/family_export.rs)")
    return problem


def plan_scene(problem):
    """The scene rai_plan reads for the planning configuration."""
    return {"exchange": problem["exchange"], "padding": problem["planner"]["search_padding"],
            "problem": problem["problem"]}


def robot_key(scene):
    e = scene["exchange"]
    return json.dumps([e["urdf"], e["joints"], e.get("held"), e["robot_elements"], scene["padding"]])


class Robots:
    """The robot configurations, built once per robot and padding (RAI takes
    milliseconds per sphere shape) and copied for every sample."""

    def __init__(self):
        self.configs, self.ms, self.cpu_ms = {}, 0.0, 0.0

    def get(self, scene):
        key = robot_key(scene)
        if key not in self.configs:
            began, cpu_began = time.perf_counter(), time.process_time()
            self.configs[key] = rai_plan.build_robot(scene)
            self.ms += (time.perf_counter() - began) * 1e3
            self.cpu_ms += (time.process_time() - cpu_began) * 1e3
        return self.configs[key]


def build_scene(problem, robots):
    """(planning config, KOMO config, KOMO marker frames): the robot copied,
    the sample's obstacles and fixed frames added."""
    scene = plan_scene(problem)
    C_plan, _ = rai_plan.build_config(scene, robots.get(scene), 0.0, report=False)
    robot = robots.get(rai_komo.robot_scene(problem))
    C_komo, _, markers = rai_komo.build_config(problem, robot, report=False)
    return C_plan, C_komo, markers


def collision_free(C, q, tolerance=1e-9):
    C.setJointState(np.asarray(q, dtype=float))
    return C.coll_totalViolation() < tolerance


def ik_problem(problem):
    """The problem reduced to its last slice: order-0 equality and inequality
    objectives active at slice T, posed on a one-slice horizon."""
    T = problem["horizon"]
    objectives = [
        {**o, "slices": [1, 1]} for o in problem["objectives"]
        if o["kind"] in ("eq", "ineq") and o["order"] == 0 and o["feature"] in STATIC_FEATURES
        and o["slices"][0] <= T <= o["slices"][1]
    ]
    return {**problem, "horizon": 1, "objectives": objectives}


def rai_ik(C_komo, C_plan, problem, markers, tries=4):
    """RAI's IK for the goal; returns (q or None, tries used)."""
    reduced = ik_problem(problem)
    start = np.asarray(problem["start"], dtype=float)
    for attempt in range(tries):
        C_komo.setJointState(start)
        komo = ry.KOMO()
        komo.setTiming(1, 1, 1.0, 0)
        komo.setConfig(C_komo, True)
        rai_komo.add_objectives(komo, reduced, markers)
        komo.addObjective([], ry.FS.qItself, [], ry.OT.sos, [0.1], start, 0)
        if attempt:
            komo.initRandom()
        sol = ry.NLP_Solver(komo.nlp(), verbose=0)
        sol.setSolver(ry.OptMethod.AugmentedLag)
        ret = sol.solve()
        q = np.asarray(komo.getPath(), dtype=float)[-1]
        if ret.feasible and collision_free(C_plan, q):
            return q, attempt + 1
    return None, tries


def tandem_goal(problem):
    """The exported tandem IK solution nearest to the start, or None."""
    start = np.asarray(problem["start"], dtype=float)
    goals = [np.asarray(g, dtype=float) for g in problem["tandem_goals"]]
    return min(goals, key=lambda g: float(np.linalg.norm(g - start))) if goals else None


def rrt(C_plan, problem, goal, seed):
    """RRT_PathFinder as rai_plan.py runs it; returns the path or None."""
    planner = problem["planner"]
    start = np.asarray(problem["start"], dtype=float)
    C_plan.setJointState(start)
    finder = ry.RRT_PathFinder()
    finder.setOptions(verbose=0, stepsize=64 * planner["resolution"], subsamples=64,
                      maxIters=planner["max_iterations"], p_connect=0.5, collisionTolerance=1e-9,
                      useBroadCollisions=True)
    finder.setProblem(C_plan)
    with CaptureStdout():
        finder.setStartGoal(start, goal)
        ry.rnd_seed(seed)
        ret = finder.solve(0)
    return np.asarray(ret.x, dtype=float) if ret.feasible else None


def resample(path, count):
    """tandem's plan::resample: count points evenly spaced in arc length."""
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    walked = np.concatenate([[0.0], np.cumsum(steps)])
    if walked[-1] == 0.0:
        return np.repeat(path[:1], count, axis=0)
    targets = walked[-1] * np.arange(count) / (count - 1)
    out = np.stack([np.interp(targets, walked, path[:, j]) for j in range(path.shape[1])], axis=1)
    out[-1] = path[-1]
    return out


def initialisation(problem, path, goal):
    """q_1 … q_T from the path, else the straight line to the goal."""
    T = problem["horizon"]
    start = np.asarray(problem["start"], dtype=float)
    if path is None:
        path = np.stack([start, goal])
    return resample(path, T + 1)[1:]


def generate_one(problem, goals, robots, options):
    """One sample, timed by phase; returns the sample's result."""
    times, began, cpu_began = {}, time.perf_counter(), time.process_time()

    def lap(name, t0):
        times[name] = (time.perf_counter() - t0) * 1e3
        return time.perf_counter()

    t = time.perf_counter()
    C_plan, C_komo, markers = build_scene(problem, robots)
    t = lap("scene", t)
    ik_tries = 0
    if goals == "tandem":
        goal = tandem_goal(problem)
    else:
        goal, ik_tries = rai_ik(C_komo, C_plan, problem, markers)
    t = lap("goal", t)
    out = {"id": problem["id"], "ik_tries": ik_tries}
    if goal is None:
        times["rrt"] = times["komo"] = 0.0
        out.update(converged=False, status="ik_failed", trajectory=None)
    else:
        path = rrt(C_plan, problem, goal, problem["id"])
        t = lap("rrt", t)
        init = initialisation(problem, path, goal)
        ret, trajectory, _, _ = rai_komo.solve_once(C_komo, problem, markers, init, options)
        lap("komo", t)
        out.update(converged=bool(ret.feasible), status="feasible" if ret.feasible else "infeasible",
                   rrt_solved=path is not None, rrt_waypoints=None if path is None else len(path),
                   goal=goal.tolist(), trajectory=trajectory.tolist())
    times["total"] = (time.perf_counter() - began) * 1e3
    out["times_ms"] = times
    out["cpu_ms"] = (time.process_time() - cpu_began) * 1e3
    return out


def parse_option(text):
    name, _, value = text.partition("=")
    try:
        return name, float(value)
    except ValueError:
        raise SystemExit(f"--komo-option {text!r}: expected NAME=NUMBER, e.g. stopTolerance=1e-3") from None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("samples", help="folder of sample_NNNNN.json (examples/family_export.rs)")
    ap.add_argument("--count", type=int, default=None, help="only the first N samples")
    ap.add_argument("--goals", choices=("rai-ik", "tandem"), default="rai-ik",
                    help="goal configuration: RAI's own IK (timed) or tandem's exported IK solution")
    ap.add_argument("--komo-option", action="append", default=[], metavar="NAME=VALUE",
                    help="an NLP_Solver option for the trajectory KOMO (default: RAI's defaults, as rai_komo.py)")
    ap.add_argument("--no-warmup", action="store_true", help="skip the untimed pass over the first sample")
    args = ap.parse_args()
    files = sorted(glob.glob(os.path.join(args.samples, "sample_*.json")))[: args.count]
    if not files:
        raise SystemExit(f"no sample_*.json in {args.samples} (write them with examples/family_export.rs)")
    problems = [load_sample(f) for f in files]
    options = dict(parse_option(o) for o in args.komo_option)
    # RAI writes its log (z.log.global) into the working directory.
    os.chdir(os.path.abspath(args.samples))
    global ry
    import robotic as ry

    rai_plan.ry = rai_komo.ry = ry
    ry.rnd_seed(0)
    robots = Robots()
    for p in problems:  # one-off: counted in the total time, not per sample
        robots.get(plan_scene(p))
        robots.get(rai_komo.robot_scene(p))
    setup_ms, setup_cpu_ms = robots.ms, robots.cpu_ms
    pairs = rai_plan.build_config(plan_scene(problems[0]))[1]
    if not args.no_warmup:
        generate_one(problems[0], args.goals, robots, options)
    samples = [generate_one(p, args.goals, robots, options) for p in problems]
    emit({
        "solver": "RAI RRT_PathFinder + KOMO (robotic)",
        "goals": args.goals,
        "family": problems[0].get("family"),
        "run_seed": problems[0].get("run_seed"),
        "horizon": problems[0]["horizon"],
        "count": len(samples),
        "setup_ms": setup_ms,
        "setup_cpu_ms": setup_cpu_ms,
        "warmup": not args.no_warmup,
        "timed": "scene (two RAI configs) + goal (RAI IK, or none with --goals tandem) + RRT_PathFinder + KOMO "
                 "(build + NLP_Solver.solve, AugmentedLag, default options)",
        "pairs_sample0": pairs,
        "komo_options": {**ry.NLP_SolverOptions().dict(), **options},
        "robotic_version": version_of("robotic"),
        "samples": samples,
    })


if __name__ == "__main__":
    main()
