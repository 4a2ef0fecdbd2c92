//! The kinematic simulator: a velocity-controlled arm, simulated operators
//! (seed §5.5.2) and shared-control episodes through an
//! [`Arbiter`](crate::arbitration::Arbiter).
//!
//! ```no_run
//! use tandem::arbitration::{Arbiter, ArbiterSettings, GoalOptions, problem_goals};
//! use tandem::problem::Problem;
//! use tandem::sim::{Approach, Episode, EpisodeSettings, TaskJudge};
//! let problem = Problem::builtin("panda_grasp_box")?;
//! let goals = problem_goals(&problem, &GoalOptions::default())?;
//! let arbiter = Arbiter::for_problem(&problem, &goals, ArbiterSettings::default())?;
//! let mut judge = TaskJudge::new(&goals[0]);
//! let episode = Episode { arbiter: &arbiter, start: &problem.start, target: goals[0].position, true_goal: 0, settings: EpisodeSettings::default() };
//! let record = episode.run(&mut arbiter.workspace(), &mut Approach::default(), &mut |q| judge.succeeded(q))?;
//! println!("{} after {} ticks", record.outcome.as_str(), record.steps);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#[cfg(feature = "experiments")]
mod arbitration_env;
mod episode;
mod judge;
mod operator;
#[cfg(feature = "experiments")]
mod planar;
#[cfg(feature = "experiments")]
mod reach_grasp;
#[cfg(feature = "learn")]
pub mod traded;

#[cfg(feature = "experiments")]
pub use arbitration_env::{
    ArbitrationEnv, ArbitrationEnvSettings, EnvOutcome, EnvTask, RewardKind, StepResult, reward,
};
pub use episode::{Episode, EpisodeRecord, EpisodeSettings, LiveEpisode, LiveStep, Outcome, percentiles};
pub use judge::{GRASP_MAX_TILT, REACH_TOLERANCE, TaskJudge};
pub use operator::{
    Approach, Biased, Laggy, Noisy, Observation, Operator, OperatorAction, Pace, PolicyFollower, Straightline,
};
#[cfg(feature = "experiments")]
pub use planar::{
    PLANAR_METHODS, PlanarEpisode, PlanarResults, PlanarSettings, PlanarTask, PlanarUser, mean_std, run_planar,
    sample_planar_task,
};
#[cfg(feature = "experiments")]
pub use reach_grasp::{
    Arm, Cell, EpisodeSummary, Method, OperatorKind, ReachGraspResults, ReachGraspSettings, Task, run_reach_grasp,
    sample_task,
};
