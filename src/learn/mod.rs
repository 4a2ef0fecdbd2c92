//! Learned robot policies (the dissertation's §3.3.1 and §3.3.3): a network
//! trained on tandem's own datasets that answers at any configuration,
//! for any goal it was trained on — including states no reference passes
//! through, where an LQR tracking policy only knows its one reference.
//!
//! - [`Demonstrations`] reads a dataset folder (`tandem generate`) and
//!   turns it into state-action [`Pairs`]: the input of [`features`] (gripper
//!   position, goal relative to it, goal rotation in the continuous 6-D form,
//!   `q`, obstacle slots) and the joint velocity as a unit direction and a norm.
//! - [`train()`] fits an MLP with candle (CPU, deterministic per seed) on the
//!   weighted sum of the two mean squared errors (§3.3.3).
//! - [`PolicyNetwork`] is the trained network at query time (hand-written
//!   `f32` layers, nothing allocated), saved as safetensors.
//! - [`LearnedPolicy`] conditions it on one goal and implements
//!   [`RobotPolicy`](crate::control::RobotPolicy), so an
//!   [`ArbiterGoal`](crate::arbitration::ArbiterGoal) can use it in every
//!   arbitration mode; its metric comes from its own queries.
//! - [`evaluate`] follows a policy alone from a task's start (kinematic
//!   steps, a collision check each step, the grasp judged by
//!   [`GraspJudge`](crate::problem::GraspJudge)), and [`dagger`] adds expert
//!   trajectories where the learned policy fails.
//!
//! This is the only module that knows the network crate. Loading and
//! querying a trained policy ([`PolicyNetwork`], [`LearnedPolicy`],
//! [`features`]) is always built; datasets, training, evaluation, DAgger
//! and figures need the `learn` feature (candle, Parquet, rayon).
//!
//! ```no_run
//! use std::sync::Arc;
//! use tandem::learn::{LearnedPolicy, PolicyNetwork};
//! use tandem::control::RobotPolicy;
//! use tandem::problem::Problem;
//! let network = Arc::new(PolicyNetwork::load("policy.safetensors".as_ref())?);
//! let problem = Problem::builtin("panda_grasp_box")?;
//! let policy = LearnedPolicy::for_problem(network, &problem)?;
//! let mut state = policy.new_workspace();
//! let mut qdot = vec![0.0; policy.dof()];
//! policy.act(&mut state, &problem.start, &vec![0.0; policy.dof()], &mut qdot)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod arbitration_actor;
#[cfg(feature = "learn")]
mod candle_reference;
#[cfg(feature = "learn")]
pub mod checkpoint;
#[cfg(feature = "learn")]
pub mod dagger;
#[cfg(feature = "learn")]
mod dataset;
#[cfg(feature = "learn")]
mod ddpg;
mod dense;
#[cfg(feature = "learn")]
pub mod evaluate;
pub mod features;
#[cfg(feature = "learn")]
pub mod grasp_intent;
#[cfg(feature = "learn")]
mod layers;
#[cfg(feature = "learn")]
pub mod loss;
mod network;
mod policy;
mod shipped;
#[cfg(feature = "learn")]
mod train;
#[cfg(feature = "learn")]
mod train_settings;

pub use arbitration_actor::{
    ARBITRATION_FORMAT, ARBITRATION_FORMAT_VERSION, ArbitrationActor, ArbitrationMeta, LayerShapes,
};
#[cfg(feature = "learn")]
pub use candle_reference::CandleNetwork;
#[cfg(feature = "learn")]
pub use dataset::{Augmentation, Demonstration, Demonstrations, InputView, Pairs, in_validation};
#[cfg(feature = "learn")]
pub use ddpg::{DdpgReport, DdpgSettings, TrainingEpisode, train_arbitration};
#[cfg(feature = "learn")]
pub use loss::{normalisation, speed_scale};
pub use network::{FORMAT, FORMAT_VERSION, NetworkWorkspace, PolicyMeta, PolicyNetwork};
pub use policy::{LearnedPolicy, LearnedPolicyWorkspace, problem_goal};
pub use shipped::{SHIPPED_POLICY_PATH, SHIPPED_POLICY_PROVENANCE, shipped_policy};
#[cfg(feature = "learn")]
pub use train::{train, train_on};
#[cfg(feature = "learn")]
pub use train_settings::{EpochLoss, LearnSettings, MAX_HIDDEN_LAYERS, MAX_HIDDEN_WIDTH, TrainReport, TrainSettings};

use std::path::PathBuf;

/// Errors reading data or policy files, training, or building a policy.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LearnError {
    /// A file or folder that cannot be read or written.
    #[error("cannot read or write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// A file that is not safetensors.
    #[error("{path} is not a safetensors file: {message}")]
    NotSafetensors {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// A policy file's metadata is missing, malformed or of another format.
    #[error("{path}: {message}")]
    Metadata {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A policy file without one of the network's tensors.
    #[error("{path}: tensor `{name}` is missing")]
    MissingTensor {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
    },
    /// A tensor of another element type than `f32`.
    #[error("{path}: tensor `{name}` has type {got}, expected F32")]
    TensorType {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// Its type.
        got: String,
    },
    /// A tensor whose shape does not fit the metadata's layer widths.
    #[error("{path}: tensor `{name}` has shape {got:?}, expected {expected:?}")]
    TensorShape {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// The shape the metadata implies.
        expected: Vec<usize>,
        /// The file's shape.
        got: Vec<usize>,
    },
    /// A tensor with NaN or infinite values (or a non-positive input scale).
    #[error("{path}: tensor `{name}` holds non-finite values (or a non-positive scale)")]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
    },
    /// A policy used with another robot, goal or dataset than it fits.
    #[error("{what}: expected {expected}, got {got}")]
    Mismatch {
        /// What differs (joints, gripper, task, …).
        what: String,
        /// What the policy or dataset needs.
        expected: String,
        /// What it was given.
        got: String,
    },
    /// A dataset folder or part file that cannot be used.
    #[error("dataset {path}: {message}")]
    Dataset {
        /// The folder or part file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A training setting out of range.
    #[error(transparent)]
    InvalidSetting(#[from] crate::settings::InvalidSetting),
    /// The network crate failed while training.
    #[error("training failed: {0}")]
    Training(String),
    /// A robot model error.
    #[error(transparent)]
    Robot(#[from] crate::robot::RobotError),
    /// A collision model error.
    #[error(transparent)]
    Collision(#[from] crate::collision::CollisionError),
    /// A grasp model error.
    #[error(transparent)]
    Grasp(#[from] crate::problem::GraspError),
    /// A tracking policy error.
    #[error(transparent)]
    Control(#[from] crate::control::ControlError),
    /// A demonstration that is not a valid trajectory.
    #[error(transparent)]
    Trajectory(#[from] crate::trajectory::TrajectoryError),
}
