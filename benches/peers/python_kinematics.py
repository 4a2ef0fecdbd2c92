"""Per-call cost from Python of forward kinematics + frame Jacobian:
tandem's package against Pinocchio's Python bindings (``pin``) on the same
URDF (tandem's Panda, 7 arm joints, fingers held open), the same frame and
the same configurations. Run by compare_python.sh (which installs the
release build of the package first).

    python python_kinematics.py [--frame F] [--calls N] [--repeats R] [--json out.json]

Each operation runs N calls over 100 random configurations, R times; the
figure is the median over the repeats of the time per call (ns), loop
included (the same loop for both). Checks first that both compute the same
pose and Jacobian (1e-12).
"""

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import tandem

REPO = Path(__file__).resolve().parents[2]
URDF = REPO / "problems" / "robots" / "panda" / "panda.urdf"


def per_call_ns(fn, qs, calls, repeats):
    """Median over repeats of the time per call of ``fn(q)`` (ns)."""
    n = len(qs)
    times = []
    for _ in range(repeats):
        start = time.perf_counter_ns()
        for i in range(calls):
            fn(qs[i % n])
        times.append((time.perf_counter_ns() - start) / calls)
    return statistics.median(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frame", default="panda_hand_tcp")
    parser.add_argument("--calls", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    robot = tandem.RobotModel.from_urdf(URDF, chain=("panda_link0", args.frame), hold={"panda_finger_joint1": 0.04})
    model = pin.buildModelFromUrdf(str(URDF))
    data = model.createData()
    fid = model.getFrameId(args.frame)
    tid = robot.frame_index(args.frame)
    world = pin.LOCAL_WORLD_ALIGNED
    rng = np.random.default_rng(0)
    lower, upper = robot.lower_limits, robot.upper_limits
    arm = [lower + (upper - lower) * rng.random(7) for _ in range(100)]
    full = []
    for q in arm:  # Pinocchio's q: the arm, then both fingers (independent there) at 0.04
        f = pin.neutral(model)
        f[:7], f[7:9] = q, 0.04
        full.append(f)

    # Same results first.
    for q, f in zip(arm[:10], full[:10]):
        jac = pin.computeFrameJacobian(model, data, f, fid, world)[:, :7]
        pose = data.oMf[fid].homogeneous  # computeFrameJacobian placed the frame
        pin.framesForwardKinematics(model, data, f)
        assert np.abs(pose - data.oMf[fid].homogeneous).max() < 1e-12
        assert np.abs(robot.frame_pose(q, tid) - pose).max() < 1e-12
        assert np.abs(robot.frame_jacobian(q, tid) - jac).max() < 1e-12

    out_pose, out_jac = np.empty((4, 4)), np.empty((6, 7))

    def tandem_fk(q):
        return robot.frame_pose(q, tid)

    def tandem_fk_jac(q):
        return robot.frame_pose(q, tid), robot.frame_jacobian(q, tid)

    def tandem_pose_jacobian(q):
        return robot.frame_pose_jacobian(q, tid)

    def tandem_fk_jac_out(q):
        robot.frame_pose(q, tid, out=out_pose)
        robot.frame_jacobian(q, tid, out=out_jac)

    def tandem_by_name(q):
        return robot.frame_pose(q, args.frame), robot.frame_jacobian(q, args.frame)

    def pin_fk(q):
        pin.forwardKinematics(model, data, q)
        return pin.updateFramePlacement(model, data, fid).homogeneous

    def pin_fk_jac(q):
        jac = pin.computeFrameJacobian(model, data, q, fid, world)
        return data.oMf[fid].homogeneous, jac

    def pin_fk_jac_steps(q):
        pin.forwardKinematics(model, data, q)
        pose = pin.updateFramePlacement(model, data, fid).homogeneous
        return pose, pin.computeFrameJacobian(model, data, q, fid, world)

    ops = [
        ("fk", "FK + frame pose", [("tandem frame_pose", tandem_fk, arm)], [("pin forwardKinematics + updateFramePlacement", pin_fk, full)]),
        (
            "fk_jacobian",
            "FK + frame pose + 6x7 Jacobian",
            [
                ("tandem frame_pose + frame_jacobian", tandem_fk_jac, arm),
                ("tandem frame_pose_jacobian", tandem_pose_jacobian, arm),
                ("tandem frame_pose + frame_jacobian, out=", tandem_fk_jac_out, arm),
                ("tandem frame_pose + frame_jacobian, frame by name", tandem_by_name, arm),
            ],
            [
                ("pin computeFrameJacobian + oMf", pin_fk_jac, full),
                ("pin forwardKinematics + updateFramePlacement + computeFrameJacobian", pin_fk_jac_steps, full),
            ],
        ),
    ]
    rows = []
    print(f"{'operation':<70} {'ns/call':>9}")
    for key, label, ours, theirs in ops:
        print(f"-- {label}")
        measured = {}
        for name, fn, qs in ours + theirs:
            measured[name] = per_call_ns(fn, qs, args.calls, args.repeats)
            print(f"   {name:<67} {measured[name]:>9.0f}")
        natural, best_pin = measured[ours[0][0]], min(measured[n] for n, _, _ in theirs)
        ratio = natural / best_pin
        print(f"   ratio tandem ({ours[0][0]}) / fastest pin: {ratio:.2f}")
        rows.append({"operation": key, "label": label, "ns_per_call": measured, "ratio_natural_to_fastest_pin": ratio})
    if args.json:
        args.json.write_text(json.dumps({"frame": args.frame, "calls": args.calls, "repeats": args.repeats, "results": rows}, indent=1))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
