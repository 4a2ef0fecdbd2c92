"""An independent check of recorded commands against the Franka Emika Panda's
published joint limits, as the robot's controller would make it.

Usage: franka_limits_check.py EPISODES_DIR [EPISODES_DIR ...]

Reads every `*.parquet` of tandem's episode recordings (columns `episode`,
`step`, `time`, `qdot`; `tandem experiment reach-grasp --out DIR` writes them
under DIR/episodes), differentiates each episode's commanded joint velocities
at the recording's own period (taken from its `time` column), from rest (the
velocity and acceleration before the first command are zero), and prints one
JSON object:

  {"episodes": N, "commands": N, "period_s": [...],
   "violations": {"velocity": N, "acceleration": N, "jerk": N},
   "peak_ratio": {"velocity": x, "acceleration": x, "jerk": x},
   "worst": [{"episode", "step", "joint", "what", "ratio"}, ...]}

The limits are written out here from libfranka 0.9's
include/franka/rate_limiting.h (kMaxJointVelocity, kMaxJointAcceleration,
kMaxJointJerk), not read from tandem: velocity 2.175 rad/s (joints 1-4) and
2.61 rad/s (5-7); acceleration 15, 7.5, 10, 12.5, 15, 20, 20 rad/s^2; jerk
7500, 3750, 5000, 6250, 7500, 10000, 10000 rad/s^3. A value counts as a
violation above the limit by more than a relative 1e-9 (rounding); NaN counts
as a violation.
"""

import glob
import json
import math
import os
import sys

import numpy as np
import pyarrow.parquet as pq

VELOCITY = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
ACCELERATION = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
JERK = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0])
TOLERANCE = 1e-9


def check_episode(name, steps, times, qdot, summary):
    order = np.argsort(steps)
    steps, times, qdot = steps[order], times[order], qdot[order]
    if len(times) > 1:
        period = float(np.median(np.diff(times)))
    else:
        period = float(times[0]) if len(times) else 0.0
    summary["period_s"].add(round(period, 12))
    before = np.vstack([np.zeros((1, 7)), qdot])
    acceleration = np.diff(before, axis=0) / period
    jerk = np.diff(np.vstack([np.zeros((1, 7)), acceleration]), axis=0) / period
    for what, values, limit in (
        ("velocity", qdot, VELOCITY),
        ("acceleration", acceleration, ACCELERATION),
        ("jerk", jerk, JERK),
    ):
        ratio = np.abs(values) / limit
        ratio = np.where(np.isnan(ratio), math.inf, ratio)
        broken = ratio > 1.0 + TOLERANCE
        summary["violations"][what] += int(broken.any(axis=1).sum())
        peak = float(ratio.max()) if ratio.size else 0.0
        summary["peak_ratio"][what] = max(summary["peak_ratio"][what], peak)
        if broken.any():
            k, j = np.unravel_index(np.argmax(ratio), ratio.shape)
            summary["worst"].append(
                {"episode": name, "step": int(steps[k]), "joint": int(j) + 1, "what": what, "ratio": float(ratio[k, j])}
            )


def main(dirs):
    summary = {
        "episodes": 0,
        "commands": 0,
        "period_s": set(),
        "violations": {"velocity": 0, "acceleration": 0, "jerk": 0},
        "peak_ratio": {"velocity": 0.0, "acceleration": 0.0, "jerk": 0.0},
        "worst": [],
    }
    files = sorted(f for d in dirs for f in glob.glob(os.path.join(d, "*.parquet")))
    if not files:
        sys.exit(f"error: no *.parquet in {', '.join(dirs)}")
    for path in files:
        table = pq.read_table(path, columns=["episode", "step", "time", "qdot"]).to_pydict()
        episodes = np.array(table["episode"])
        steps = np.array(table["step"])
        times = np.array(table["time"])
        qdot = np.array(table["qdot"], dtype=float)
        if qdot.ndim != 2 or qdot.shape[1] != 7:
            sys.exit(f"error: {path}: qdot must have 7 columns (a Panda), has shape {qdot.shape}")
        for name in sorted(set(episodes)):
            m = episodes == name
            check_episode(f"{os.path.basename(path)}:{name}", steps[m], times[m], qdot[m], summary)
            summary["episodes"] += 1
            summary["commands"] += int(m.sum())
    summary["period_s"] = sorted(summary["period_s"])
    summary["worst"] = sorted(summary["worst"], key=lambda w: -w["ratio"])[:10]
    print(json.dumps(summary))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
