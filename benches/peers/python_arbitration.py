"""Per-call cost of one arbitration tick from Python (``tandem.Arbiter.tick``)
on the Panda grasp scene, every mode, along a recorded episode (an operator
pushing the gripper toward the grasp point at 10 cm/s): the numbers to set
beside the Rust tick of ``cargo bench --bench arbitration`` (the difference
is the Python call: argument conversion, the diagnostics dict).

    python python_arbitration.py [--repeats R] [--json out.json]
"""

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
import tandem

MODES = ["direct", "blend-timid", "blend-aggressive", "avoid", "natural-gradient", "natural-gradient-joint",
         "constrained", "sos"]


def record(problem, arbiter):
    """The (q, velocity, command) of each tick of one SoS episode."""
    robot, target = problem.robot, np.array(arbiter.goal_positions[0])
    q, velocity, ticks = problem.start.copy(), np.zeros(robot.nq), []
    arbiter.reset()
    for _ in range(300):
        error = target - robot.frame_pose(q, "panda_hand_tcp")[:3, 3]
        if np.linalg.norm(error) < 0.005:
            break
        command = 0.1 * error / max(np.linalg.norm(error), 0.1)
        ticks.append((q.copy(), velocity.copy(), command))
        qdot, _, _ = arbiter.tick(q, command, velocity=velocity)
        q, velocity = q + arbiter.period * qdot, qdot.copy()
    return ticks


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    problem = tandem.Problem.builtin("panda_grasp_box")
    arbiter = tandem.Arbiter(problem, mode="sos", seed=0)
    ticks = record(problem, arbiter)
    out = np.zeros(problem.robot.nq)
    results = {}
    print(f"{'mode':<24} {'median µs':>10} {'p99 µs':>10}   ({len(ticks)} ticks x {args.repeats})")
    for mode in MODES:
        arbiter.mode = mode
        times = []
        for _ in range(args.repeats):
            arbiter.reset()
            for q, v, c in ticks:
                began = time.perf_counter_ns()
                arbiter.tick(q, c, velocity=v, out=out)
                times.append((time.perf_counter_ns() - began) / 1e3)
        times.sort()
        results[mode] = {"median_us": statistics.median(times), "p99_us": times[int(0.99 * (len(times) - 1))]}
        print(f"{mode:<24} {results[mode]['median_us']:>10.1f} {results[mode]['p99_us']:>10.1f}")
    if args.json:
        args.json.write_text(json.dumps({"ticks": len(ticks), "modes": results}, indent=1))


if __name__ == "__main__":
    main()
