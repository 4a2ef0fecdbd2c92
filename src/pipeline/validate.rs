//! The checks a trajectory passes before it is accepted: collision-free
//! between slices and within limits ([`validate`]), at the goal
//! ([`goal_miss`]), and for grasp goals a grasp the judge accepts
//! ([`judge_grasp`]).

use crate::collision::CollisionWorkspace;
use crate::komo::TrajectoryProblem;
use crate::problem::{Goal, GraspCriteria, GraspError, GraspJudge, GraspReport, Problem};
use crate::robot::{KinematicsWorkspace, RobotError};
use nalgebra::{IsometryMatrix3, Vector3};

/// Checks of a trajectory beyond the solver's own measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Validation {
    /// No collision on the straight joint-space motions start → q_1 → … →
    /// q_T, checked so that no joint moves more than `resolution` between
    /// checks.
    pub collision_free: bool,
    /// Smallest signed distance over the slices (m); `None` without a
    /// collision model.
    pub min_distance: Option<f64>,
    /// Every slice within the joint limits.
    pub within_limits: bool,
    /// The resolution of the collision check (rad or m).
    pub resolution: f64,
}

/// Checks `trajectory` (`q_1 … q_T` of `problem`, from its start) for
/// collisions between slices at `resolution` and for joint limits.
///
/// # Errors
/// Configurations the model rejects; a bad resolution.
pub fn validate(
    problem: &TrajectoryProblem,
    trajectory: &[Vec<f64>],
    resolution: f64,
) -> Result<Validation, RobotError> {
    let robot = problem.robot();
    let within_limits = trajectory.iter().all(|q| robot.within_limits(q));
    let (mut collision_free, mut min_distance) = (true, None);
    if let Some(model) = problem.collision_model() {
        let mut ws = CollisionWorkspace::new(model);
        let mut previous = problem.start();
        for q in trajectory {
            collision_free &= model.motion_free(&mut ws, previous, q, resolution)?;
            // Only pairs closer than the closest so far matter.
            let below = min_distance.unwrap_or(f64::INFINITY);
            if let Some(d) = model.min_distance_below(&mut ws, q, below)? {
                min_distance = Some(d.signed.distance);
            }
            previous = q;
        }
    }
    Ok(Validation { collision_free, min_distance, within_limits, resolution })
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

/// What generated grasps may miss the margin of the problem's collision
/// inequalities by (m): ten times the optimizer's constraint tolerance.
const GRASP_CLEARANCE_TOLERANCE: f64 = 1e-4;

/// The grasp at `q` and the criteria it is held to, for a grasp goal whose
/// gripper has finger pads (`None` otherwise): the object between the pads,
/// the fingertip centre within its footprint, the gripper within
/// `max_tilt` of the grasp frame's approach axis, palm and fingers at
/// least the final collision margin from it.
pub fn judge_grasp(
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

/// How far configuration `q` is from the problem's goal; see [`GoalMiss`].
///
/// # Errors
/// Unknown frames or a configuration of the wrong length.
pub fn goal_miss(problem: &Problem, q: &[f64]) -> Result<GoalMiss, RobotError> {
    let robot = &problem.robot;
    let frame_pose = |name: &str| -> Result<IsometryMatrix3<f64>, RobotError> {
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
