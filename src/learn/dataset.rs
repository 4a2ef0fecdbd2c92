//! Demonstrations from a dataset folder (`tandem generate`'s Parquet
//! parts, schema of [`crate::data::schema`]) or from expert solves in
//! memory, and the state-action pairs the network learns from.

use super::LearnError;
use super::features::{
    GoalFeatures, InputFrames, MAX_OBSTACLE_FRAMES, ObstacleFeature, Placement, encode, input_width,
};
use crate::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use crate::data::TrajectoryRecord;
use crate::robot::{KinematicsWorkspace, RobotModel};
use crate::trajectory::JointTrajectory;
use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, UInt64Type};
use arrow_array::{Array, RecordBatch};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
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
        // q_0 … q_T, the start first (schema version 2 on).
        let states = record.q.clone();
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
    /// Joint names, in the order of the configurations.
    pub joints: Vec<String>,
    /// The trajectories, in file and row order.
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
    /// `view` sees them, of the demonstrations `keep` selects (by id),
    /// with `augment` perturbed states per state. Built in parallel,
    /// concatenated in demonstration order.
    ///
    /// # Errors
    /// Joints other than the robot's; an unknown gripper or obstacle
    /// frame, more than [`MAX_OBSTACLE_FRAMES`]; a demonstration the
    /// tracking policy rejects.
    pub fn pairs(
        &self,
        robot: &RobotModel,
        view: &InputView,
        augment: &Augmentation,
        keep: impl Fn(u64) -> bool + Sync,
    ) -> Result<Pairs, LearnError> {
        if robot.joint_names() != self.joints.as_slice() {
            return Err(LearnError::Mismatch {
                what: "dataset joints".into(),
                expected: robot.joint_names().join(", "),
                got: self.joints.join(", "),
            });
        }
        let frames = InputFrames::resolve(robot, view.gripper, view.frames)?;
        let (slots, width) = (view.slots, input_width(robot.nq(), view.slots, view.frames.len()));
        let parts: Vec<Pairs> = self
            .items
            .par_iter()
            .filter(|d| keep(d.id))
            .map(|d| {
                let mut pairs = Pairs::new(robot.nq(), width);
                let mut ws = KinematicsWorkspace::new(robot);
                let goal = d.goal(view.static_obstacles, slots);
                let mut at = Robot { model: robot, frames: &frames, ws: &mut ws, slots };
                let first = pairs.add(&mut at, d, &goal)?;
                if augment.per_state > 0 {
                    pairs.add_perturbed(&mut at, d, &goal, augment, &self.joints, first)?;
                }
                Ok(pairs)
            })
            .collect::<Result<_, LearnError>>()?;
        // Sized once and each part freed as it is copied: at 300K
        // trajectories the pairs take gigabytes, and growing by doubling
        // beside the parts would need three times that.
        let mut all = Pairs::new(robot.nq(), width);
        all.inputs.reserve_exact(parts.iter().map(|p| p.inputs.len()).sum());
        all.directions.reserve_exact(parts.iter().map(|p| p.directions.len()).sum());
        all.speeds.reserve_exact(parts.iter().map(|p| p.speeds.len()).sum());
        all.slopes.reserve_exact(parts.iter().map(|p| p.slopes.len()).sum());
        all.slope_rows.reserve_exact(parts.iter().map(|p| p.slope_rows.len()).sum());
        for p in parts {
            all.extend(&p);
        }
        Ok(all)
    }
}

/// How a network sees a task: its gripper frame, the obstacles that are
/// part of every task (never in a slot), its obstacle slots and its
/// obstacle frames (see [`features`](super::features)).
#[derive(Debug, Clone, Copy)]
pub struct InputView<'a> {
    /// Gripper frame name.
    pub gripper: &'a str,
    /// Obstacles never put in a slot.
    pub static_obstacles: &'a [String],
    /// Obstacle slots.
    pub slots: usize,
    /// Obstacle frame names.
    pub frames: &'a [String],
}

/// The robot while pairs are made: its model, frames and kinematics.
struct Robot<'a> {
    model: &'a RobotModel,
    frames: &'a InputFrames,
    ws: &'a mut KinematicsWorkspace,
    slots: usize,
}

/// Perturbed states around the demonstrations, labelled by the LQR
/// tracking policy of the demonstration (the dissertation's §3.3.4, with the
/// demonstration's velocity as the arm's): the network learns how to get
/// back to a motion, not only the motion (DART-style noise injection with
/// a local expert, no optimizer solve).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Augmentation {
    /// Perturbed states per demonstrated state (0: none).
    pub per_state: usize,
    /// Standard deviation of the perturbation per joint, drawn log-uniformly
    /// in `[noise.0, noise.1]` for each perturbed state (rad).
    pub noise: (f64, f64),
    /// Seed of the perturbations (mixed with the demonstration's id).
    pub seed: u64,
}

impl Default for Augmentation {
    fn default() -> Self {
        Augmentation { per_state: 0, noise: (0.005, 0.05), seed: 0 }
    }
}

/// Inputs and targets: for each state `q_t` of a demonstration, the input
/// of [`encode`] and the velocity `(q_{t+1} − q_t)/Δt` as its unit direction
/// and its norm (rad/s); the last state's velocity is zero.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pairs {
    /// Values per input row.
    pub input_width: usize,
    /// Joints (values per direction row).
    pub dof: usize,
    /// Row-major `len × input_width`.
    pub inputs: Vec<f32>,
    /// Row-major `len × dof` unit directions (zero where the velocity is).
    pub directions: Vec<f32>,
    /// Speeds (rad/s).
    pub speeds: Vec<f32>,
    /// For each perturbed pair, its row and the row of the demonstrated
    /// state it perturbs: `[perturbed, demonstrated]` (empty without
    /// augmentation).
    pub slope_rows: Vec<[usize; 2]>,
    /// Row-major `slope_rows.len() × dof`: the LQR tracking policy's
    /// velocity change from the demonstrated state to the perturbed one per
    /// unit of their distance, `(π(q′) − π(q)) / ‖q′ − q‖` (rad/s per
    /// rad): a directional derivative the network's may be trained to
    /// match ([`TrainSettings::slope_weight`](super::TrainSettings::slope_weight)).
    pub slopes: Vec<f32>,
    /// `1 / ‖q′ − q‖` of each slope (1/rad).
    pub slope_inverse_lengths: Vec<f32>,
    /// Demonstrations added.
    pub trajectories: usize,
}

impl Pairs {
    fn new(dof: usize, input_width: usize) -> Pairs {
        Pairs { input_width, dof, ..Pairs::default() }
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.speeds.len()
    }

    /// Whether there are no pairs.
    pub fn is_empty(&self) -> bool {
        self.speeds.is_empty()
    }

    /// Adds the pairs of `d`'s states; returns the row of its first.
    fn add(&mut self, at: &mut Robot, d: &Demonstration, goal: &GoalFeatures) -> Result<usize, LearnError> {
        let first = self.len();
        for (t, q) in d.states.iter().enumerate() {
            let velocity: Vec<f64> = match d.states.get(t + 1) {
                Some(next) => next.iter().zip(q).map(|(b, a)| (b - a) / d.time_step).collect(),
                None => vec![0.0; self.dof],
            };
            self.push(at, d.id, goal, q, &velocity)?;
        }
        self.trajectories += 1;
        Ok(first)
    }

    /// One pair: the input at `q` and the target `velocity`.
    fn push(
        &mut self,
        at: &mut Robot,
        id: u64,
        goal: &GoalFeatures,
        q: &[f64],
        velocity: &[f64],
    ) -> Result<(), LearnError> {
        at.model.forward_kinematics(at.ws, q).map_err(|e| LearnError::Dataset {
            path: PathBuf::from(format!("demonstration {id}")),
            message: e.to_string(),
        })?;
        let mut origins = [[0.0; 3]; MAX_OBSTACLE_FRAMES];
        let (gripper, frames) = at.frames.place(at.model, at.ws, &mut origins);
        let start = self.inputs.len();
        self.inputs.resize(start + self.input_width, 0.0);
        encode(&mut self.inputs[start..], Placement { gripper: &gripper, frames }, goal, q, at.slots);
        let speed = velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
        let inverse = if speed > 0.0 { 1.0 / speed } else { 0.0 };
        self.directions.extend(velocity.iter().map(|v| (v * inverse) as f32));
        self.speeds.push(speed as f32);
        Ok(())
    }

    /// `augment.per_state` perturbed copies of every state of `d`,
    /// labelled by `d`'s LQR tracking policy, with their slopes from the
    /// demonstrated states (whose rows start at `first`).
    fn add_perturbed(
        &mut self,
        at: &mut Robot,
        d: &Demonstration,
        goal: &GoalFeatures,
        augment: &Augmentation,
        joints: &[String],
        first: usize,
    ) -> Result<(), LearnError> {
        let reference = JointTrajectory::new(joints.to_vec(), d.time_step, &d.states)?;
        let policy = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant)?;
        let mut tracking = policy.workspace();
        let mut rng = ChaCha8Rng::seed_from_u64(crate::problem::sample_seed(augment.seed, d.id));
        let (lo, hi) = (augment.noise.0.max(1e-9).ln(), augment.noise.1.max(augment.noise.0).max(1e-9).ln());
        let n = self.dof;
        let (mut perturbed, mut label, mut at_state) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (t, q) in d.states.iter().enumerate() {
            let velocity = policy.reference().velocity(t).to_vec();
            policy.query(&mut tracking, q, Some(&velocity), &mut at_state)?;
            for _ in 0..augment.per_state {
                let sigma = rng.random_range(lo..=hi).exp();
                for ((x, q0), l) in perturbed.iter_mut().zip(q).zip(at.model.limits()) {
                    *x = (q0 + sigma * gaussian(&mut rng)).clamp(l.lower, l.upper);
                }
                policy.probe(&mut tracking, &perturbed, Some(&velocity), &mut label)?;
                let distance = perturbed.iter().zip(q).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
                // A perturbation clamped back onto the state has no slope.
                if distance > 1e-9 {
                    self.slope_rows.push([self.len(), first + t]);
                    self.slopes.extend(label.iter().zip(&at_state).map(|(a, b)| ((a - b) / distance) as f32));
                    self.slope_inverse_lengths.push((1.0 / distance) as f32);
                }
                self.push(at, d.id, goal, &perturbed, &label)?;
            }
        }
        Ok(())
    }

    /// Appends `other` (same widths).
    pub fn extend(&mut self, other: &Pairs) {
        let offset = self.len();
        self.slope_rows.extend(other.slope_rows.iter().map(|[a, b]| [a + offset, b + offset]));
        self.slopes.extend_from_slice(&other.slopes);
        self.slope_inverse_lengths.extend_from_slice(&other.slope_inverse_lengths);
        self.inputs.extend_from_slice(&other.inputs);
        self.directions.extend_from_slice(&other.directions);
        self.speeds.extend_from_slice(&other.speeds);
        self.trajectories += other.trajectories;
    }
}

/// A standard normal draw (Box-Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Whether sample `id` belongs to the validation share `fraction` (a hash
/// of the id, so the split does not depend on file order or count).
pub fn in_validation(id: u64, fraction: f64) -> bool {
    let h = crate::problem::sample_seed(0x5EED_5EED, id);
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
    for (r, &time_step) in time_steps.iter().enumerate().take(batch.num_rows()) {
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
        // `q` holds q_0 … q_T, the start first (schema version 2 on).
        if flat[..n] != start[..] {
            return Err(column_error(path, "q", &format!("row {r}: q_0 is not the row's start")));
        }
        let states: Vec<Vec<f64>> = flat.chunks_exact(n).map(<[f64]>::to_vec).collect();
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
        if !(time_step.is_finite() && time_step > 0.0) {
            return Err(column_error(path, "time_step", &format!("row {r}: {time_step} s")));
        }
        items.push(Demonstration { id: ids.value(r), time_step, goal_pose, obstacles, states });
    }
    Ok(())
}
