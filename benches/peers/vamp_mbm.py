"""VAMP's RRT-Connect on MotionBenchMaker's problems, timed as VAMP's own
`scripts/evaluate_mbm.py` times them: the same calls (its default planner
and simplifier settings, the Halton sampler reset per problem, `trials` runs
per problem, simplification after each solved run) and the same clocks (the
nanoseconds VAMP's C++ reports for planning and for simplification). Prints
one JSON object: per figure (planning, simplification, total) the median,
mean and 95th percentile in ms, per family the total's, and the mean
joint-space length of the simplified paths (rad, VAMP's `path.cost()`).

    vamp_mbm.py PROBLEMS.pkl [--robot panda] [--trials 3] [--per-family N]

PROBLEMS.pkl is VAMP's dataset (its resources/<robot>/problem_tar_to_pkl_json.py
writes it from the problems.tar.bz2 VAMP ships); compare_vamp.sh makes it.
"""

import argparse
import json
import pickle
import statistics
import sys

import vamp


def summary(values):
    values = sorted(values)
    p95 = values[min(len(values) - 1, round(0.95 * (len(values) - 1)))]
    return {"median_ms": statistics.median(values), "mean_ms": statistics.fmean(values), "p95_ms": p95}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("problems", help="VAMP's problems.pkl")
    parser.add_argument("--robot", default="panda")
    parser.add_argument("--trials", type=int, default=3, help="runs per problem (default 3)")
    parser.add_argument("--per-family", type=int, default=None, help="only the first N problems of each family")
    args = parser.parse_args()
    with open(args.problems, "rb") as f:
        problems = pickle.load(f)["problems"]
    module, plan, plan_settings, simp_settings = vamp.configure_robot_and_planner_with_kwargs(args.robot, "rrtc")
    sampler = module.halton()
    times = {"planning": [], "simplification": [], "total": []}
    by_family, unsolved, valid, lengths = {}, [], 0, []
    for family, instances in problems.items():
        for i, data in enumerate(instances[: args.per_family]):
            if not data["valid"]:
                continue
            valid += 1
            env = vamp.problem_dict_to_vamp(data)
            sampler.reset()
            for trial in range(args.trials):
                result = plan(data["start"], data["goals"], env, plan_settings, sampler)
                if not result.solved:
                    unsolved.append(f"{family} {i} trial {trial}")
                    break
                simple = module.simplify(result.path, env, simp_settings, sampler)
                planning, simplification = result.nanoseconds / 1e6, simple.nanoseconds / 1e6
                times["planning"].append(planning)
                times["simplification"].append(simplification)
                times["total"].append(planning + simplification)
                by_family.setdefault(family, []).append(planning + simplification)
                lengths.append(simple.path.cost())
    out = {figure: summary(v) for figure, v in times.items()}
    out["families"] = {family: summary(v) for family, v in by_family.items()}
    out["solved"] = len(times["total"])
    out["runs"] = valid * args.trials
    out["unsolved"] = unsolved
    out["mean_path_length_rad"] = statistics.fmean(lengths)
    out["vamp"] = getattr(vamp, "__version__", "?")
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
