//! The pipeline of one problem, from a problem file to a policy:
//! plan (IK of the goal, RRT-Connect, shortcutting) → optimize (KOMO, from
//! the planned path) → validate (collision-free between slices at fine
//! resolution, within limits; re-optimized with collision rows between
//! slices while it is not) → accept (at the goal, the grasp judged,
//! retried with another seed or the flipped grasp) → a reference
//! ([`ProblemSolution::reference`]) and its LQR tracking policy
//! ([`ProblemSolution::tracking_policy`]).
//!
//! `tandem solve`, bulk generation ([`crate::data`]), the arbiter's goals,
//! the experiments and the Python package all run this one pipeline.
//!
//! ```
//! use tandem::control::{GainSchedule, TrackingWeights};
//! use tandem::pipeline::{SolveSettings, solve_problem};
//! use tandem::problem::Problem;
//! let problem = Problem::builtin("panda_reach")?;
//! let solution = solve_problem(&problem, &SolveSettings::default())?;
//! assert!(solution.converged() && solution.validation.collision_free);
//! let policy = solution.tracking_policy(&problem.start, TrackingWeights::default(), GainSchedule::Constant)?;
//! assert_eq!(policy.reference().len(), solution.trajectory.len() + 1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod accept;
mod solve;
mod validate;

pub use accept::{Accepted, MAX_ATTEMPTS, MAX_EVALUATIONS, PipelineSettings, Rejected, solve_accepted};
pub use solve::{InitialGuess, ProblemSolution, SolveSettings, solve_problem};
pub use validate::{GoalMiss, Validation, goal_miss, judge_grasp, validate};

use crate::komo::KomoError;
use crate::plan::PlanError;
use thiserror::Error;

/// Errors running the pipeline (a solve that does not converge is not an
/// error: see [`ProblemSolution::status`]).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// The optimizer cannot be set up (objectives, horizon, collision model).
    #[error(transparent)]
    Optimizer(#[from] KomoError),
    /// Planning the initial path failed outright (unreachable IK goals, a
    /// collision model that cannot be built).
    #[error("planning the initial path: {0}")]
    Plan(Box<PlanError>),
    /// A configuration the robot model rejects.
    #[error(transparent)]
    Robot(#[from] crate::robot::RobotError),
}

impl From<PlanError> for PipelineError {
    fn from(e: PlanError) -> Self {
        PipelineError::Plan(Box::new(e))
    }
}
