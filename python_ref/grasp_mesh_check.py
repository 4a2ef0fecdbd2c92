#!/usr/bin/env python3
"""Judges Panda grasps with example-robot-data's (erd) collision meshes through coal,
independently of tandem's sphere model, for tandem's grasp tests and benches.

Usage:
  grasp_mesh_check.py < request.json
  grasp_mesh_check.py --dataset DIR [--object NAME] [--margin M] [--slices final|all]
      the final slice (q_T) of every trajectory of a `tandem generate` dataset, grasping
      its object NAME (default: its only object) with the fingers open at 0.04 m, margin M
      (default 0.005 m); prints the same summary without the per-grasp list unless a
      grasp fails (then the failing ones, with their ids). With `--slices all`, also the
      clearances at every slice q_1 ... q_T ("motion": hand, fingers' outer parts and arm
      must keep the margin there too; the pads are reported, they may come close).

Request:
  {"joints": [the 7 arm joint names, the order of each q],
   "finger": opening of each finger (m, panda_finger_joint1/2; default 0.04),
   "margin": clearance the palm and the fingers' outer parts must keep (m),
   "pad_depth": thickness of the fingers' contact layer (m; default 0.005),
   "grasps": [{"q": [7 values], "box": {"half_extents": [3], "translation": [3],
               "rotation": [[3] x 3]}, "final": true}]}
  A grasp with "final": false is a configuration on the way: only the clearances count.

Geometry (erd's, placed by Pinocchio's forward kinematics of erd's panda.urdf, whose
frames agree with tandem's embedded Panda to 0 m, see problems/robots/panda/README.md):
  - hand: meshes/collision/hand.stl (convex: its hull is itself);
  - arm: meshes/collision/link0..7.stl, as convex hulls (conservative);
  - each finger: finger.stl and erd's four finger collision boxes, split at the plane
    `pad_depth` from the finger's inner face (the face towards the other finger): the
    inner layer is the contact surface (pads), the rest the finger's outer part. Each
    piece is convex, so each part is the hull of its clipped vertices.
Signed distances come from coal (GJK/EPA, tightened tolerances) against the target box.

Per grasp the output holds
  hand, arm, finger_outer, pad: smallest signed distance (m) to the box of the hand, the
      arm links (link0..link7), the fingers' outer parts, the pads;
  between_pads: the segment joining the centres of the two rubber-tip inner faces
      (finger frame (0, 0, 45.25 mm)) crosses the box: closing the fingers meets it;
  in_footprint: the fingertip centre (panda_hand_tcp) lies within the box's footprint
      (|x|, |y| within the half extents in the box frame);
  tilt: angle (rad) between panda_hand_tcp's z axis and the world's -z;
  ok: hand and finger_outer >= margin, arm >= margin, pad >= 0, between_pads, in_footprint.
Prints {"coal_version", "grasps": [...], "worst": {...}} as JSON on stdout.
"""
import json
import sys
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_panda_urdf import ERD_COLLISION, ERD_URDF, clip_convex, link_solids, read_stl  # noqa: E402

PAD_CENTER = np.array([0.0, 0.0, 45.25e-3])  # centre of the rubber tip's inner face, left finger frame


def convex(tris_or_points) -> coal.Convex:
    pts = coal.StdVec_Vec3s()
    for p in np.unique(np.asarray(tris_or_points, dtype=float).reshape(-1, 3), axis=0):
        pts.append(p)
    return coal.Convex.convexHull(pts, False, None)


def finger_parts(pad_depth):
    """(outer pieces, pad pieces) of the left finger as coal convexes in its frame; the right
    finger is the left one turned by pi about z (erd's convention)."""
    pieces = link_solids()["panda_leftfinger"]
    inward = np.array([0.0, 1.0, 0.0])
    pads = [c for t in pieces if (c := clip_convex(t, inward, pad_depth)) is not None]
    outer = [c for t in pieces if (c := clip_convex(t, -inward, -pad_depth)) is not None]
    return [convex(c) for c in outer], [convex(c) for c in pads]


def segment_crosses_box(a, b, half):
    """Slab test: does the segment a->b (box frame) meet the box [-half, half]?"""
    lo, hi = 0.0, 1.0
    d = b - a
    for i in range(3):
        if abs(d[i]) < 1e-15:
            if abs(a[i]) > half[i]:
                return False
            continue
        t0, t1 = sorted(((-half[i] - a[i]) / d[i], (half[i] - a[i]) / d[i]))
        lo, hi = max(lo, t0), min(hi, t1)
        if lo > hi:
            return False
    return True


def main(req):
    model = pin.buildModelFromUrdf(str(ERD_URDF))
    data = model.createData()
    names = list(req["joints"])
    finger = float(req.get("finger", 0.04))
    margin = float(req["margin"])
    pad_depth = float(req.get("pad_depth", 0.005))
    frame = {n: model.getFrameId(n) for n in ("panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_hand_tcp")}
    hand = convex(read_stl(ERD_COLLISION / "hand.stl"))
    arm = [(model.getFrameId(f"panda_link{i}"), convex(read_stl(ERD_COLLISION / f"link{i}.stl"))) for i in range(8)]
    outer, pads = finger_parts(pad_depth)
    turn = pin.SE3(pin.utils.rotate("z", np.pi), np.zeros(3))  # right finger = left turned by pi
    request = coal.DistanceRequest()
    request.enable_signed_distance = True
    request.gjk_tolerance = 1e-10
    request.epa_tolerance = 1e-8
    request.gjk_max_iterations = 1000
    request.epa_max_iterations = 1000

    def distance(shape, pose, box, box_pose):
        result = coal.DistanceResult()
        coal.distance(shape, coal.Transform3s(pose.rotation, pose.translation), box, box_pose, request, result)
        return result.min_distance

    out = []
    for g in req["grasps"]:
        q = pin.neutral(model)
        for n, v in zip(names, g["q"]):
            q[model.idx_qs[model.getJointId(n)]] = v
        for n in ("panda_finger_joint1", "panda_finger_joint2"):
            q[model.idx_qs[model.getJointId(n)]] = finger
        pin.framesForwardKinematics(model, data, q)
        placed = {n: data.oMf[f] for n, f in frame.items()}
        half = np.array(g["box"]["half_extents"], dtype=float)
        R, t = np.array(g["box"]["rotation"], dtype=float), np.array(g["box"]["translation"], dtype=float)
        box, box_pose = coal.Box(*(2 * half)), coal.Transform3s(R, t)
        fingers = [placed["panda_leftfinger"], placed["panda_rightfinger"] * turn]
        res = {
            "hand": distance(hand, placed["panda_hand"], box, box_pose),
            "arm": min(distance(s, data.oMf[f], box, box_pose) for f, s in arm),
            "finger_outer": min(distance(s, M, box, box_pose) for M in fingers for s in outer),
            "pad": min(distance(s, M, box, box_pose) for M in fingers for s in pads),
        }
        ends = [R.T @ (M.act(PAD_CENTER) - t) for M in fingers]
        res["between_pads"] = bool(segment_crosses_box(ends[0], ends[1], half))
        tcp = placed["panda_hand_tcp"]
        local = R.T @ (tcp.translation - t)
        res["in_footprint"] = bool(abs(local[0]) <= half[0] and abs(local[1]) <= half[1])
        res["tilt"] = float(np.arccos(np.clip(-tcp.rotation[2, 2], -1.0, 1.0)))
        clear = res["hand"] >= margin and res["finger_outer"] >= margin and res["arm"] >= margin
        res["final"] = bool(g.get("final", True))
        res["ok"] = bool(clear and (not res["final"] or (res["pad"] >= 0.0 and res["between_pads"] and res["in_footprint"])))
        out.append(res)
    finals = [r for r in out if r["final"]]
    worst = {k: min(r[k] for r in finals) for k in ("hand", "arm", "finger_outer", "pad")} if finals else {}
    worst["tilt"] = max((r["tilt"] for r in finals), default=0.0)
    worst["failed"] = sum(not r["ok"] for r in out)
    summary = {"coal_version": coal.__version__, "grasps": out, "worst": worst}
    if len(finals) < len(out):
        summary["worst_motion"] = {k: min(r[k] for r in out) for k in ("hand", "arm", "finger_outer", "pad")}
    return summary


def dataset_request(folder, object_name, margin, every_slice=False):
    """A request of the final slices (or every slice) of a dataset's trajectories, and their ids."""
    import pyarrow.parquet as pq

    manifest = json.load(open(Path(folder) / "_manifest.json"))
    table = pq.read_table(folder)
    grasps, ids = [], []
    for row in table.select(["id", "q", "object_names", "object_sizes", "object_poses"]).to_pylist():
        names = row["object_names"]
        k = names.index(object_name) if object_name else 0
        if not object_name and len(names) != 1:
            raise SystemExit(f"sample {row['id']} has objects {names}: name the grasped one with --object")
        x, y, z, qx, qy, qz, qw = row["object_poses"][k]
        rotation = pin.Quaternion(qw, qx, qy, qz).toRotationMatrix()
        box = {"half_extents": [v / 2 for v in row["object_sizes"][k]], "translation": [x, y, z],
               "rotation": rotation.tolist()}
        slices = row["q"] if every_slice else row["q"][-1:]
        for k, q in enumerate(slices):
            grasps.append({"q": q, "box": box, "final": k == len(slices) - 1})
            ids.append(row["id"])
    return {"joints": manifest["joints"], "margin": margin, "grasps": grasps}, ids


if __name__ == "__main__":
    args = sys.argv[1:]
    if not args:
        json.dump(main(json.load(sys.stdin)), sys.stdout)
    elif args[0] == "--dataset" and len(args) >= 2:
        opts = dict(zip(args[2::2], args[3::2]))
        every = {"final": False, "all": True}[opts.get("--slices", "final")]
        req, ids = dataset_request(args[1], opts.get("--object"), float(opts.get("--margin", 0.005)), every)
        res = main(req)
        failed = [dict(id=i, **g) for i, g in zip(ids, res.pop("grasps")) if not g["ok"]]
        res["count"] = len(set(ids))
        res["configurations"] = len(ids)
        if failed:
            res["failed_grasps"] = failed
        json.dump(res, sys.stdout)
        sys.exit(1 if failed else 0)
    else:
        raise SystemExit(__doc__)
