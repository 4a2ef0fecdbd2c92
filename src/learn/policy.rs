//! [`LearnedPolicy`]: the network conditioned on one goal, behind the
//! [`RobotPolicy`] interface the arbiter queries.

use super::LearnError;
use super::features::{GoalFeatures, InputFrames, MAX_OBSTACLE_FRAMES, ObstacleFeature, Placement, encode};
use super::network::{NetworkWorkspace, PolicyNetwork};
use crate::control::{ControlError, RobotPolicy, RobotPolicyWorkspace};
use crate::problem::Problem;
use crate::robot::{KinematicsWorkspace, RobotModel};
use std::sync::Arc;

/// A learned robot policy for one goal: at any configuration `q`, the
/// network's joint velocity (rad/s) toward the goal. Immutable and
/// `Send + Sync`; queries allocate nothing (the state holds the kinematics
/// workspace and the network's buffers). The state carries no memory
/// between queries, so [`RobotPolicy::act`] and [`RobotPolicy::probe`]
/// agree and the metric's finite differences see one smooth field.
#[derive(Debug, Clone)]
pub struct LearnedPolicy {
    network: Arc<PolicyNetwork>,
    robot: Arc<RobotModel>,
    frames: InputFrames,
    goal: GoalFeatures,
}

/// Per-caller buffers of a [`LearnedPolicy`].
#[derive(Debug, Clone)]
pub struct LearnedPolicyWorkspace {
    kin: KinematicsWorkspace,
    scratch: NetworkWorkspace,
    input: Vec<f32>,
    raw: Vec<f32>,
}

impl LearnedPolicy {
    /// The `network` for `robot` (its active joints must be the network's,
    /// in order) conditioned on `goal`.
    ///
    /// # Errors
    /// Other joints than the network's, an unknown gripper frame, more
    /// obstacles than the network has slots, a non-finite goal.
    pub fn new(network: Arc<PolicyNetwork>, robot: Arc<RobotModel>, goal: GoalFeatures) -> Result<Self, LearnError> {
        let meta = network.meta();
        if robot.joint_names() != meta.joints.as_slice() {
            return Err(LearnError::Mismatch {
                what: "active joints".into(),
                expected: meta.joints.join(", "),
                got: robot.joint_names().join(", "),
            });
        }
        let frames = InputFrames::resolve(&robot, &meta.gripper, &meta.obstacle_frames)?;
        if goal.obstacles.len() > meta.obstacle_slots {
            return Err(LearnError::Mismatch {
                what: "obstacles".into(),
                expected: format!("at most {}", meta.obstacle_slots),
                got: goal.obstacles.len().to_string(),
            });
        }
        let finite = goal.position.iter().chain(&goal.rotation6).all(|v| v.is_finite())
            && goal.obstacles.iter().all(|o| o.center.iter().chain(&o.size).all(|v| v.is_finite()));
        if !finite {
            return Err(LearnError::Mismatch {
                what: "goal".into(),
                expected: "finite values".into(),
                got: format!("{goal:?}"),
            });
        }
        Ok(LearnedPolicy { network, robot, frames, goal })
    }

    /// The policy for `problem`'s grasp or pose goal, seeing the scene's
    /// obstacles that are not static (the first `obstacle_slots`).
    ///
    /// # Errors
    /// A joint goal; as [`LearnedPolicy::new`].
    pub fn for_problem(network: Arc<PolicyNetwork>, problem: &Problem) -> Result<Self, LearnError> {
        let goal = problem_goal(network.meta(), problem)?;
        LearnedPolicy::new(network, problem.robot.clone(), goal)
    }

    /// The network.
    pub fn network(&self) -> &Arc<PolicyNetwork> {
        &self.network
    }

    /// What the policy is conditioned on.
    pub fn goal(&self) -> &GoalFeatures {
        &self.goal
    }

    /// A fresh state (allocates).
    pub fn state(&self) -> LearnedPolicyWorkspace {
        let meta = self.network.meta();
        LearnedPolicyWorkspace {
            kin: KinematicsWorkspace::new(&self.robot),
            scratch: self.network.scratch(),
            input: vec![0.0; meta.input_width()],
            raw: vec![0.0; meta.dof() + 1],
        }
    }

    /// The joint velocity (rad/s) at `q`, written to `velocity`.
    ///
    /// # Errors
    /// Wrong lengths or non-finite values.
    pub fn query(
        &self,
        state: &mut LearnedPolicyWorkspace,
        q: &[f64],
        velocity: &mut [f64],
    ) -> Result<(), ControlError> {
        let n = self.network.meta().dof();
        check(q, n, "q")?;
        if velocity.len() != n {
            return Err(ControlError::WrongLength { what: "action", expected: n, got: velocity.len() });
        }
        self.robot.forward_kinematics(&mut state.kin, q).map_err(|_| ControlError::WrongLength {
            what: "q",
            expected: n,
            got: q.len(),
        })?;
        let mut origins = [[0.0; 3]; MAX_OBSTACLE_FRAMES];
        let (gripper, frames) = self.frames.place(&self.robot, &state.kin, &mut origins);
        let slots = self.network.meta().obstacle_slots;
        encode(&mut state.input, Placement { gripper: &gripper, frames }, &self.goal, q, slots);
        self.network.forward(&state.input, &mut state.scratch, &mut state.raw);
        self.network.velocity_from_outputs(&state.raw, velocity);
        Ok(())
    }
}

/// The goal features of `problem` for a network described by `meta`.
///
/// # Errors
/// A joint goal, or a goal whose pose cannot be found.
pub fn problem_goal(meta: &super::PolicyMeta, problem: &Problem) -> Result<GoalFeatures, LearnError> {
    let pose = match &problem.goal {
        crate::problem::Goal::Grasp { .. } => problem.grasp_target(),
        crate::problem::Goal::Pose { position, orientation, .. } => Some(nalgebra::IsometryMatrix3::from_parts(
            (*position).into(),
            orientation.unwrap_or_else(nalgebra::Rotation3::identity),
        )),
        crate::problem::Goal::Joints(_) => None,
    }
    .ok_or_else(|| LearnError::Mismatch {
        what: "goal".into(),
        expected: "a grasp or pose goal".into(),
        got: format!("{:?}", problem.goal),
    })?;
    let obstacles = problem
        .scene
        .obstacles()
        .iter()
        .filter(|o| !meta.static_obstacles.contains(&o.name))
        .take(meta.obstacle_slots)
        .map(|o| {
            let e = o.shape.extents();
            ObstacleFeature { center: o.pose.translation.vector.into(), size: [e.x, e.y, e.z] }
        })
        .collect();
    Ok(GoalFeatures::new(&pose, obstacles))
}

fn check(values: &[f64], n: usize, what: &'static str) -> Result<(), ControlError> {
    if values.len() != n {
        return Err(ControlError::WrongLength { what, expected: n, got: values.len() });
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(ControlError::NonFinite { what, index, value: values[index] }),
        None => Ok(()),
    }
}

impl LearnedPolicy {
    fn learned_state<'s>(
        &self,
        state: &'s mut RobotPolicyWorkspace,
    ) -> Result<&'s mut LearnedPolicyWorkspace, ControlError> {
        state.get_mut::<LearnedPolicyWorkspace>().ok_or(ControlError::ForeignState)
    }
}

impl RobotPolicy for LearnedPolicy {
    fn dof(&self) -> usize {
        self.network.meta().dof()
    }

    fn new_workspace(&self) -> RobotPolicyWorkspace {
        RobotPolicyWorkspace::new(self.state())
    }

    fn act(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError> {
        check(velocity, self.dof(), "velocity")?;
        let s = self.learned_state(state)?;
        self.query(s, q, action)
    }

    fn probe(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError> {
        self.act(state, q, velocity, action)
    }

    fn reset(&self, _state: &mut RobotPolicyWorkspace) {}
}
