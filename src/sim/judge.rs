//! When a task counts as done: the success criteria, fixed before any
//! result was looked at.
//!
//! A grasp (a problem with finger pads and a grasp goal) succeeds when the
//! object lies between the finger pads, the fingertip centre is over its
//! footprint, the gripper's approach axis is within 0.2 rad (11.5°) of the
//! grasp frame's, and the palm and the fingers' outer sides do not touch it
//! ([`GraspJudge`], clearance ≥ 0). Any other goal succeeds with the
//! gripper within 1 cm of the goal's final gripper position.

use crate::arbitration::ProblemGoal;
use crate::problem::{Goal, GraspCriteria, GraspJudge, Problem};
use crate::robot::KinematicsWorkspace;

/// Largest tilt of a successful teleoperated grasp (rad).
pub const GRASP_MAX_TILT: f64 = 0.2;
/// Distance to the goal position of a successful reach (m).
pub const REACH_TOLERANCE: f64 = 0.01;

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
                let tcp = robot.frame_pose(&self.kin, judge.geometry().gripper_frame()).translation.vector;
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
                let p = robot.frame_pose(&self.kin, frame).translation.vector;
                let d = (p - nalgebra::Vector3::from(*target)).norm();
                d <= REACH_TOLERANCE
            }
        }
    }
}
