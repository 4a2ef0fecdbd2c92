//! LQR tracking policies: the autonomous agent of shared control.
//!
//! A [`TrackingPolicy`] turns a joint-space reference
//! ([`JointTrajectory`](crate::trajectory::JointTrajectory))
//! into a policy that can be queried at any configuration: it finds the
//! closest reference waypoint, forms the error state of the joint-space
//! double integrator, applies the LQR gain from the discrete algebraic
//! Riccati equation (constant, or time-varying along the reference) and
//! integrates the acceleration over one time step into a joint-velocity
//! command (the dissertation's Algorithm 1, §3.3.4). Queries follow the
//! reference by progress (a local search from the previous closest point, so
//! references that reverse or cross themselves are followed in order), are
//! O(1) amortised and allocate nothing. [`RobotPolicy`] is the interface the
//! arbiter queries; [`TrackingPolicy`] implements it. [`timing`] keeps a
//! control loop's tick durations in fixed memory.
//!
//! ```
//! use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
//! use tandem::trajectory::JointTrajectory;
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
mod robot_policy;
pub mod timing;

pub use policy::{Feedforward, GainSchedule, PolicyQuery, PolicyWorkspace, TrackingPolicy, TrackingWeights};
pub use robot_policy::{RobotPolicy, RobotPolicyWorkspace};

use tandem_solvers::riccati::RiccatiError;

/// Shortest time step of a reference and of the control ticks (s): 10 kHz.
pub const MIN_TIME_STEP: f64 = 1e-4;
/// Longest time step (s): 1 Hz.
pub const MAX_TIME_STEP: f64 = 1.0;
/// Most joints of a reference: the policy solves Riccati equations of
/// twice that size (cubic cost); a humanoid has about 40.
pub const MAX_REFERENCE_JOINTS: usize = 64;
/// Range of each tracking weight ([`TrackingWeights`]): within it, and
/// with a time step in [`MIN_TIME_STEP`] ..= [`MAX_TIME_STEP`], the
/// Riccati equations are solved for every combination (tested at the corners).
pub const WEIGHT_RANGE: std::ops::RangeInclusive<f64> = 1e-4..=1e4;

/// Errors building or querying a tracking policy.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    /// A time step outside [`MIN_TIME_STEP`] ..= [`MAX_TIME_STEP`].
    #[error("time step {dt} s is outside [{MIN_TIME_STEP}, {MAX_TIME_STEP}] s")]
    InvalidTimeStep {
        /// Time step (s).
        dt: f64,
    },
    /// A reference with more than [`MAX_REFERENCE_JOINTS`] joints.
    #[error("the reference has {count} joints, more than {MAX_REFERENCE_JOINTS}")]
    TooManyJoints {
        /// How many joints it has.
        count: usize,
    },
    /// A trajectory that cannot be a reference (empty, non-finite, too
    /// long), or a reference file that cannot be read.
    #[error(transparent)]
    Trajectory(#[from] crate::trajectory::TrajectoryError),
    /// A tracking weight outside [`WEIGHT_RANGE`].
    #[error(
        "the {name} weight is {}, outside [{}, {}]",
        crate::settings::readable(*value),
        WEIGHT_RANGE.start(),
        WEIGHT_RANGE.end()
    )]
    InvalidWeight {
        /// Which weight: `position`, `velocity` or `control`.
        name: &'static str,
        /// The offending value.
        value: f64,
    },
    /// The Riccati solve failed.
    #[error("Riccati solve failed: {0}")]
    Riccati(#[from] RiccatiError),
    /// A query vector of the wrong length.
    #[error("{what} has {got} values, expected {expected}")]
    WrongLength {
        /// Which vector (`q`, `v`, …).
        what: &'static str,
        /// The length it should have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// A policy state made by another kind of policy.
    #[error("the policy state was made by another kind of policy")]
    ForeignState,
    /// A query vector holding NaN or an infinity.
    #[error("{what}[{index}] = {value} is not finite")]
    NonFinite {
        /// Which vector (`q`, `v`, …).
        what: &'static str,
        /// Index of the waypoint (or vector entry).
        index: usize,
        /// The offending value.
        value: f64,
    },
}
