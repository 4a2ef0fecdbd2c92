//! One dataset sample: family sample → the accepted solve of the
//! [pipeline](crate::pipeline) → the record (or the rejection) it yields.

use super::GenerateSettings;
use crate::pipeline::{Accepted, GoalMiss, solve_accepted};
use crate::plan::path_length;
use crate::problem::{Goal, GraspReport, Problem, ProblemFamily};
use crate::robot::{KinematicsWorkspace, RobotError};
use crate::scene::Shape;
use nalgebra::{IsometryMatrix3, UnitQuaternion};
use std::time::{Duration, Instant};

/// A pose as `[x, y, z, qx, qy, qz, qw]`: position (m) and unit quaternion
/// (scalar last, as ROS and scipy), in the world frame.
pub type PoseArray = [f64; 7];

/// A shape placed in the world, as stored in the dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedShape {
    pub name: String,
    /// `box`, `sphere`, `cylinder`, `capsule` or `convex`.
    pub shape: &'static str,
    /// See [`Shape::extents`] (m).
    pub size: [f64; 3],
    pub pose: PoseArray,
}

/// How the solve of an accepted sample went.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordReport {
    pub outer_iterations: u32,
    pub inner_steps: u32,
    pub evaluations: u32,
    /// `Σ r²` of the cost rows.
    pub cost: f64,
    /// Largest equality violation.
    pub eq_violation: f64,
    /// Largest inequality violation (≥ 0).
    pub ineq_violation: f64,
    /// Smallest signed distance over the slices (m; +∞ without a collision model).
    pub min_distance: f64,
    /// RRT-Connect iterations of the initial path.
    pub plan_iterations: u32,
    /// Attempts it took (1 = the first IK + planning + optimization).
    pub attempts: u32,
    /// Joint-space length of start → q_1 → … → q_T (rad).
    pub path_length: f64,
    /// How far q_T is from the goal; see [`GoalMiss`].
    pub goal_miss: GoalMiss,
}

/// An accepted trajectory with its problem parameters; one dataset row.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryRecord {
    /// Sample id within the run (0 … N−1).
    pub id: u64,
    /// Seed of the sample's random stream, from (run seed, id).
    pub seed: u64,
    /// Seconds between slices.
    pub time_step: f64,
    /// Start configuration q_0 (at rest).
    pub start: Vec<f64>,
    /// Target pose of the gripper frame, for pose and grasp goals.
    pub goal_pose: Option<PoseArray>,
    /// Target configuration, for joint goals.
    pub goal_joints: Option<Vec<f64>>,
    /// Scene objects (graspable) and obstacles, table included.
    pub objects: Vec<PlacedShape>,
    /// Obstacles, the table included.
    pub obstacles: Vec<PlacedShape>,
    /// q_0 … q_T: the start, then the optimized configurations (the
    /// convention of every trajectory tandem writes).
    pub q: Vec<Vec<f64>>,
    /// Velocities at slices 0 … T: 0 at the start (at rest), then the
    /// backward differences (q_t − q_{t−1}) / Δt.
    pub qd: Vec<Vec<f64>>,
    /// Gripper frame poses at slices 0 … T, when the problem names a gripper.
    pub ee_pose: Option<Vec<PoseArray>>,
    /// Solver and planner counts.
    pub report: RecordReport,
    /// The grasp at q_T, for grasp goals ([`GraspJudge`](crate::problem::GraspJudge)).
    pub grasp: Option<GraspReport>,
}

/// A sample that produced no trajectory, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rejection {
    /// Sample id within the run.
    pub id: u64,
    /// Stable snake_case reason: `sample_failed`, `ik_unreachable`,
    /// `ik_in_collision`, `plan_failed`, `in_collision`, `outside_limits`,
    /// `goal_missed`, `grasp_failed` (see [`GraspReport::failure`]), a solver termination (`infeasible`,
    /// `iteration_limit`, …) or `error`.
    pub reason: String,
    /// A human-readable explanation.
    pub detail: String,
}

/// Wall-clock times of one sample (the only machine-dependent output).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SampleTiming {
    /// IK + RRT-Connect + shortcutting (ms).
    pub plan_ms: f64,
    /// Everything else: sampling, optimization, re-solves, validation (ms).
    pub optimize_ms: f64,
    /// Whole sample, every attempt (ms).
    pub total_ms: f64,
}

/// What one sample produced.
#[derive(Debug, Clone, PartialEq)]
pub enum SampleOutcome {
    /// The sample passed every check.
    Accepted(Box<TrajectoryRecord>),
    /// It was rejected, with the reason.
    Rejected(Rejection),
}

impl SampleOutcome {
    /// The sample id.
    pub fn id(&self) -> u64 {
        match self {
            SampleOutcome::Accepted(r) => r.id,
            SampleOutcome::Rejected(r) => r.id,
        }
    }
}

/// Generates sample `id` of `family` for the run settings: the family's
/// sample, then [`solve_accepted`] with `settings.pipeline`; the outcome
/// depends on (settings.seed, id, settings.pipeline) only.
pub fn run_sample(family: &ProblemFamily, settings: &GenerateSettings, id: u64) -> (SampleOutcome, SampleTiming) {
    let began = Instant::now();
    let sample = match family.sample(settings.seed, id) {
        Ok(s) => s,
        Err(e) => {
            let rejected =
                SampleOutcome::Rejected(Rejection { id, reason: "sample_failed".into(), detail: e.to_string() });
            return (rejected, timing(began, Duration::ZERO));
        }
    };
    let (outcome, plan_time) = solve_sample(sample.problem, sample.seed, id, settings);
    (outcome, timing(began, plan_time))
}

/// Solves `problem` as sample `id` with random stream `seed` (as
/// [`run_sample`] does): the expert of a problem that no family draws,
/// such as a start where a learned policy failed.
pub fn run_problem(
    problem: &Problem,
    seed: u64,
    id: u64,
    settings: &GenerateSettings,
) -> (SampleOutcome, SampleTiming) {
    let began = Instant::now();
    let (outcome, plan_time) = solve_sample(problem.clone(), seed, id, settings);
    (outcome, timing(began, plan_time))
}

fn solve_sample(problem: Problem, seed: u64, id: u64, settings: &GenerateSettings) -> (SampleOutcome, Duration) {
    let (accepted, plan_time) = solve_accepted(problem, seed, &settings.pipeline);
    let outcome = match accepted {
        Ok(accepted) => {
            let attempt = accepted.attempt;
            record(seed, id, accepted).unwrap_or_else(|e| {
                let detail = format!("attempt {}: {e}", attempt + 1);
                SampleOutcome::Rejected(Rejection { id, reason: "error".into(), detail })
            })
        }
        Err(r) => SampleOutcome::Rejected(Rejection { id, reason: r.reason.into(), detail: r.detail }),
    };
    (outcome, plan_time)
}

fn timing(began: Instant, plan: Duration) -> SampleTiming {
    let total = began.elapsed();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    SampleTiming { plan_ms: ms(plan), optimize_ms: ms(total.saturating_sub(plan)), total_ms: ms(total) }
}

/// The dataset row of an accepted solution (of the problem of the accepted
/// attempt: its grasp may be the flipped one).
fn record(seed: u64, id: u64, accepted: Accepted) -> Result<SampleOutcome, RobotError> {
    let Accepted { problem, solution: s, attempt, goal_miss: miss, grasp } = accepted;
    let problem = &problem;
    let mut full = Vec::with_capacity(s.trajectory.len() + 1);
    full.push(problem.start.clone());
    full.extend(s.trajectory.iter().cloned());
    let mut qd = vec![vec![0.0; problem.start.len()]];
    qd.extend(full.windows(2).map(|w| w[1].iter().zip(&w[0]).map(|(b, a)| (b - a) / s.time_step).collect()));
    let report = RecordReport {
        outer_iterations: saturate(s.report.outer_iterations),
        inner_steps: saturate(s.report.inner_steps),
        evaluations: saturate(s.report.evaluations),
        cost: s.report.cost,
        eq_violation: s.report.equality_violation,
        ineq_violation: s.report.inequality_violation,
        min_distance: s.validation.min_distance.unwrap_or(f64::INFINITY),
        plan_iterations: saturate(s.plan.result.iterations),
        attempts: attempt + 1,
        path_length: path_length(&full),
        goal_miss: miss,
    };
    Ok(SampleOutcome::Accepted(Box::new(TrajectoryRecord {
        id,
        seed,
        time_step: s.time_step,
        start: problem.start.clone(),
        goal_pose: goal_pose(problem).map(|p| pose_array(&p)),
        goal_joints: match &problem.goal {
            Goal::Joints(q) => Some(q.clone()),
            _ => None,
        },
        objects: problem.scene.objects().iter().map(|o| placed(&o.name, &o.shape, &o.pose)).collect(),
        obstacles: problem.scene.obstacles().iter().map(|o| placed(&o.name, &o.shape, &o.pose)).collect(),
        qd,
        ee_pose: gripper_poses(problem, &full)?,
        q: full,
        report,
        grasp,
    })))
}

fn saturate(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

fn placed(name: &str, shape: &Shape, pose: &IsometryMatrix3<f64>) -> PlacedShape {
    let e = shape.extents();
    PlacedShape { name: name.to_string(), shape: shape.kind_name(), size: [e.x, e.y, e.z], pose: pose_array(pose) }
}

/// `[x, y, z, qx, qy, qz, qw]` of a pose.
pub fn pose_array(pose: &IsometryMatrix3<f64>) -> PoseArray {
    let t = pose.translation.vector;
    let q = UnitQuaternion::from_rotation_matrix(&pose.rotation);
    [t.x, t.y, t.z, q.i, q.j, q.k, q.w]
}

/// The world pose the goal asks of the gripper (grasp) or of its frame (pose).
fn goal_pose(problem: &Problem) -> Option<IsometryMatrix3<f64>> {
    match &problem.goal {
        Goal::Grasp { .. } => problem.grasp_target(),
        Goal::Pose { position, orientation, .. } => Some(IsometryMatrix3::from_parts(
            (*position).into(),
            orientation.unwrap_or_else(nalgebra::Rotation3::identity),
        )),
        Goal::Joints(_) => None,
    }
}

fn gripper_poses(problem: &Problem, q: &[Vec<f64>]) -> Result<Option<Vec<PoseArray>>, RobotError> {
    let Some(gripper) = &problem.robot_spec.gripper else { return Ok(None) };
    let robot = &problem.robot;
    let frame = robot.frame_id(gripper)?;
    let mut ws = KinematicsWorkspace::new(robot);
    let mut poses = Vec::with_capacity(q.len());
    for qt in q {
        robot.forward_kinematics(&mut ws, qt)?;
        poses.push(pose_array(&robot.frame_pose(&ws, frame)));
    }
    Ok(Some(poses))
}
