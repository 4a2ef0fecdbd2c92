//! Shared control every tick: blend the operator's command with the robot
//! policies so the operator keeps authority while the robot prevents
//! collisions and fixes what the operator overlooks (the dissertation's
//! chapters 4–5; `docs/design.md`, "One arbitration tick").
//!
//! An [`Arbiter`] holds the robot, its collision model, the goals (each a
//! world point for intent and a [`RobotPolicy`](crate::control::RobotPolicy)
//! that reaches it) and [`ArbiterSettings`]; it is immutable and shared. Each
//! control loop owns an [`ArbiterWorkspace`]. [`Arbiter::tick`] takes the
//! state and the operator's [`HumanCommand`] and returns a [`Command`]: the
//! joint velocity for one period, a [`TickStatus`] from a closed set, and
//! [`Diagnostics`]. A tick never panics and allocates nothing of its own;
//! only a Clarabel solve (`Constrained`'s cone, by default) allocates, one
//! small map in Clarabel's internal timers.
//!
//! A tick runs in stages, each filling its part of the workspace (see
//! [`workspace`]): inputs validated (a wrong length or a NaN gives a hold
//! and a status, no solve); the goal posterior updated
//! ([`IntentEstimator`]); each goal's robot action queried; the mode's
//! metric recovered from the policies ([`metric`](self#metrics)); the
//! [`ArbitrationMode`]'s objective built (damped least squares near
//! singularities); hard constraints added (joint position and velocity
//! limits, linearised distances ≥ margin for the pairs within reach); the
//! problem solved — the closed form when it meets every constraint, else
//! the exact active-set solver on the violated rows (Clarabel for the
//! `Constrained` mode's cone, or when the active set cannot finish; see
//! [`SolverBackend`]); the step certified against the exact geometry.
//!
//! # Metrics
//! See the [`metric`] module: the Hessian metric of eq. 5.5–5.6 from
//! `1 + n(n+3)/2` policy queries, the Fisher metric of Algorithm 3 by
//! locally weighted regression, both repaired (eigenvalue floor, mean
//! eigenvalue 1) and combined over goals by belief (Algorithm 2).
//!
//! ```
//! use std::sync::Arc;
//! use tandem::arbitration::{Arbiter, ArbiterGoal, ArbiterSettings, ArbitrationMode, HumanCommand, TickInput};
//! use tandem::collision::CollisionModel;
//! use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
//! use tandem::trajectory::JointTrajectory;
//! use tandem::robot::RobotModel;
//!
//! let panda = Arc::new(RobotModel::panda());
//! let collision = Arc::new(CollisionModel::builder(panda.clone()).build()?);
//! let ready = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
//! let goal = [0.4, -0.3, 0.1, -2.0, 0.0, 1.8, 0.7];
//! let reference = JointTrajectory::minimum_jerk(panda.joint_names().to_vec(), &ready, &goal, 3.0, 0.05)?;
//! let policy = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant)?;
//! let goals = vec![ArbiterGoal { name: "reach".into(), position: [0.5, 0.0, 0.3], policy: Arc::new(policy) }];
//! let settings = ArbiterSettings { mode: ArbitrationMode::SumOfSquares, ..ArbiterSettings::default() };
//! let arbiter = Arbiter::new(collision, "panda_hand_tcp", goals, settings)?;
//! let mut ws = arbiter.workspace();
//! // The operator pushes the gripper forward at 10 cm/s.
//! let command = arbiter.tick(&mut ws, &TickInput::new(&ready, HumanCommand::Linear(&[0.1, 0.0, 0.0])));
//! assert_eq!(command.qdot.len(), 7);
//! // A NaN never reaches the robot: the tick holds and says why.
//! let bad = arbiter.tick(&mut ws, &TickInput::new(&ready, HumanCommand::Linear(&[f64::NAN, 0.0, 0.0])));
//! assert!(bad.qdot.iter().all(|v| *v == 0.0));
//! assert_eq!(bad.status, tandem::arbitration::TickStatus::InvalidCommand);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod arbiter;
mod command;
pub mod decision;
mod field;
mod intent;
mod learned;
pub mod metric;
mod modes;
mod motion;
mod objective;
mod repulsion;
mod safety;
mod settings;
mod setup;
mod solve;
mod tick;
pub mod workspace;

pub use arbiter::{Arbiter, ArbiterGoal};
pub use command::{Command, Diagnostics, HumanCommand, TickInput, TickStatus, limit_speed};
pub use field::{FieldSample, metric_field};
pub use intent::{IntentEstimator, IntentSettings};
pub use learned::{ArbitrationPolicy, StateLayout};
pub use metric::{Metric, MetricSettings};
pub use modes::{ArbitrationMode, BlendingStyle, MetricSpace, ModeSettings, UnknownMode};
pub use motion::{MotionAudit, MotionStage, brake_velocity, stopping_distance};
pub use repulsion::ObstacleRepulsion;
pub use safety::{SafetyRows, SafetySettings};
pub use settings::{ArbiterSettings, DampingSettings, SolverBackend};
pub use setup::{GoalObjects, GoalSettings, ProblemGoal, problem_goals};
pub use workspace::{ArbiterWorkspace, SolvedProblem};

use crate::robot::RobotError;

/// Errors building an [`Arbiter`] (ticks never fail: they return a status).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ArbitrationError {
    /// A goal policy for another number of joints.
    #[error("goal '{goal}': its policy has {got} joints, the robot {expected}")]
    PolicyDof {
        /// The goal.
        goal: String,
        /// The robot's joints.
        expected: usize,
        /// The policy's joints.
        got: usize,
    },
    /// A goal position with NaN or an infinity.
    #[error("goal '{goal}': its position is not finite")]
    GoalPosition {
        /// The goal.
        goal: String,
    },
    /// A setting out of its range (its path, as `safety.margin`).
    #[error(transparent)]
    InvalidSetting(#[from] crate::settings::InvalidSetting),
    /// The gripper frame (or another robot-side input) is wrong.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// [`ArbitrationMode::Learned`] asked of an arbiter without a policy
    /// ([`Arbiter::with_arbitration_policy`]).
    #[error(
        "the learned arbitration mode needs a trained arbitration actor (from `tandem learn arbitration`: \
         --arbiter FILE on the command line, Arbiter::with_arbitration_policy in Rust); none is loaded"
    )]
    NoArbitrationPolicy,
    /// An arbitration policy trained for another number of goals (or with
    /// an invalid layout).
    #[error(
        "the arbitration policy was trained for {goals} goals in {task_dims} task dimensions; this arbiter has {expected_goals} goals in {expected_task_dims} (2 for a planar robot's x-y, 3 for an arm)"
    )]
    PolicyLayout {
        /// The arbiter's goals.
        expected_goals: usize,
        /// The arbiter's task dimensions ([`Arbiter::task_dims`]).
        expected_task_dims: usize,
        /// The policy's goals.
        goals: usize,
        /// The policy's task dimensions.
        task_dims: usize,
    },
    /// A collision model of another robot than the arbiter's (other
    /// joints).
    #[error("the collision model is of another robot: its joints differ from the arbiter's")]
    OtherRobot,
    /// The problem names no gripper frame (`robot.gripper`).
    #[error("the problem names no gripper frame (robot.gripper): task commands and intent need one")]
    NoGripper,
    /// A goal's reference could not be optimized.
    #[error("goal '{goal}': the optimizer ended '{status}', no reference to track")]
    GoalNotReached {
        /// The goal.
        goal: String,
        /// How the optimizer ended.
        status: &'static str,
    },
    /// A problem file or retargeting error.
    #[error(transparent)]
    Problem(#[from] crate::problem::ProblemError),
    /// A goal's reference could not be planned or optimized.
    #[error(transparent)]
    Pipeline(#[from] crate::pipeline::PipelineError),
    /// The collision model could not be built.
    #[error(transparent)]
    Collision(#[from] crate::collision::CollisionError),
    /// A tracking policy could not be built.
    #[error(transparent)]
    Control(#[from] crate::control::ControlError),
    /// A scene edit failed.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
}
