#!/usr/bin/env python3
"""Pinocchio reference kinematics for tandem's cross-check tests.

Usage:
  pin_reference.py robots
      One JSON object on stdout: the example-robot-data package folder and
      the URDF paths of the robots the tests use.
  pin_reference.py meshes < request.json
      Request: {"urdf": path, "package_dir": path}. Loads the collision
      geometry with Pinocchio (meshes read by coal through assimp) and prints
      {"objects": [{"name", "frame", "vertices", "min": [x,y,z], "max": [x,y,z]}]}
      for every mesh object, bounds in the object's own frame (scaled).
  pin_reference.py kinematics < request.json
      Request: {"urdf": path, "joints": [names], "frames": [{"name": str,
      "kind": "link"|"joint"}], "q": [[values in `joints` order], ...],
      "output": path}. Every movable joint of the URDF must be named in
      `joints` (Pinocchio is built without mimic support, so mimic joints
      are independent here). Writes to `output` little-endian f64 values:
      for each configuration, for each frame: rotation (3x3, row-major),
      translation (3), world-aligned Jacobian (6 x n, row-major, columns in
      `joints` order), local Jacobian (6 x n). Prints a JSON summary.
"""
import json
import sys

import numpy as np
import pinocchio as pin


def erd_share():
    """The folder holding example-robot-data's `robots/` (the wheel installs it
    under site-packages/cmeel.prefix/share; it has no Python module)."""
    import sysconfig
    from pathlib import Path

    share = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share"
    if not (share / "example-robot-data" / "robots").is_dir():
        raise SystemExit(f"pin_reference: example-robot-data not found under {share}; "
                         "install python_ref/requirements.txt")
    return share


def erd_robots():
    share = erd_share()

    def path(rel):
        return str(share / "example-robot-data" / "robots" / rel)

    robots = {
        "panda": "panda_description/urdf/panda.urdf",
        "ur10": "ur_description/urdf/ur10_robot.urdf",
        "so100": "so_arm_description/urdf/so100.urdf",
        "double_pendulum_continuous": "double_pendulum_description/urdf/double_pendulum_continuous.urdf",
        "talos": "talos_data/robots/talos_full_v2.urdf",
        "pr2": "pr2_description/urdf/pr2.urdf",
        "baxter": "baxter_description/urdf/baxter.urdf",
        "tiago": "tiago_description/robots/tiago.urdf",
        "kinova": "kinova_description/robots/kinova.urdf",
        "hyq": "hyq_description/robots/hyq_no_sensors.urdf",
    }
    # package://example-robot-data/robots/... resolves against the folder holding example-robot-data.
    return {
        "pinocchio_version": pin.__version__,
        "package_dir": str(share),
        "robots": {k: path(v) for k, v in robots.items()},
    }


def pin_config(model, joint_ids, values):
    q = pin.neutral(model)
    for jid, v in zip(joint_ids, values):
        jm = model.joints[jid]
        if jm.nq == 2:  # continuous joint: (cos, sin)
            q[jm.idx_q], q[jm.idx_q + 1] = np.cos(v), np.sin(v)
        else:
            q[jm.idx_q] = v
    return q


def find_frame(model, name, kind):
    wanted = {"link": [pin.FrameType.BODY], "joint": [pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT]}[kind]
    for i, f in enumerate(model.frames):
        if f.name == name and f.type in wanted:
            return i
    raise SystemExit(f"pin_reference: no {kind} frame named {name!r} in the Pinocchio model")


def kinematics(req):
    model = pin.buildModelFromUrdf(req["urdf"])
    data = model.createData()
    names = list(req["joints"])
    joint_ids = []
    for n in names:
        if not model.existJointName(n):
            raise SystemExit(f"pin_reference: joint {n!r} not in the Pinocchio model")
        joint_ids.append(model.getJointId(n))
    missing = set(model.names[1:]) - set(names)
    if missing:
        raise SystemExit(f"pin_reference: request does not give values for joints {sorted(missing)}")
    cols = [model.joints[j].idx_v for j in joint_ids]
    frames = [find_frame(model, f["name"], f["kind"]) for f in req["frames"]]
    out = []
    for values in req["q"]:
        q = pin_config(model, joint_ids, values)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for fid in frames:
            m = data.oMf[fid]
            jw = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:, cols]
            jl = pin.getFrameJacobian(model, data, fid, pin.LOCAL)[:, cols]
            # copies: Pinocchio returns views into `data`, which the next configuration overwrites
            out.extend([np.array(m.rotation).ravel(), np.array(m.translation), jw.ravel(), jl.ravel()])
    arr = np.concatenate(out) if out else np.zeros(0)
    arr.astype("<f8").tofile(req["output"])
    return {"configurations": len(req["q"]), "frames": len(frames), "values": int(arr.size),
            "pinocchio_version": pin.__version__}


def meshes(req):
    model = pin.buildModelFromUrdf(req["urdf"])
    geom = pin.buildGeomFromUrdf(model, req["urdf"], pin.GeometryType.COLLISION, package_dirs=[req["package_dir"]])
    out = []
    for obj in geom.geometryObjects:
        g = obj.geometry
        if not hasattr(g, "num_vertices") or g.num_vertices == 0:
            continue
        v = np.array(g.vertices())
        out.append({"name": obj.name, "frame": model.frames[obj.parentFrame].name, "vertices": int(len(v)),
                    "min": v.min(axis=0).tolist(), "max": v.max(axis=0).tolist()})
    return {"objects": out}


def main():
    commands = {"robots": lambda: erd_robots(), "kinematics": lambda: kinematics(json.load(sys.stdin)),
                "meshes": lambda: meshes(json.load(sys.stdin))}
    if len(sys.argv) != 2 or sys.argv[1] not in commands:
        raise SystemExit(__doc__)
    result = commands[sys.argv[1]]()
    json.dump(result, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
