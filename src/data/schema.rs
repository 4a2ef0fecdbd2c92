//! The dataset's layout and Parquet schema (version [`SCHEMA_VERSION`]).
//!
//! A dataset folder holds (names beside the parts start with `_` or `.`,
//! so pyarrow, Spark and friends read the folder itself as the dataset):
//! - `_dataset.json`: the run parameters ([`DatasetParameters`](super::DatasetParameters));
//!   re-running with other parameters into the same folder is refused.
//! - `part-NNNNN.parquet`: the accepted trajectories of ids
//!   `N·chunk … (N+1)·chunk − 1`, one row each, in id order, Snappy-compressed.
//!   The file's key-value metadata holds `tandem.schema_version`,
//!   `tandem.joints` (JSON list of the active joint names, the order of every
//!   joint-space column), `tandem.ee_frame` (the gripper frame of `ee_pose`,
//!   or empty), `tandem.horizon` (T), `tandem.ids` (JSON `[first, end)`) and
//!   `tandem.rejected` (JSON list of `{id, reason, detail}`: every id of the
//!   range is either a row or a rejection).
//! - `_manifest.json` (or `_manifest-shard-I-of-M.json` for `--shard I/M`):
//!   counts, rejections by reason, every part with its row count and
//!   SHA-256; see [`Manifest`](super::Manifest).
//! - `_timings/part-NNNNN.csv`: wall-clock times per id, the only output that
//!   depends on the machine (everything else is byte-identical across runs,
//!   thread counts and shardings).
//!
//! Trajectories hold T + 1 slices, the start first (q_0 … q_T), as every
//! trajectory tandem writes. Columns (n = number of active joints, T = horizon; poses are
//! `[x, y, z, qx, qy, qz, qw]` in the world frame, m and unit quaternion):
//!
//! | column | type | meaning |
//! | --- | --- | --- |
//! | `id` | u64 | sample id within the run |
//! | `seed` | u64 | seed of the sample's random stream, from (run seed, id) |
//! | `time_step` | f64 | seconds between slices |
//! | `start` | f64\[n\] | q_0, at rest |
//! | `goal_pose` | f64\[7\] or null | gripper target pose (grasp and pose goals) |
//! | `goal_joints` | f64\[n\] or null | target configuration (joint goals) |
//! | `object_names`, `object_shapes` | list\<str\> | graspable objects |
//! | `object_sizes` | list\<f64\[3\]\> | bounding-box edge lengths in the shape frame (m) |
//! | `object_poses` | list\<f64\[7\]\> | object poses |
//! | `obstacle_names`, `obstacle_shapes`, `obstacle_sizes`, `obstacle_poses` | as above | obstacles, table included |
//! | `q` | f64\[T+1\]\[n\] | q_0 … q_T (rad or m): the start, then the optimized slices |
//! | `qd` | f64\[T+1\]\[n\] | 0 at slice 0 (at rest), then (q_t − q_{t−1}) / time_step |
//! | `ee_pose` | f64\[T+1\]\[7\] or null | gripper frame poses at slices 0 … T |
//! | `outer_iterations`, `inner_steps`, `evaluations`, `plan_iterations` | u32 | solver and planner counts (of the accepted attempt) |
//! | `attempts` | u32 | IK + planning + optimization attempts it took (retries use other planner seeds) |
//! | `cost`, `eq_violation`, `ineq_violation` | f64 | optimizer report |
//! | `min_distance` | f64 | smallest signed distance over the slices (m) |
//! | `path_length` | f64 | joint-space length of q_0 … q_T (rad) |
//! | `goal_distance`, `goal_angle` | f64 | how far q_T is from the goal (m, rad) |
//! | `palm_clearance`, `finger_clearance` | f64 or null | grasp goals: smallest distance (m) at q_T between the target object and the palm, and the fingers' shapes other than their pads |
//! | `pad_distance` | f64 or null | grasp goals: the same for the finger pads (they may touch it) |
//! | `grasp_tilt` | f64 or null | grasp goals: angle (rad) at q_T between the gripper's approach axis and the grasp frame's |
//!
//! Version 2 (grasps a gripper can make): a grasp goal lets only the finger
//! pads near its target, the palm and the fingers' other shapes keep the
//! collision margin, and an accepted grasp has the object between the pads
//! and the fingertip centre within its footprint (`tandem::problem::grasp`);
//! the four grasp columns are new.
//!
//! ```python
//! import pyarrow.parquet as pq, numpy as np
//! t = pq.read_table("dataset")            # every part file of the folder
//! q = np.array(t["q"].to_pylist())         # (rows, T + 1, n), q[:, 0] the start
//! ```

use super::sample::{PlacedShape, TrajectoryRecord};
use crate::problem::GraspReport;
use arrow_array::builder::{FixedSizeListBuilder, Float64Builder, ListBuilder, StringBuilder};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, UInt32Array, UInt64Array};
use arrow_schema::{ArrowError, Field, Schema};
use std::sync::Arc;

/// Version of the layout above; bumped on any change to columns or metadata
/// (2: `q`, `qd` and `ee_pose` hold the start as slice 0; 3: the grasp
/// columns and grasp-judged acceptance).
pub const SCHEMA_VERSION: u32 = 3;

/// The rows of `records` (all with `joints` joints and `horizon + 1`
/// slices, the start first) as one Arrow record batch.
///
/// # Errors
/// Records of another shape than (`horizon + 1`, `joints`).
pub fn record_batch(records: &[&TrajectoryRecord], joints: usize, horizon: usize) -> Result<RecordBatch, ArrowError> {
    let slices = horizon + 1;
    if let Some(r) = records.iter().find(|r| r.q.len() != slices || r.q.iter().any(|q| q.len() != joints)) {
        return Err(ArrowError::InvalidArgumentError(format!(
            "trajectory {} is not {slices} slices (q_0 … q_T) of {joints} joints",
            r.id
        )));
    }
    let (n, t) = (width(joints), width(slices));
    let mut columns: Vec<(&str, ArrayRef, bool)> = vec![
        ("id", Arc::new(records.iter().map(|r| r.id).collect::<UInt64Array>()), false),
        ("seed", Arc::new(records.iter().map(|r| r.seed).collect::<UInt64Array>()), false),
        ("time_step", f64_column(records, |r| r.time_step), false),
        ("start", fixed(records.iter().map(|r| Some(r.start.as_slice())), n), false),
        ("goal_pose", fixed(records.iter().map(|r| r.goal_pose.as_ref().map(|p| p.as_slice())), 7), true),
        ("goal_joints", fixed(records.iter().map(|r| r.goal_joints.as_deref()), n), true),
    ];
    let object_names = ["object_names", "object_shapes", "object_sizes", "object_poses"];
    let obstacle_names = ["obstacle_names", "obstacle_shapes", "obstacle_sizes", "obstacle_poses"];
    columns.extend(shape_columns(records, object_names, |r| &r.objects));
    columns.extend(shape_columns(records, obstacle_names, |r| &r.obstacles));
    columns.push(("q", nested(records.iter().map(|r| Some(r.q.as_slice())), t, n), false));
    columns.push(("qd", nested(records.iter().map(|r| Some(r.qd.as_slice())), t, n), false));
    columns.push(("ee_pose", nested(records.iter().map(|r| r.ee_pose.as_deref()), t, 7), true));
    columns.extend(report_columns(records));
    let fields: Vec<Field> =
        columns.iter().map(|(name, array, nullable)| Field::new(*name, array.data_type().clone(), *nullable)).collect();
    let arrays = columns.into_iter().map(|(_, array, _)| array).collect();
    RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays)
}

fn width(n: usize) -> i32 {
    i32::try_from(n).unwrap_or(i32::MAX)
}

fn f64_column(records: &[&TrajectoryRecord], get: impl Fn(&TrajectoryRecord) -> f64) -> ArrayRef {
    Arc::new(records.iter().map(|r| get(r)).collect::<Float64Array>())
}

fn u32_column(records: &[&TrajectoryRecord], get: impl Fn(&TrajectoryRecord) -> u32) -> ArrayRef {
    Arc::new(records.iter().map(|r| get(r)).collect::<UInt32Array>())
}

/// Fixed-size lists of `size` values; `None` rows are null.
fn fixed<'a>(rows: impl Iterator<Item = Option<&'a [f64]>>, size: i32) -> ArrayRef {
    let mut b = FixedSizeListBuilder::new(Float64Builder::new(), size);
    for row in rows {
        match row {
            Some(values) => b.values().append_slice(values),
            None => b.values().append_nulls(size as usize),
        }
        b.append(row.is_some());
    }
    Arc::new(b.finish())
}

/// Fixed-size lists (`outer`) of fixed-size lists (`inner`); `None` rows are null.
fn nested<'a, R: AsRef<[f64]> + 'a>(rows: impl Iterator<Item = Option<&'a [R]>>, outer: i32, inner: i32) -> ArrayRef {
    let mut b = FixedSizeListBuilder::new(FixedSizeListBuilder::new(Float64Builder::new(), inner), outer);
    for row in rows {
        for k in 0..outer as usize {
            let item = row.and_then(|items| items.get(k));
            match item {
                Some(values) => b.values().values().append_slice(values.as_ref()),
                None => b.values().values().append_nulls(inner as usize),
            }
            b.values().append(item.is_some());
        }
        b.append(row.is_some());
    }
    Arc::new(b.finish())
}

/// The names, shapes, sizes and poses columns of placed shapes, named `names`.
fn shape_columns(
    records: &[&TrajectoryRecord],
    names_of_columns: [&'static str; 4],
    get: impl Fn(&TrajectoryRecord) -> &[PlacedShape],
) -> Vec<(&'static str, ArrayRef, bool)> {
    let mut names = ListBuilder::new(StringBuilder::new());
    let mut shapes = ListBuilder::new(StringBuilder::new());
    let mut sizes = ListBuilder::new(FixedSizeListBuilder::new(Float64Builder::new(), 3));
    let mut poses = ListBuilder::new(FixedSizeListBuilder::new(Float64Builder::new(), 7));
    for r in records {
        for s in get(r) {
            names.values().append_value(&s.name);
            shapes.values().append_value(s.shape);
            sizes.values().values().append_slice(&s.size);
            sizes.values().append(true);
            poses.values().values().append_slice(&s.pose);
            poses.values().append(true);
        }
        names.append(true);
        shapes.append(true);
        sizes.append(true);
        poses.append(true);
    }
    let [n, sh, si, po] = names_of_columns;
    vec![
        (n, Arc::new(names.finish()) as ArrayRef, false),
        (sh, Arc::new(shapes.finish()), false),
        (si, Arc::new(sizes.finish()), false),
        (po, Arc::new(poses.finish()), false),
    ]
}

fn report_columns(records: &[&TrajectoryRecord]) -> Vec<(&'static str, ArrayRef, bool)> {
    vec![
        ("outer_iterations", u32_column(records, |r| r.report.outer_iterations), false),
        ("inner_steps", u32_column(records, |r| r.report.inner_steps), false),
        ("evaluations", u32_column(records, |r| r.report.evaluations), false),
        ("plan_iterations", u32_column(records, |r| r.report.plan_iterations), false),
        ("attempts", u32_column(records, |r| r.report.attempts), false),
        ("cost", f64_column(records, |r| r.report.cost), false),
        ("eq_violation", f64_column(records, |r| r.report.eq_violation), false),
        ("ineq_violation", f64_column(records, |r| r.report.ineq_violation), false),
        ("min_distance", f64_column(records, |r| r.report.min_distance), false),
        ("path_length", f64_column(records, |r| r.report.path_length), false),
        ("goal_distance", f64_column(records, |r| r.report.goal_miss.distance), false),
        ("goal_angle", f64_column(records, |r| r.report.goal_miss.angle), false),
        ("palm_clearance", grasp_column(records, |g| g.palm_clearance), true),
        ("finger_clearance", grasp_column(records, |g| g.finger_clearance), true),
        ("pad_distance", grasp_column(records, |g| g.pad_distance), true),
        ("grasp_tilt", grasp_column(records, |g| g.tilt), true),
    ]
}

/// A value of each record's grasp report; null without one.
fn grasp_column(records: &[&TrajectoryRecord], get: impl Fn(&GraspReport) -> f64) -> ArrayRef {
    Arc::new(records.iter().map(|r| r.grasp.as_ref().map(&get)).collect::<Float64Array>())
}
