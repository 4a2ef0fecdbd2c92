//! The dissertation's experiments, one command each (feature
//! `experiments`; those with learned parts need `learn`), all run by one
//! [harness](run): the output folder checked first, a thread pool of the
//! asked size (results never depend on it), progress, then the results as
//! JSON (`NAME.json`), a table and figures.
//!
//! | experiment | dissertation | settings |
//! | --- | --- | --- |
//! | reach-and-grasp with simulated operators | Table 5.1, Fig. 5.4 | [`ReachGraspSettings`] |
//! | planar pick-and-place | Table 4.1, Fig. 4.5 | [`PlanarSettings`] |
//! | the learned robot policy alone, DAgger, shared control on it | §3.3.3, Fig. 3.8 | `policy::PolicyExperiment` |
//! | learned arbitration (DDPG) | Table 6.1, Figs. 6.4–6.5 | `learned::LearnedExperiment` |
//! | traded control from predicted intent | Table 7.3, Fig. 7.9 | `traded::TradedExperimentSettings` |
//!
//! Tasks, operators and judges are the simulator's ([`crate::sim`]).
//!
//! ```no_run
//! use tandem::data::Progress;
//! use tandem::experiments::{HarnessSettings, PlanarSettings, run};
//! let settings = PlanarSettings { tasks: 10, ..PlanarSettings::default() };
//! let harness = HarnessSettings { progress: Progress::quiet(), out: Some("results".into()), ..HarnessSettings::default() };
//! let report = run(&settings, &harness)?;
//! print!("{}", report.table);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod figures;
mod harness;
#[cfg(feature = "learn")]
pub mod learned;
mod planar;
#[cfg(feature = "learn")]
pub mod policy;
mod reach_grasp;
#[cfg(feature = "learn")]
pub mod traded;

pub use harness::{
    Context, Experiment, ExperimentError, HarnessSettings, MAX_THREADS, Report, mean_std, run, tidy_json,
};
pub use planar::{PLANAR_METHODS, PlanarEpisode, PlanarResults, PlanarSettings, run_planar};
pub use reach_grasp::{
    Agreement, Cell, EpisodeSummary, Method, PhysicsOutcome, ReachGraspResults, ReachGraspSettings, Simulator,
    run_reach_grasp,
};
