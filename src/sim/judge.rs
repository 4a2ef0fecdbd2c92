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
use crate::robot::KinematicsWorkspace;
use crate::scene::{Goal, GraspCriteria, GraspJudge, Problem};

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
    /// The judge of `goal` (prepared from `problem`, see the module docs).
    ///
    /// # Errors
    /// A grasp goal whose object is missing.
    pub fn new(goal: &ProblemGoal) -> Result<TaskJudge, Box<dyn std::error::Error + Send + Sync>> {
        let problem = &goal.problem;
        let kin = KinematicsWorkspace::new(&problem.robot);
        let kind = match (&problem.goal, GraspJudge::new(problem)) {
            (Goal::Grasp { object, .. }, Ok(judge)) => {
                let object = problem.scene.object(object).ok_or("the grasp target is not in the scene")?.clone();
                let approach = problem.grasp_target().ok_or("no grasp target")?.rotation * nalgebra::Vector3::z();
                let criteria = GraspCriteria { approach, max_tilt: GRASP_MAX_TILT, margin: 0.0 };
                Kind::Grasp { judge: Box::new(judge), object: Box::new(object), criteria }
            }
            _ => Kind::Reach { problem: Box::new(problem.clone()), target: goal.position },
        };
        Ok(TaskJudge { kind, kin })
    }

    /// Whether the task is done at `q`.
    pub fn succeeded(&mut self, q: &[f64]) -> bool {
        match &self.kind {
            Kind::Grasp { judge, object, criteria } => {
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
