//! When a task counts as done: the success criteria, fixed before any
//! result was looked at.
//!
//! A grasp (a problem with finger pads and a grasp goal) succeeds when the
//! object lies between the finger pads, the fingertip centre is over its
//! footprint, the gripper's approach axis is within 0.2 rad (11.5°) of the
//! grasp frame's, and the palm and the fingers' outer sides do not touch it
//! ([`GraspJudge`], clearance ≥ 0). Any other goal succeeds with the
//! gripper within 1 cm of the goal's final gripper position.
//!
//! The numbers are [`GRASP_MAX_TILT`] and [`REACH_TOLERANCE`]; a failure's
//! [`Reason`] carries the bound it missed.

use super::reason::Reason;
use crate::arbitration::ProblemGoal;
use crate::problem::{Goal, GraspCriteria, GraspJudge, Problem};
use crate::robot::KinematicsWorkspace;

/// Largest tilt of a successful teleoperated grasp (rad).
pub const GRASP_MAX_TILT: f64 = 0.2;
/// Distance to the goal position of a successful reach (m).
pub const REACH_TOLERANCE: f64 = 0.01;

/// What an episode asks of its task: whether the task is done at a
/// configuration, and why not when the operator stops. A closure
/// `FnMut(&[f64]) -> bool` is a judge that gives no reason beyond the
/// distance to the goal.
pub trait Judge {
    /// Whether the task is done at `q`.
    fn succeeded(&mut self, q: &[f64]) -> bool;

    /// Why the task is not done at `q`, the gripper at `gripper` and the
    /// goal's grasp point at `target` (m, world).
    fn diagnose(&mut self, q: &[f64], gripper: [f64; 3], target: [f64; 3]) -> Reason {
        let _ = q;
        stopped_short(gripper, target).unwrap_or(Reason::JudgeDeclined)
    }
}

impl<F: FnMut(&[f64]) -> bool> Judge for F {
    fn succeeded(&mut self, q: &[f64]) -> bool {
        self(q)
    }
}

/// `StoppedShort` when `gripper` is farther than [`REACH_TOLERANCE`] from `target`.
fn stopped_short(gripper: [f64; 3], target: [f64; 3]) -> Option<Reason> {
    let distance = super::operator::distance(gripper, target);
    (distance > REACH_TOLERANCE).then_some(Reason::StoppedShort { distance, tolerance: REACH_TOLERANCE })
}

/// A judge of task success at a configuration.
pub struct TaskJudge {
    kind: Kind,
    kin: KinematicsWorkspace,
}

enum Kind {
    Grasp { judge: Box<GraspJudge>, object: Box<crate::scene::SceneObject>, criteria: GraspCriteria },
    Reach { problem: Box<Problem>, target: [f64; 3] },
}

impl TaskJudge {
    /// The judge of `goal` (see the module docs): a grasp judge when its
    /// problem grasps an object with a two-finger gripper with pads, else a
    /// reach judge.
    pub fn new(goal: &ProblemGoal) -> TaskJudge {
        let problem = &goal.problem;
        let kin = KinematicsWorkspace::new(&problem.robot);
        let grasp = match (&problem.goal, GraspJudge::new(problem), problem.grasp_target()) {
            (Goal::Grasp { object, .. }, Ok(judge), Some(target)) => problem.scene.object(object).map(|object| {
                let approach = target.rotation * nalgebra::Vector3::z();
                let criteria = GraspCriteria { approach, max_tilt: GRASP_MAX_TILT, margin: 0.0 };
                Kind::Grasp { judge: Box::new(judge), object: Box::new(object.clone()), criteria }
            }),
            _ => None,
        };
        let kind = grasp.unwrap_or_else(|| Kind::Reach { problem: Box::new(problem.clone()), target: goal.position });
        TaskJudge { kind, kin }
    }

    /// Whether the task is done at `q`.
    pub fn succeeded(&mut self, q: &[f64]) -> bool {
        match &self.kind {
            Kind::Grasp { judge, object, criteria } => {
                // Far from the object no grasp can hold: skip the distances.
                let robot = &judge.robot();
                if robot.forward_kinematics(&mut self.kin, q).is_err() {
                    return false;
                }
                let tcp = robot.frame_position(&self.kin, judge.geometry().gripper_frame());
                let reach = object.shape.bounding_radius() + 0.05;
                if (tcp - object.pose.translation.vector).norm() > reach && object.attachment.is_none() {
                    return false;
                }
                judge.judge(&mut self.kin, q, object, criteria).is_ok_and(|r| r.success(criteria))
            }
            Kind::Reach { problem, target } => {
                let robot = &problem.robot;
                let Some(frame) = problem.robot_spec.gripper.as_deref().and_then(|g| robot.frame_id(g).ok()) else {
                    return false;
                };
                if robot.forward_kinematics(&mut self.kin, q).is_err() {
                    return false;
                }
                let p = robot.frame_position(&self.kin, frame);
                let d = (p - nalgebra::Vector3::from(*target)).norm();
                d <= REACH_TOLERANCE
            }
        }
    }
}

impl Judge for TaskJudge {
    fn succeeded(&mut self, q: &[f64]) -> bool {
        TaskJudge::succeeded(self, q)
    }

    /// Reaches: how far short. Grasps: how far short when the gripper is
    /// not at the object, else which criterion the grasp fails.
    fn diagnose(&mut self, q: &[f64], gripper: [f64; 3], target: [f64; 3]) -> Reason {
        let Kind::Grasp { judge, object, criteria } = &self.kind else {
            return stopped_short(gripper, target).unwrap_or(Reason::JudgeDeclined);
        };
        let robot = judge.robot();
        if robot.forward_kinematics(&mut self.kin, q).is_err() {
            return Reason::JudgeDeclined;
        }
        let tcp = robot.frame_position(&self.kin, judge.geometry().gripper_frame());
        let reach = object.shape.bounding_radius() + 0.05;
        if (tcp - object.pose.translation.vector).norm() > reach && object.attachment.is_none() {
            return stopped_short(gripper, target).unwrap_or(Reason::JudgeDeclined);
        }
        match judge.judge(&mut self.kin, q, object, criteria) {
            Ok(report) => Reason::of_grasp(&report, criteria),
            Err(_) => Reason::JudgeDeclined,
        }
    }
}
