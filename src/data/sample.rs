//! One dataset sample: family sample → IK → RRT-Connect → optimizer →
//! validation, and the record (or the rejection) it yields.

use super::GenerateSettings;
use crate::komo::{KomoError, ProblemSolution, SolveOptions, solve_problem};
use crate::plan::{IkError, PlanError, path_length};
use crate::problem::{Goal, GraspCriteria, GraspError, GraspJudge, GraspReport, Problem, ProblemFamily, sample_seed};
use crate::robot::KinematicsWorkspace;
use crate::scene::Shape;
use nalgebra::{IsometryMatrix3, UnitQuaternion, Vector3};
use std::borrow::Cow;
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

/// Distance of a final configuration from the goal. Pose and grasp goals:
/// the gripper's position error (m) and the angle (rad) between its axis
/// and the target axis (full orientation error when the goal fixes one).
/// Joint goals: `distance` 0 and `angle` the largest joint difference
/// (rad, or m for prismatic joints).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GoalMiss {
    /// Position error of the gripper at q_T (m).
    pub distance: f64,
    /// Angle between its axis and the goal's (rad).
    pub angle: f64,
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
    /// The grasp at q_T, for grasp goals ([`GraspJudge`]).
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

/// Generates sample `id` of `family` for the run settings, trying up to
/// `settings.attempts` times (odd attempts with the flipped grasp, each
/// with another IK + planning seed): the outcome depends on
/// (settings.seed, id, horizon, attempts, tolerances) only. Time budgets
/// of the planner are lifted (its iteration budget bounds the work) so that
/// machine load cannot change the dataset.
pub fn run_sample(family: &ProblemFamily, settings: &GenerateSettings, id: u64) -> (SampleOutcome, SampleTiming) {
    let began = Instant::now();
    let reject =
        |reason: &str, detail: String| SampleOutcome::Rejected(Rejection { id, reason: reason.into(), detail });
    let sample = match family.sample(settings.seed, id) {
        Ok(s) => s,
        Err(e) => return (reject("sample_failed", e.to_string()), timing(began, Duration::ZERO)),
    };
    let (outcome, plan_time) = solve_sample(sample.problem, sample.seed, id, settings);
    (outcome, timing(began, plan_time))
}

/// Solves `problem` as sample `id` with random stream `seed` (IK,
/// RRT-Connect, optimizer, validation, up to `settings.attempts` times as
/// [`run_sample`] does): the expert of a problem that no family draws, such
/// as a start where a learned policy failed.
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

fn solve_sample(mut problem: Problem, seed: u64, id: u64, settings: &GenerateSettings) -> (SampleOutcome, Duration) {
    let reject =
        |reason: &str, detail: String| SampleOutcome::Rejected(Rejection { id, reason: reason.into(), detail });
    problem.planner.time_limit = UNLIMITED_SECONDS;
    problem.optimizer.max_iterations = settings.max_evaluations;
    let mut plan_time = Duration::ZERO;
    let mut outcome = reject("error", "no attempt was made".into());
    for attempt in 0..settings.attempts.max(1) {
        let variant = grasp_variant(&problem, attempt);
        let (next, planned) = attempt_sample(&variant, seed, id, attempt, settings);
        plan_time += planned;
        outcome = next;
        if matches!(outcome, SampleOutcome::Accepted(_)) {
            break;
        }
    }
    (outcome, plan_time)
}

/// The problem of attempt `a`: odd attempts of a grasp turn the grasp frame
/// by π about its approach axis ([`Scene::flip_grasp`](crate::scene::Scene::flip_grasp)),
/// an equivalent grasp whose wrist motion can avoid what blocked the first.
fn grasp_variant(problem: &Problem, attempt: u32) -> Cow<'_, Problem> {
    match &problem.goal {
        Goal::Grasp { object, grasp } if attempt % 2 == 1 => {
            let mut flipped = problem.clone();
            match flipped.scene.flip_grasp(object, grasp) {
                Ok(()) => Cow::Owned(flipped),
                Err(_) => Cow::Borrowed(problem),
            }
        }
        _ => Cow::Borrowed(problem),
    }
}

/// One IK + planning + optimization attempt: attempt `a` seeds IK and
/// RRT-Connect with `sample_seed(seed, a)` (the sample's own seed for a = 0),
/// so a retry explores another goal configuration and initial path.
fn attempt_sample(
    problem: &Problem,
    seed: u64,
    id: u64,
    attempt: u32,
    settings: &GenerateSettings,
) -> (SampleOutcome, Duration) {
    let reject = |reason: &str, detail: String| {
        let detail = format!("attempt {}: {detail}", attempt + 1);
        SampleOutcome::Rejected(Rejection { id, reason: reason.into(), detail })
    };
    let planner_seed = if attempt == 0 { seed } else { sample_seed(seed, u64::from(attempt)) };
    let options = SolveOptions {
        seed: Some(planner_seed),
        horizon: settings.horizon,
        validation_resolution: settings.validation_resolution,
    };
    let solution = match solve_problem(problem, &options) {
        Ok(s) => s,
        Err(e) => return (reject(error_reason(&e), e.to_string()), Duration::ZERO),
    };
    let plan_time = solution.plan.planning_time + solution.plan.simplify_time;
    let outcome = match solution.status() {
        "converged" => accept(problem, seed, id, attempt, &solution, settings),
        status => Ok(reject(status, format!("the solve ended {status}: {}", describe(&solution)))),
    };
    (outcome.unwrap_or_else(|e| reject("error", e.to_string())), plan_time)
}

/// Planner budget used in generation (s): effectively none.
const UNLIMITED_SECONDS: f64 = 1e6;

fn timing(began: Instant, plan: Duration) -> SampleTiming {
    let total = began.elapsed();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    SampleTiming { plan_ms: ms(plan), optimize_ms: ms(total.saturating_sub(plan)), total_ms: ms(total) }
}

fn error_reason(e: &KomoError) -> &'static str {
    match e {
        KomoError::Plan(PlanError::Ik(IkError::Unreachable { .. })) => "ik_unreachable",
        KomoError::Plan(PlanError::Ik(IkError::InCollision { .. })) => "ik_in_collision",
        _ => "error",
    }
}

fn describe(s: &ProblemSolution) -> String {
    format!(
        "plan {}, eq {:.1e}, ineq {:.1e}, min distance {:.2e} m",
        s.plan.result.status.name(),
        s.report.equality_violation,
        s.report.inequality_violation,
        s.validation.min_distance.unwrap_or(f64::INFINITY)
    )
}

fn accept(
    problem: &Problem,
    seed: u64,
    id: u64,
    attempt: u32,
    s: &ProblemSolution,
    settings: &GenerateSettings,
) -> Result<SampleOutcome, crate::robot::RobotError> {
    let last = s.trajectory.last().map(Vec::as_slice).unwrap_or(&problem.start);
    let miss = goal_miss(problem, last)?;
    if miss.distance > settings.goal_tolerance || miss.angle > settings.goal_angle_tolerance {
        let detail = format!("q_T misses the goal by {:.2e} m, {:.2e} rad", miss.distance, miss.angle);
        return Ok(SampleOutcome::Rejected(Rejection { id, reason: "goal_missed".into(), detail }));
    }
    let grasp = match judge_grasp(problem, last, settings.goal_angle_tolerance) {
        Ok(Some((report, criteria))) => match report.failure(&criteria) {
            Some(why) => {
                let detail = format!("attempt {}: at q_T {why}", attempt + 1);
                return Ok(SampleOutcome::Rejected(Rejection { id, reason: "grasp_failed".into(), detail }));
            }
            None => Some(report),
        },
        Ok(None) => None,
        Err(e) => {
            let detail = format!("attempt {}: cannot judge the grasp: {e}", attempt + 1);
            return Ok(SampleOutcome::Rejected(Rejection { id, reason: "error".into(), detail }));
        }
    };
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

/// What generated grasps may miss the margin of the problem's collision
/// inequalities by (m): ten times the optimizer's constraint tolerance.
const GRASP_CLEARANCE_TOLERANCE: f64 = 1e-4;

/// The grasp at `q` and the criteria it is held to, for a grasp goal whose
/// gripper has finger pads (`None` otherwise): the object between the pads,
/// the fingertip centre within its footprint, the gripper within
/// `max_tilt` of the grasp frame's approach axis, palm and fingers at
/// least the final collision margin from it.
fn judge_grasp(
    problem: &Problem,
    q: &[f64],
    max_tilt: f64,
) -> Result<Option<(GraspReport, GraspCriteria)>, GraspError> {
    let (Goal::Grasp { object, .. }, false) = (&problem.goal, problem.robot_spec.finger_pads.is_empty()) else {
        return Ok(None);
    };
    let (Some(criteria), Some(target)) =
        (GraspCriteria::for_goal(problem, max_tilt, GRASP_CLEARANCE_TOLERANCE), problem.scene.object(object))
    else {
        return Ok(None);
    };
    let judge = GraspJudge::new(problem)?;
    let mut ws = KinematicsWorkspace::new(&problem.robot);
    Ok(Some((judge.judge(&mut ws, q, target, &criteria)?, criteria)))
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

fn gripper_poses(problem: &Problem, q: &[Vec<f64>]) -> Result<Option<Vec<PoseArray>>, crate::robot::RobotError> {
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

/// How far configuration `q` is from the problem's goal; see [`GoalMiss`].
///
/// # Errors
/// Unknown frames or a configuration of the wrong length.
pub fn goal_miss(problem: &Problem, q: &[f64]) -> Result<GoalMiss, crate::robot::RobotError> {
    let robot = &problem.robot;
    let frame_pose = |name: &str| -> Result<IsometryMatrix3<f64>, crate::robot::RobotError> {
        let mut ws = KinematicsWorkspace::new(robot);
        robot.forward_kinematics(&mut ws, q)?;
        Ok(robot.frame_pose(&ws, robot.frame_id(name)?))
    };
    let axis_angle = |pose: &IsometryMatrix3<f64>, axis: usize, direction: &Vector3<f64>| {
        (pose.rotation * Vector3::ith(axis, 1.0)).angle(direction)
    };
    Ok(match &problem.goal {
        Goal::Joints(goal) => {
            let angle = goal.iter().zip(q).map(|(g, v)| (g - v).abs()).fold(0.0, f64::max);
            GoalMiss { distance: 0.0, angle }
        }
        Goal::Pose { frame, position, orientation, axis_alignment } => {
            let pose = frame_pose(frame)?;
            let angle = match (orientation, axis_alignment) {
                (Some(r), _) => crate::robot::rotation_log(&(pose.rotation.inverse() * r)).norm(),
                (None, Some((axis, direction))) => axis_angle(&pose, *axis, direction),
                (None, None) => 0.0,
            };
            GoalMiss { distance: (pose.translation.vector - position).norm(), angle }
        }
        Goal::Grasp { .. } => {
            let (Some(gripper), Some(target)) = (&problem.robot_spec.gripper, problem.grasp_target()) else {
                return Ok(GoalMiss { distance: f64::INFINITY, angle: f64::INFINITY });
            };
            let pose = frame_pose(gripper)?;
            let approach = target.rotation * Vector3::z();
            GoalMiss {
                distance: (pose.translation.vector - target.translation.vector).norm(),
                angle: axis_angle(&pose, 2, &approach),
            }
        }
    })
}
