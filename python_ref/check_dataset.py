"""Reads a dataset written by `tandem generate` with pyarrow and checks it
independently of tandem: Pinocchio does the kinematics.

    python check_dataset.py DATASET_DIR URDF

Checks, for every part file listed in _manifest.json:
- pyarrow reads the folder as one dataset;
- the file's SHA-256 and row count match the manifest, and rows + rejections
  cover the part's id range exactly once (ids ascending);
- shapes: q, qd and ee_pose are (rows, T + 1, n) / (rows, T + 1, 7) (the
  start is slice 0), start is (rows, n) and equals q[:, 0];
- q stays within the URDF's joint limits (1e-9 rad);
- qd is 0 at slice 0 and the backward differences of q / time_step after;
- ee_pose equals Pinocchio's placement of the gripper frame at every slice;
- q_T reaches the goal: the gripper position within the run's goal
  tolerance of goal_pose, its z axis along goal_pose's z axis within the
  angle tolerance.
Prints one JSON object with the counts and largest errors; exits 1 with a
message on the first failed check.
"""

import glob
import hashlib
import json
import math
import os
import sys

import numpy as np
import pinocchio as pin
import pyarrow.parquet as pq


def fail(message):
    sys.stderr.write(f"check_dataset: {message}\n")
    sys.exit(1)


def worse(a, b):
    """The larger of two errors, NaN when either is (the builtin max drops a NaN)."""
    return float("nan") if math.isnan(a) or math.isnan(b) else max(a, b)


def quat_to_matrix(xyzw):
    x, y, z, w = xyzw
    return pin.Quaternion(w, x, y, z).toRotationMatrix()


def main(folder, urdf):
    manifest = json.load(open(os.path.join(folder, "_manifest.json")))
    params = manifest["parameters"]
    joints = manifest["joints"]
    ee_frame = manifest["ee_frame"]
    model = pin.buildModelFromUrdf(urdf)
    data = model.createData()
    index = [model.idx_qs[model.getJointId(name)] for name in joints]
    lower = model.lowerPositionLimit[index]
    upper = model.upperPositionLimit[index]
    frame = model.getFrameId(ee_frame)
    base_q = pin.neutral(model)
    worst = {"limit": 0.0, "qd": 0.0, "ee_pose": 0.0, "goal_distance": 0.0, "goal_angle": 0.0}
    rows_total, rejected_total = 0, 0
    listed = sorted(p["file"] for p in manifest["parts"])
    on_disk = sorted(os.path.basename(p) for p in glob.glob(os.path.join(folder, "part-*.parquet")))
    if listed != on_disk:
        fail(f"manifest lists {listed}, the folder holds {on_disk}")
    for part in manifest["parts"]:
        path = os.path.join(folder, part["file"])
        digest = hashlib.sha256(open(path, "rb").read()).hexdigest()
        if digest != part["sha256"]:
            fail(f"{part['file']}: SHA-256 {digest} differs from the manifest's")
        meta = pq.read_metadata(path).metadata
        rejected = json.loads(meta[b"tandem.rejected"])
        table = pq.read_table(path)
        ids = table["id"].to_numpy()
        covered = sorted(list(ids) + [r["id"] for r in rejected])
        if covered != list(range(*part["ids"])) or list(ids) != sorted(ids):
            fail(f"{part['file']}: ids do not cover {part['ids']} exactly once, in order")
        if table.num_rows != part["rows"]:
            fail(f"{part['file']}: {table.num_rows} rows, the manifest says {part['rows']}")
        rows_total += table.num_rows
        rejected_total += len(rejected)
        if table.num_rows == 0:
            continue
        T, n = params["horizon"], len(joints)
        q = np.array(table["q"].to_pylist())
        qd = np.array(table["qd"].to_pylist())
        ee = np.array(table["ee_pose"].to_pylist())
        start = np.array(table["start"].to_pylist())
        goal = np.array(table["goal_pose"].to_pylist())
        dt = table["time_step"].to_numpy()
        rows = table.num_rows
        slices = T + 1
        if q.shape != (rows, slices, n) or qd.shape != (rows, slices, n) or ee.shape != (rows, slices, 7) or start.shape != (rows, n):
            fail(f"{part['file']}: shapes q {q.shape}, qd {qd.shape}, ee_pose {ee.shape}, start {start.shape}")
        if not np.array_equal(q[:, 0], start):
            fail(f"{part['file']}: q[:, 0] is not the start")
        worst["limit"] = worse(worst["limit"], float(np.max(np.maximum(lower - q, q - upper))))
        worst["qd"] = worse(worst["qd"], float(np.max(np.abs(qd[:, 0]))))
        worst["qd"] = worse(worst["qd"], float(np.max(np.abs(np.diff(q, axis=1) / dt[:, None, None] - qd[:, 1:]))))
        for r in range(rows):
            for t in range(slices):
                qq = base_q.copy()
                qq[index] = q[r, t]
                pin.framesForwardKinematics(model, data, qq)
                placement = data.oMf[frame]
                err_p = np.linalg.norm(placement.translation - ee[r, t, :3])
                err_r = np.linalg.norm(placement.rotation - quat_to_matrix(ee[r, t, 3:]))
                worst["ee_pose"] = worse(worse(worst["ee_pose"], float(err_p)), float(err_r))
            target_z = quat_to_matrix(goal[r, 3:])[:, 2]
            final_z = placement.rotation[:, 2]
            worst["goal_distance"] = worse(worst["goal_distance"], float(np.linalg.norm(placement.translation - goal[r, :3])))
            angle = float(np.arccos(np.clip(final_z @ target_z, -1.0, 1.0)))
            worst["goal_angle"] = worse(worst["goal_angle"], angle)
    # The folder itself is a dataset: the files beside the parts start with "_".
    whole = pq.read_table(folder)
    if whole.num_rows != rows_total:
        fail(f"pq.read_table(folder) reads {whole.num_rows} rows, the parts hold {rows_total}")
    if rows_total != manifest["accepted"] or rejected_total != manifest["rejected"]:
        fail(f"rows {rows_total} / rejections {rejected_total} differ from the manifest")
    # `not x <= tol`: a NaN error fails.
    if not worst["limit"] <= 1e-9:
        fail(f"q leaves the joint limits by {worst['limit']:.3e}")
    if not worst["qd"] <= 1e-9:
        fail(f"qd differs from the differences of q by {worst['qd']:.3e}")
    if not worst["ee_pose"] <= 1e-9:
        fail(f"ee_pose differs from Pinocchio's by {worst['ee_pose']:.3e}")
    if not (worst["goal_distance"] <= params["goal_tolerance"] and worst["goal_angle"] <= params["goal_angle_tolerance"]):
        fail(f"q_T misses the goal by {worst['goal_distance']:.3e} m, {worst['goal_angle']:.3e} rad")
    print(json.dumps({"rows": rows_total, "rejected": rejected_total, "worst": worst}))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        fail("usage: check_dataset.py DATASET_DIR URDF")
    main(sys.argv[1], sys.argv[2])
