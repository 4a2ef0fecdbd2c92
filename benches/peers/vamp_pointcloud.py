"""VAMP's point-cloud pipeline on MotionBenchMaker's problems, as VAMP's own
`scripts/evaluate_mbm.py --pointcloud` runs it, on points both sides share.

For every valid problem the points are sampled the way evaluate_mbm.py
samples them (`vamp.pointcloud.problem_to_pointcloud`: 10,000 points on the
surface of every box and cylinder, `np.random.seed(0)` per problem) and
written as one binary little-endian PLY of float32 x, y, z per problem,
CLOUDS/<family>/<NNNN>.ply (NNNN the problem's number in MotionBenchMaker,
from 0001, as in its scene files), unless the file is there already. The
points are then read back from that file, so that VAMP plans on exactly
the points tandem reads (`motionbenchmaker -- --clouds CLOUDS`).

Each run is then VAMP's whole pipeline, with evaluate_mbm.py's calls and
settings, and the nanoseconds VAMP's C++ reports for each step:
- filter: `vamp.filter_pointcloud` (its Morton-order minimum-distance
  filter) at 2 cm (`--filter-radius`), culling points farther than the
  robot's reach (1.19 m for the Panda) from its first joint;
- build: `Environment.add_pointcloud` (the CAPT) with the robot's
  `min_max_radii()` and points of `vamp.constants.POINT_RADIUS` (2.5 mm);
- planning: RRT-Connect with VAMP's default settings (those vamp_mbm.py
  uses), the Halton sampler reset per problem;
- simplification: `simplify` with its default settings.
evaluate_mbm.py filters and builds once per problem and counts those times
into each of its trials; here every trial filters and builds again (same
points, same result), so each run is a full pipeline, as on tandem's side.

Prints one JSON object: per figure (filter, build, planning,
simplification, total = planning + simplification, and
filter_build_plan_simplify) the median, mean and 95th percentile in ms over
solved runs; solved and run counts; point counts before and after the
filter (median, mean); the unsolved runs.

    vamp_pointcloud.py PROBLEMS.pkl CLOUDS [--robot panda] [--trials 3] [--per-family N]
        [--samples-per-object 10000] [--filter-radius 0.02] [--write-only]

PROBLEMS.pkl is VAMP's dataset (compare_vamp.sh makes it). `--write-only`
writes the PLY files and exits.
"""

import argparse
import json
import pickle
import statistics
import sys
from pathlib import Path

import numpy as np
import vamp
from vamp import pointcloud as vpc
from vamp.constants import POINT_RADIUS, ROBOT_FIRST_JOINT_LOCATIONS, ROBOT_MAX_RADII


def summary(values):
    values = sorted(values)
    if not values:
        return None
    p95 = values[min(len(values) - 1, round(0.95 * (len(values) - 1)))]
    return {"median_ms": statistics.median(values), "mean_ms": statistics.fmean(values), "p95_ms": p95}


def write_ply(path, points):
    points = np.ascontiguousarray(points, dtype="<f4")
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment MotionBenchMaker scene sampled as VAMP's evaluate_mbm.py "
        f"--pointcloud does\nelement vertex {len(points)}\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    with open(tmp, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(points.tobytes())
    tmp.replace(path)


def read_ply(path):
    """The points of a PLY file write_ply wrote (N × 3 float32)."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").split("\n")
    assert header[1] == "format binary_little_endian 1.0", f"{path}: not a file of write_ply"
    count = next(int(line.split()[2]) for line in header if line.startswith("element vertex"))
    return np.frombuffer(data, dtype="<f4", count=3 * count, offset=end).reshape(count, 3)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("problems", help="VAMP's problems.pkl")
    parser.add_argument("clouds", help="folder of the PLY files (written where missing)")
    parser.add_argument("--robot", default="panda")
    parser.add_argument("--trials", type=int, default=3, help="runs per problem (default 3)")
    parser.add_argument("--per-family", type=int, default=None, help="only the first N problems of each family")
    parser.add_argument("--samples-per-object", type=int, default=10000, help="evaluate_mbm.py's default")
    parser.add_argument("--filter-radius", type=float, default=0.02, help="evaluate_mbm.py's default (m)")
    parser.add_argument("--write-only", action="store_true", help="write the PLY files, time nothing")
    args = parser.parse_args()
    with open(args.problems, "rb") as f:
        problems = pickle.load(f)["problems"]
    clouds = Path(args.clouds)
    module, plan, plan_settings, simp_settings = vamp.configure_robot_and_planner_with_kwargs(args.robot, "rrtc")
    r_min, r_max = module.min_max_radii()
    origin = ROBOT_FIRST_JOINT_LOCATIONS.get(args.robot, [0.0, 0.0, 0.0])
    cull_radius = ROBOT_MAX_RADII.get(args.robot, 1.4)
    bbox_lo = np.asarray(origin) - cull_radius
    bbox_hi = np.asarray(origin) + cull_radius
    sampler = module.halton()
    names = ["filter", "build", "planning", "simplification", "total", "filter_build_plan_simplify"]
    times = {name: [] for name in names}
    unsolved, valid, lengths, original, filtered_sizes = [], 0, [], [], []
    for family, instances in problems.items():
        for data in instances[: args.per_family]:
            if not data["valid"]:
                continue
            valid += 1
            path = clouds / family / f"{data['index']:04d}.ply"
            if not path.exists():
                write_ply(path, np.asarray(vpc.problem_to_pointcloud(data, args.samples_per_object)))
            if args.write_only:
                continue
            # As evaluate_mbm.py hands them over: a list of points.
            points = read_ply(path).tolist()
            original.append(len(points))
            sampler.reset()
            for trial in range(args.trials):
                filtered, filter_ns = vamp.filter_pointcloud(
                    points, args.filter_radius, cull_radius, origin, bbox_lo, bbox_hi, True
                )
                env = vamp.Environment()
                build_ns = env.add_pointcloud(filtered, r_min, r_max, POINT_RADIUS)
                if trial == 0:
                    filtered_sizes.append(len(filtered))
                result = plan(data["start"], data["goals"], env, plan_settings, sampler)
                if not result.solved:
                    unsolved.append(f"{family} {data['index']} trial {trial}")
                    break
                simple = module.simplify(result.path, env, simp_settings, sampler)
                run = {
                    "filter": filter_ns / 1e6,
                    "build": build_ns / 1e6,
                    "planning": result.nanoseconds / 1e6,
                    "simplification": simple.nanoseconds / 1e6,
                }
                run["total"] = run["planning"] + run["simplification"]
                run["filter_build_plan_simplify"] = run["filter"] + run["build"] + run["total"]
                for name in names:
                    times[name].append(run[name])
                lengths.append(simple.path.cost())
    if args.write_only:
        print(f"{valid} clouds in {clouds}", file=sys.stderr)
        return
    out = {name: summary(v) for name, v in times.items()}
    out["solved"] = len(times["total"])
    out["runs"] = valid * args.trials
    out["unsolved"] = unsolved
    out["points"] = {
        "original_median": statistics.median(original),
        "original_mean": statistics.fmean(original),
        "filtered_median": statistics.median(filtered_sizes),
        "filtered_mean": statistics.fmean(filtered_sizes),
    }
    out["settings"] = {
        "filter_radius_m": args.filter_radius,
        "point_radius_m": POINT_RADIUS,
        "cull_radius_m": cull_radius,
        "r_min_m": r_min,
        "r_max_m": r_max,
        "samples_per_object": args.samples_per_object,
        "trials": args.trials,
    }
    out["mean_path_length_rad"] = statistics.fmean(lengths) if lengths else None
    out["vamp"] = getattr(vamp, "__version__", "?")
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
