//! The kinematic simulator: a velocity-controlled arm, simulated operators
//! (seed §5.5.2) and shared-control episodes through an
//! [`Arbiter`](crate::arbitration::Arbiter).
//!
//! ```no_run
//! use tandem::arbitration::{Arbiter, ArbiterSettings, GoalOptions, problem_goals};
//! use tandem::scene::Problem;
//! use tandem::sim::{Approach, EpisodeSettings, run_episode};
//! let problem = Problem::builtin("panda_grasp_box")?;
//! let goals = problem_goals(&problem, &GoalOptions::default())?;
//! let arbiter = Arbiter::for_problem(&problem, &goals, ArbiterSettings::default())?;
//! let goal = goals[0].final_gripper_pose()?;
//! let record = run_episode(&arbiter, &mut arbiter.workspace(), &problem.start, &goal, &mut Approach::default(), &EpisodeSettings::default())?;
//! println!("{} after {} ticks", record.outcome.as_str(), record.steps);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod episode;
mod operator;

pub use episode::{EpisodeRecord, EpisodeSettings, Outcome, percentiles, run_episode};
pub use operator::{Approach, Observation, Operator, Straightline};
