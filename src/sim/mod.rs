//! The kinematic simulator: a velocity-controlled arm, simulated operators
//! (§5.5.2 of the dissertation) and shared-control episodes through an
//! [`Arbiter`](crate::arbitration::Arbiter).
//!
//! ```no_run
//! use tandem::arbitration::{Arbiter, ArbiterSettings, GoalSettings, problem_goals};
//! use tandem::problem::Problem;
//! use tandem::sim::{Approach, Episode, EpisodeSettings, TaskJudge};
//! let problem = Problem::builtin("panda_grasp_box")?;
//! let goals = problem_goals(&problem, &GoalSettings::default())?;
//! let arbiter = Arbiter::for_problem(&problem, &goals, ArbiterSettings::default())?;
//! let mut judge = TaskJudge::new(&goals[0]);
//! let episode = Episode { arbiter: &arbiter, start: &problem.start, target: goals[0].position, true_goal: 0, settings: EpisodeSettings::default() };
//! let record = episode.run(&mut arbiter.workspace(), &mut Approach::default(), &mut judge)?;
//! println!("{} after {} ticks", record.outcome.as_str(), record.steps);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#[cfg(feature = "experiments")]
mod arbitration_env;
mod episode;
mod judge;
#[cfg(feature = "mujoco")]
pub mod mujoco;
mod operator;
mod physics;
mod reason;
#[cfg(feature = "data")]
mod record;
mod tasks;

#[cfg(feature = "experiments")]
pub use arbitration_env::{
    ArbitrationEnv, ArbitrationEnvSettings, EnvError, EnvOutcome, EnvTask, RewardKind, StepResult, reward,
};
pub use episode::{Episode, EpisodeRecord, EpisodeSettings, LiveEpisode, LiveStep, Outcome, percentiles};
pub use judge::{GRASP_MAX_TILT, Judge, REACH_TOLERANCE, TaskJudge};
// Shared with the learned policy's evaluation (the `learn` feature).
#[cfg(feature = "learn")]
pub(crate) use operator::distance;
pub use operator::{
    Approach, Biased, Laggy, Noisy, Observation, Operator, OperatorAction, OperatorKind, Pace, PlanarUser,
    PolicyFollower, Straightline,
};
pub use physics::PhysicsSettings;
pub use reason::Reason;
#[cfg(feature = "data")]
pub use record::write_episodes;
#[cfg(feature = "experiments")]
pub(crate) use tasks::mix;
pub use tasks::{Arm, PlanarTask, Task, sample_planar_task, sample_task};
