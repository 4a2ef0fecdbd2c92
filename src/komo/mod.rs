//! KOMO-style trajectory optimization: a k-order sum-of-squares problem
//! over configurations `q_1 … q_T` with equality and inequality
//! constraints, solved by the augmented-Lagrangian / Levenberg-Marquardt
//! solver of `tandem_solvers` on its block-banded normal equations.
//!
//! A problem is a list of [`Objective`]s — (feature, time span, kind,
//! scale, target, order) — over features with analytic Jacobians: joint
//! state, joint limits, frame position, position difference, scalar
//! product of frame axes, orientation difference and pairwise collision
//! distance. Order-1 and order-2 objectives difference a feature over
//! consecutive slices (`τ = duration / T` apart); the `k` configurations
//! before `q_1` are the start, at rest. Objectives come from problem files
//! ([`TrajectoryProblem::from_problem`]) or are built in Rust. Planning
//! the initial path, validating the result and accepting it are the
//! [pipeline](crate::pipeline)'s.
//!
//! ```
//! use tandem::komo::{Initialization, TrajectoryOptimizer, TrajectoryProblem, trajectory_solver_settings};
//! use tandem::problem::Problem;
//! let problem = Problem::builtin("panda_reach")?;
//! let goal = [0.5, -0.3, 0.2, -2.0, 0.1, 1.8, 0.6];
//! let mut optimizer = TrajectoryOptimizer::new(TrajectoryProblem::from_problem(&problem)?, trajectory_solver_settings());
//! let result = optimizer.solve(Initialization::Interpolate(&goal))?;
//! println!("{} slices, cost {:.3}", result.trajectory.len(), result.report.cost);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod feature;
mod objective;
mod problem;
mod solve;

pub use feature::{Feature, FeatureWorkspace, FrameRef, JOINT_LIMIT_CUTOFF};
pub use objective::{Objective, TimeSpan, default_objectives, objective_from_spec};
pub use problem::{COLLISION_CUTOFF, Measures, TrajectoryProblem, TrajectoryWorkspace};
pub use solve::{
    Initialization, TrajectoryOptimizer, TrajectoryResult, stiff_solver_settings, trajectory_solver_settings,
};

use crate::collision::CollisionError;
use crate::robot::RobotError;
use thiserror::Error;

/// Errors setting up or running an optimization (a solve that does not
/// converge is not an error: see the report's termination).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum KomoError {
    /// An objective cannot be built or does not fit the problem.
    #[error("objective {name}: {message}")]
    Objective {
        /// The objective's name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// Horizon, order or duration out of range.
    #[error(transparent)]
    InvalidSetting(#[from] crate::settings::InvalidSetting),
    /// A workspace made for another problem.
    #[error("the workspace does not fit the problem")]
    ForeignWorkspace,
    /// An initialisation of the wrong shape or with bad values.
    #[error("initialisation: {0}")]
    Initialization(String),
    /// A grasp goal needs `robot.gripper`.
    #[error("the problem's goal needs robot.gripper")]
    NoGripper,
    #[error(transparent)]
    /// A robot-side error (bad configuration, unknown frame).
    Robot(#[from] RobotError),
    #[error(transparent)]
    /// The collision model cannot be built.
    Collision(#[from] CollisionError),
}
