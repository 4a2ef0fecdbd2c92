//! The [`Arbiter`]: immutable and shared, it holds the robot, its
//! collision model, the goals with their policies and the settings. What
//! a tick does with it, stage by stage, is in `tick`.

use super::ArbitrationError;
use super::command::HumanCommand;
use super::learned::ArbitrationPolicy;
use super::modes::ArbitrationMode;
use super::settings::ArbiterSettings;
use crate::collision::CollisionModel;
use crate::control::RobotPolicy;
use crate::robot::{FrameId, ReferenceFrame, RobotModel};
use std::sync::Arc;

/// One goal the operator may be heading for: a name, a point in the world
/// the intent estimator compares the gripper path with (m), and the robot
/// policy that reaches it.
#[derive(Debug, Clone)]
pub struct ArbiterGoal {
    /// Its name.
    pub name: String,
    /// A world point (m).
    pub position: [f64; 3],
    /// The robot policy that reaches it.
    pub policy: Arc<dyn RobotPolicy>,
}

/// Shared control every tick: the robot, its collision model, the goals
/// with their policies, and the settings. Immutable and `Send + Sync`; each
/// control loop owns an [`ArbiterWorkspace`](super::ArbiterWorkspace).
#[derive(Debug)]
pub struct Arbiter {
    pub(crate) robot: Arc<RobotModel>,
    pub(crate) collision: Arc<CollisionModel>,
    pub(crate) gripper: FrameId,
    pub(crate) goals: Vec<ArbiterGoal>,
    pub(crate) settings: ArbiterSettings,
    /// The policy of [`ArbitrationMode::Learned`].
    pub(crate) learned: Option<Arc<dyn ArbitrationPolicy>>,
}

/// Distance rows beyond the bounds the solver may take per tick.
pub(crate) const MAX_SOLVER_ROWS: usize = 64;

impl Arbiter {
    /// An arbiter for the robot of `collision`, the gripper frame `gripper`
    /// (task commands and intent refer to it) and `goals`.
    ///
    /// # Errors
    /// An unknown gripper frame, a goal policy for another number of
    /// joints, a non-finite goal position, invalid settings.
    pub fn new(
        collision: Arc<CollisionModel>,
        gripper: &str,
        goals: Vec<ArbiterGoal>,
        settings: ArbiterSettings,
    ) -> Result<Arbiter, ArbitrationError> {
        let robot = collision.robot().clone();
        let gripper = robot.frame_id(gripper)?;
        for goal in &goals {
            if goal.policy.dof() != robot.nq() {
                return Err(ArbitrationError::PolicyDof {
                    goal: goal.name.clone(),
                    expected: robot.nq(),
                    got: goal.policy.dof(),
                });
            }
            if goal.position.iter().any(|x| !x.is_finite()) {
                return Err(ArbitrationError::GoalPosition { goal: goal.name.clone() });
            }
        }
        settings.validate()?;
        if settings.mode == ArbitrationMode::Learned {
            return Err(ArbitrationError::NoArbitrationPolicy);
        }
        Ok(Arbiter { robot, collision, gripper, goals, settings, learned: None })
    }

    /// The same robot, collision model and goals with other settings
    /// (cheap: shares them).
    ///
    /// # Errors
    /// Invalid settings.
    pub fn with_settings(&self, settings: ArbiterSettings) -> Result<Arbiter, ArbitrationError> {
        settings.validate()?;
        if settings.mode == ArbitrationMode::Learned && self.learned.is_none() {
            return Err(ArbitrationError::NoArbitrationPolicy);
        }
        Ok(Arbiter {
            robot: self.robot.clone(),
            collision: self.collision.clone(),
            gripper: self.gripper,
            goals: self.goals.clone(),
            settings,
            learned: self.learned.clone(),
        })
    }

    /// The same arbiter with `policy` as the policy of
    /// [`ArbitrationMode::Learned`] (cheap: shares the rest).
    ///
    /// # Errors
    /// A policy whose [`StateLayout`](super::StateLayout) has another number of goals or
    /// other task dimensions than [`Self::task_dims`], or an invalid layout.
    pub fn with_arbitration_policy(&self, policy: Arc<dyn ArbitrationPolicy>) -> Result<Arbiter, ArbitrationError> {
        let layout = policy.layout();
        let expected_task_dims = self.task_dims();
        if layout.goals != self.goals.len() || !layout.is_valid() || layout.task_dims != expected_task_dims {
            return Err(ArbitrationError::PolicyLayout {
                expected_goals: self.goals.len(),
                expected_task_dims,
                goals: layout.goals,
                task_dims: layout.task_dims,
            });
        }
        Ok(Arbiter {
            robot: self.robot.clone(),
            collision: self.collision.clone(),
            gripper: self.gripper,
            goals: self.goals.clone(),
            settings: self.settings,
            learned: Some(policy),
        })
    }

    /// The task dimensions the gripper moves in: 2 when no joint moves it
    /// along the world's z axis (a planar robot: an arbitration policy
    /// trained on the x–y plane), else 3. Read from the gripper's Jacobian
    /// at the middle of the joint limits and two configurations beside it.
    pub fn task_dims(&self) -> usize {
        let robot = &self.robot;
        let mut ws = crate::robot::KinematicsWorkspace::new(robot);
        let mut jacobian = nalgebra::Matrix6xX::zeros(robot.nq());
        let middle: Vec<f64> = robot.limits().iter().map(|l| 0.5 * (l.lower + l.upper)).collect();
        for offset in [0.0, 0.3, -0.2] {
            let q: Vec<f64> = middle
                .iter()
                .zip(robot.limits())
                .map(|(m, l)| (m + offset * (l.upper - l.lower)).clamp(l.lower, l.upper))
                .collect();
            let moves_in_z = robot.forward_kinematics(&mut ws, &q).is_ok()
                && robot.frame_jacobian(&ws, self.gripper, ReferenceFrame::WorldAligned, &mut jacobian).is_ok()
                && (0..robot.nq()).any(|k| jacobian[(2, k)].abs() > 1e-9);
            if moves_in_z {
                return 3;
            }
        }
        2
    }

    /// The policy of [`ArbitrationMode::Learned`], if any.
    pub fn arbitration_policy(&self) -> Option<&Arc<dyn ArbitrationPolicy>> {
        self.learned.as_ref()
    }

    /// The settings.
    pub fn settings(&self) -> &ArbiterSettings {
        &self.settings
    }

    /// The goals.
    pub fn goals(&self) -> &[ArbiterGoal] {
        &self.goals
    }

    /// The robot.
    pub fn robot(&self) -> &Arc<RobotModel> {
        &self.robot
    }

    /// The gripper frame task commands and intent refer to.
    pub fn gripper_frame(&self) -> FrameId {
        self.gripper
    }

    /// The collision model the hard constraints use.
    pub fn collision_model(&self) -> &Arc<CollisionModel> {
        &self.collision
    }

    /// The same goals, policies and settings against `collision`, another
    /// collision model of the same robot (the scene with a new point
    /// cloud, say). Cheap: shares the rest. A workspace of this arbiter
    /// made by [`Self::workspace`] is ready; one of the old arbiter must
    /// take [`Self::safety_rows`] first
    /// ([`ArbiterWorkspace::swap_safety_rows`](super::ArbiterWorkspace::swap_safety_rows)),
    /// which keeps everything else it holds (beliefs, motion, mode).
    ///
    /// # Errors
    /// [`ArbitrationError::OtherRobot`] for a model whose robot has other joints.
    pub fn with_collision_model(&self, collision: Arc<CollisionModel>) -> Result<Arbiter, ArbitrationError> {
        if collision.robot().joint_names() != self.robot.joint_names() {
            return Err(ArbitrationError::OtherRobot);
        }
        Ok(Arbiter {
            robot: self.robot.clone(),
            collision,
            gripper: self.gripper,
            goals: self.goals.clone(),
            settings: self.settings,
            learned: self.learned.clone(),
        })
    }
}

/// Whether the human command is a task command, and its dimension.
pub(crate) fn task_dim(command: &HumanCommand<'_>) -> Option<usize> {
    match command {
        HumanCommand::Linear(_) => Some(3),
        HumanCommand::Twist(_) => Some(6),
        HumanCommand::Joint(_) => None,
    }
}
