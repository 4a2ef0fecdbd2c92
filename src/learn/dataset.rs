//! Demonstrations from a dataset folder (`tandem generate`'s Parquet
//! parts, schema of [`crate::data::schema`]) or from expert solves in
//! memory, and the state-action pairs the network learns from.

use super::LearnError;
use super::features::{GoalFeatures, ObstacleFeature, encode, input_width};
use crate::data::TrajectoryRecord;
use crate::robot::{FrameId, KinematicsWorkspace, RobotModel};
use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, UInt64Type};
use arrow_array::{Array, RecordBatch};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::{Path, PathBuf};

/// One optimized trajectory: the task's goal and obstacles, and its
/// configurations `q_0 … q_T` (the start, at rest, first).
#[derive(Debug, Clone, PartialEq)]
pub struct Demonstration {
    /// Sample id (train/validation split by id).
    pub id: u64,
    /// Seconds between slices.
    pub time_step: f64,
    /// Gripper goal pose `[x, y, z, qx, qy, qz, qw]` (m, world).
    pub goal_pose: [f64; 7],
    /// Every obstacle of the task, by name (static ones included).
    pub obstacles: Vec<(String, ObstacleFeature)>,
    /// `q_0 … q_T`.
    pub states: Vec<Vec<f64>>,
}

impl Demonstration {
    /// The demonstration of an accepted dataset record (`None` without a
    /// goal pose: joint goals are not learned).
    pub fn from_record(record: &TrajectoryRecord) -> Option<Demonstration> {
        let goal_pose = record.goal_pose?;
        let mut states = Vec::with_capacity(record.q.len() + 1);
        states.push(record.start.clone());
        states.extend(record.q.iter().cloned());
        let obstacles = record.obstacles.iter().map(|o| (o.name.clone(), obstacle_feature(&o.pose, &o.size))).collect();
        Some(Demonstration { id: record.id, time_step: record.time_step, goal_pose, obstacles, states })
    }

    /// The goal features, with the obstacles not named in `static_obstacles`
    /// in the first `slots` slots.
    pub fn goal(&self, static_obstacles: &[String], slots: usize) -> GoalFeatures {
        let obstacles =
            self.obstacles.iter().filter(|(name, _)| !static_obstacles.contains(name)).take(slots).map(|(_, o)| *o);
        GoalFeatures::from_pose_array(&self.goal_pose, obstacles.collect())
    }
}

fn obstacle_feature(pose: &[f64; 7], size: &[f64; 3]) -> ObstacleFeature {
    ObstacleFeature { center: [pose[0], pose[1], pose[2]], size: *size }
}

/// Demonstrations and the joint order of their configurations.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Demonstrations {
    pub joints: Vec<String>,
    pub items: Vec<Demonstration>,
}

impl Demonstrations {
    /// Reads every `part-*.parquet` of a dataset folder, in name order.
    ///
    /// # Errors
    /// A missing folder or one without parts, unreadable Parquet, another
    /// schema version, parts with different joints, a missing column or
    /// one of the wrong type (named with the file).
    pub fn read(dir: &Path) -> Result<Demonstrations, LearnError> {
        let entries = std::fs::read_dir(dir).map_err(|source| LearnError::Io { path: dir.to_path_buf(), source })?;
        let mut parts: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                name.starts_with("part-") && name.ends_with(".parquet")
            })
            .collect();
        parts.sort();
        if parts.is_empty() {
            return Err(LearnError::Dataset {
                path: dir.to_path_buf(),
                message: "no part-*.parquet files (write one with `tandem generate`)".into(),
            });
        }
        let mut all = Demonstrations::default();
        for part in &parts {
            let (joints, items) = read_part(part)?;
            if all.joints.is_empty() {
                all.joints = joints;
            } else if all.joints != joints {
                return Err(LearnError::Dataset {
                    path: part.clone(),
                    message: format!("joints {joints:?} differ from the first part's {:?}", all.joints),
                });
            }
            all.items.extend(items);
        }
        Ok(all)
    }

    /// State-action pairs for `robot`, conditioned as a network with
    /// `static_obstacles` and `slots` sees them, of the demonstrations
    /// `keep` selects (by id).
    ///
    /// # Errors
    /// Joints other than the robot's; an unknown gripper frame.
    pub fn pairs(
        &self,
        robot: &RobotModel,
        gripper: &str,
        static_obstacles: &[String],
        slots: usize,
        keep: impl Fn(u64) -> bool,
    ) -> Result<Pairs, LearnError> {
        if robot.joint_names() != self.joints.as_slice() {
            return Err(LearnError::Mismatch {
                what: "dataset joints".into(),
                expected: robot.joint_names().join(", "),
                got: self.joints.join(", "),
            });
        }
        let frame = robot.frame_id(gripper).map_err(|_| LearnError::Mismatch {
            what: "gripper frame".into(),
            expected: gripper.into(),
            got: "a robot without it".into(),
        })?;
        let mut pairs = Pairs::new(robot.nq(), slots);
        let mut ws = KinematicsWorkspace::new(robot);
        for d in self.items.iter().filter(|d| keep(d.id)) {
            pairs.add(robot, frame, &mut ws, d, &d.goal(static_obstacles, slots))?;
        }
        Ok(pairs)
    }
}

/// Inputs and targets: for each state `q_t` of a demonstration, the input
/// of [`encode`] and the velocity `(q_{t+1} − q_t)/Δt` as its unit direction
/// and its norm (rad/s); the last state's velocity is zero.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pairs {
    pub input_width: usize,
    pub dof: usize,
    /// Row-major `len × input_width`.
    pub inputs: Vec<f32>,
    /// Row-major `len × dof` unit directions (zero where the velocity is).
    pub directions: Vec<f32>,
    /// Speeds (rad/s).
    pub speeds: Vec<f32>,
    /// Demonstrations added.
    pub trajectories: usize,
}

impl Pairs {
    fn new(dof: usize, slots: usize) -> Pairs {
        Pairs { input_width: input_width(dof, slots), dof, ..Pairs::default() }
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.speeds.len()
    }

    pub fn is_empty(&self) -> bool {
        self.speeds.is_empty()
    }

    fn add(
        &mut self,
        robot: &RobotModel,
        gripper: FrameId,
        ws: &mut KinematicsWorkspace,
        d: &Demonstration,
        goal: &GoalFeatures,
    ) -> Result<(), LearnError> {
        let slots = (self.input_width - 12 - self.dof) / super::features::OBSTACLE_FEATURES;
        let mut row = vec![0.0f32; self.input_width];
        for (t, q) in d.states.iter().enumerate() {
            robot.forward_kinematics(ws, q).map_err(|e| LearnError::Dataset {
                path: PathBuf::from(format!("demonstration {}", d.id)),
                message: e.to_string(),
            })?;
            let p: [f64; 3] = robot.frame_pose(ws, gripper).translation.vector.into();
            encode(&mut row, &p, goal, q, slots);
            self.inputs.extend_from_slice(&row);
            let velocity: Vec<f64> = match d.states.get(t + 1) {
                Some(next) => next.iter().zip(q).map(|(b, a)| (b - a) / d.time_step).collect(),
                None => vec![0.0; self.dof],
            };
            let speed = velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
            let inverse = if speed > 0.0 { 1.0 / speed } else { 0.0 };
            self.directions.extend(velocity.iter().map(|v| (v * inverse) as f32));
            self.speeds.push(speed as f32);
        }
        self.trajectories += 1;
        Ok(())
    }

    /// Appends `other` (same widths).
    pub fn extend(&mut self, other: &Pairs) {
        self.inputs.extend_from_slice(&other.inputs);
        self.directions.extend_from_slice(&other.directions);
        self.speeds.extend_from_slice(&other.speeds);
        self.trajectories += other.trajectories;
    }
}

/// Whether sample `id` belongs to the validation share `fraction` (a hash
/// of the id, so the split does not depend on file order or count).
pub fn in_validation(id: u64, fraction: f64) -> bool {
    let h = crate::scene::sample_seed(0x5EED_5EED, id);
    (h >> 11) as f64 / (1u64 << 53) as f64 <= fraction && fraction > 0.0
}

fn column_error(path: &Path, column: &str, message: &str) -> LearnError {
    LearnError::Dataset { path: path.to_path_buf(), message: format!("column `{column}`: {message}") }
}

fn read_part(path: &Path) -> Result<(Vec<String>, Vec<Demonstration>), LearnError> {
    let parquet_error = |e: &dyn std::fmt::Display| LearnError::Dataset { path: path.into(), message: e.to_string() };
    let file = std::fs::File::open(path).map_err(|source| LearnError::Io { path: path.into(), source })?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| parquet_error(&e))?;
    let meta = builder.metadata().file_metadata().key_value_metadata().cloned().unwrap_or_default();
    let value = |key: &str| meta.iter().find(|kv| kv.key == key).and_then(|kv| kv.value.clone());
    let version = value("tandem.schema_version").unwrap_or_default();
    if version != crate::data::schema::SCHEMA_VERSION.to_string() {
        return Err(LearnError::Dataset {
            path: path.into(),
            message: format!(
                "schema version {version:?}, this build reads {} (regenerate the dataset)",
                crate::data::schema::SCHEMA_VERSION
            ),
        });
    }
    let joints: Vec<String> = serde_json::from_str(&value("tandem.joints").unwrap_or_default())
        .map_err(|e| LearnError::Dataset { path: path.into(), message: format!("tandem.joints: {e}") })?;
    let reader = builder.build().map_err(|e| parquet_error(&e))?;
    let mut items = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|e| parquet_error(&e))?;
        read_batch(path, &batch, joints.len(), &mut items)?;
    }
    Ok((joints, items))
}

fn f64_values<'a>(path: &Path, column: &str, array: &'a dyn Array) -> Result<&'a [f64], LearnError> {
    array
        .as_primitive_opt::<Float64Type>()
        .map(|a| a.values().as_ref())
        .ok_or_else(|| column_error(path, column, "expected f64 values"))
}

/// The flat f64 values of row `r` of a (nested) fixed-size list column.
fn row_values(path: &Path, column: &str, array: &dyn Array, r: usize, depth: usize) -> Result<Vec<f64>, LearnError> {
    let list =
        array.as_fixed_size_list_opt().ok_or_else(|| column_error(path, column, "expected a fixed-size list"))?;
    if list.is_null(r) {
        return Err(column_error(path, column, &format!("row {r} is null")));
    }
    let row = list.value(r);
    if depth == 1 {
        return Ok(f64_values(path, column, row.as_ref())?.to_vec());
    }
    let inner = row.as_fixed_size_list_opt().ok_or_else(|| column_error(path, column, "expected nested lists"))?;
    Ok(f64_values(path, column, inner.values().as_ref())?.to_vec())
}

fn read_batch(path: &Path, batch: &RecordBatch, n: usize, items: &mut Vec<Demonstration>) -> Result<(), LearnError> {
    let column = |name: &str| batch.column_by_name(name).ok_or_else(|| column_error(path, name, "missing"));
    let ids = column("id")?.as_primitive_opt::<UInt64Type>().ok_or_else(|| column_error(path, "id", "expected u64"))?;
    let time_steps = f64_values(path, "time_step", column("time_step")?.as_ref())?;
    let names = column("obstacle_names")?;
    let names = names.as_list_opt::<i32>().ok_or_else(|| column_error(path, "obstacle_names", "expected a list"))?;
    let sizes = column("obstacle_sizes")?;
    let sizes = sizes.as_list_opt::<i32>().ok_or_else(|| column_error(path, "obstacle_sizes", "expected a list"))?;
    let poses = column("obstacle_poses")?;
    let poses = poses.as_list_opt::<i32>().ok_or_else(|| column_error(path, "obstacle_poses", "expected a list"))?;
    let (start, goal, q) = (column("start")?, column("goal_pose")?, column("q")?);
    for r in 0..batch.num_rows() {
        let goal_list =
            goal.as_fixed_size_list_opt().ok_or_else(|| column_error(path, "goal_pose", "expected a list"))?;
        if goal_list.is_null(r) {
            continue; // joint goals: nothing to condition on
        }
        let goal_pose: [f64; 7] = row_values(path, "goal_pose", goal.as_ref(), r, 1)?
            .try_into()
            .map_err(|_| column_error(path, "goal_pose", "expected 7 values"))?;
        let start = row_values(path, "start", start.as_ref(), r, 1)?;
        let flat = row_values(path, "q", q.as_ref(), r, 2)?;
        if start.len() != n || flat.is_empty() || flat.len() % n != 0 {
            return Err(column_error(path, "q", &format!("row {r} is not a whole number of {n}-joint configurations")));
        }
        let mut states = vec![start];
        states.extend(flat.chunks_exact(n).map(<[f64]>::to_vec));
        let row_names = names.value(r);
        let row_names =
            row_names.as_string_opt::<i32>().ok_or_else(|| column_error(path, "obstacle_names", "expected strings"))?;
        let (row_sizes, row_poses) = (sizes.value(r), poses.value(r));
        let mut obstacles = Vec::with_capacity(row_names.len());
        for k in 0..row_names.len() {
            let size = row_values(path, "obstacle_sizes", row_sizes.as_ref(), k, 1)?;
            let pose = row_values(path, "obstacle_poses", row_poses.as_ref(), k, 1)?;
            let (Ok(size), Ok(pose)) = (<[f64; 3]>::try_from(size), <[f64; 7]>::try_from(pose)) else {
                return Err(column_error(path, "obstacle_poses", &format!("row {r}: obstacle {k} is malformed")));
            };
            obstacles.push((row_names.value(k).to_string(), obstacle_feature(&pose, &size)));
        }
        let time_step = time_steps[r];
        if !(time_step.is_finite() && time_step > 0.0) {
            return Err(column_error(path, "time_step", &format!("row {r}: {time_step} s")));
        }
        items.push(Demonstration { id: ids.value(r), time_step, goal_pose, obstacles, states });
    }
    Ok(())
}
