//! LQR tracking policies: the autonomous agent of shared control.
//!
//! A [`TrackingPolicy`] turns a joint-space reference ([`JointTrajectory`])
//! into a policy that can be queried at any configuration: it finds the
//! closest reference waypoint, forms the error state of the joint-space
//! double integrator, applies the LQR gain from the discrete algebraic
//! Riccati equation (constant, or time-varying along the reference) and
//! integrates the acceleration over one time step into a joint-velocity
//! command (the seed's Algorithm 1, §3.3.4). Queries follow the reference
//! by progress (a local search from the previous closest point, so
//! references that reverse or cross themselves are followed in order), are
//! O(1) amortised and allocate nothing. [`RobotPolicy`] is the interface the
//! arbiter queries; [`TrackingPolicy`] implements it.
//!
//! ```
//! use tandem::control::{GainSchedule, JointTrajectory, TrackingPolicy, TrackingWeights};
//! let joints = vec!["j1".to_string(), "j2".to_string()];
//! let reference = JointTrajectory::minimum_jerk(joints, &[0.0, 0.0], &[1.0, -0.5], 2.0, 0.01)?;
//! let policy = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant)?;
//! let mut ws = policy.workspace();
//! let mut command = [0.0; 2];
//! // Pushed 0.1 rad off the start against the motion of joint 2 (which
//! // heads to -0.5), the policy pulls joint 2 back down.
//! let found = policy.query(&mut ws, &[0.0, 0.1], None, &mut command)?;
//! assert_eq!(found.index, 0);
//! assert!(command[1] < 0.0);
//! # Ok::<(), tandem::control::ControlError>(())
//! ```

mod policy;
mod reference;
mod robot_policy;

pub use policy::{Feedforward, GainSchedule, PolicyQuery, PolicyWorkspace, TrackingPolicy, TrackingWeights};
pub use reference::JointTrajectory;
pub use robot_policy::{PolicyState, RobotPolicy};

use std::path::PathBuf;
use tandem_solvers::riccati::RiccatiError;

/// Errors building or querying a tracking policy.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    /// The time step is not positive and finite.
    #[error("time step {dt} s is not positive and finite")]
    InvalidTimeStep { dt: f64 },
    /// A duration that is not positive and finite.
    #[error("duration {duration} s is not positive and finite")]
    InvalidDuration { duration: f64 },
    /// A reference with no waypoint or no joint.
    #[error("the reference has no waypoint or no joint")]
    EmptyReference,
    /// A waypoint with the wrong number of values.
    #[error("waypoint {index} has {got} values, expected {expected}")]
    WaypointLength { index: usize, expected: usize, got: usize },
    /// A waypoint holding NaN or an infinity.
    #[error("waypoint {index}: joint '{joint}' has non-finite value {value}")]
    NonFiniteWaypoint { index: usize, joint: String, value: f64 },
    /// A reference file that could not be read.
    #[error("cannot read {path}: {message}")]
    Io { path: PathBuf, message: String },
    /// A malformed reference CSV.
    #[error("{path}:{line}: {message}")]
    Csv { path: PathBuf, line: usize, message: String },
    /// Weights that are not positive and finite.
    #[error("tracking weights must be positive and finite, got {weights:?}")]
    InvalidWeights { weights: TrackingWeights },
    /// The Riccati solve failed.
    #[error("Riccati solve failed: {0}")]
    Riccati(#[from] RiccatiError),
    /// A query vector of the wrong length.
    #[error("{what} has {got} values, expected {expected}")]
    WrongLength { what: &'static str, expected: usize, got: usize },
    /// A policy state made by another kind of policy.
    #[error("the policy state was made by another kind of policy")]
    ForeignState,
    /// A query vector holding NaN or an infinity.
    #[error("{what}[{index}] = {value} is not finite")]
    NonFinite { what: &'static str, index: usize, value: f64 },
}
