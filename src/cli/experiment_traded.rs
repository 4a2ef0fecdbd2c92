//! `tandem experiment traded`: Table 7.3 and Fig. 7.9 of the dissertation.

use crate::experiments::traded::{PredictorKind, TradedExperimentSettings, TradedSettings};
use std::path::PathBuf;

/// Arguments of `tandem experiment traded`.
#[derive(Debug, clap::Args)]
pub struct TradedArgs {
    /// Episodes per user (1 … 100000); each episode picks the three objects
    /// and is run in every planning mode on the same demonstrations.
    #[arg(long, default_value_t = 12, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub episodes: u32,
    /// Seed of the demonstrations, the training and the planner.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Consecutive equal predictions (frames at 180 Hz) that commit a target.
    #[arg(long, default_value_t = 80)]
    pub commit_steps: usize,
    /// Frames at the start of each demonstration whose predictions are ignored.
    #[arg(long, default_value_t = 300)]
    pub discard_steps: usize,
    /// Charge this planning time (s) per plan instead of the measured one
    /// (makes the times exactly reproducible; e.g. the dissertation's planner
    /// took seconds), 0 to 3600.
    #[arg(long, value_name = "SECONDS", value_parser = |s: &str| super::number_in(s, 0.0..=MAX_PLANNING_LATENCY))]
    pub planning_latency: Option<f64>,
    /// The predictor driving the robot: the trained classifier (the
    /// dissertation's) or the Bayesian goal posterior over the palm path
    /// (baseline).
    #[arg(long, default_value = "network", value_parser = ["network", "posterior"])]
    pub predictor: String,
    /// Training demonstrations per (object, direction) for the classifier.
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u32).range(3..=100_000))]
    pub training: u32,
    /// Worker threads (default: all cores); results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object: {"episodes", "results": [{"user", "mode",
    /// "time_until_execution_s": [mean, std], "episode_s": [mean, std],
    /// "goal_accuracy", "direction_accuracy", "planning_s": [mean, std],
    /// "plans_per_pick", "solved"}, ...], "curves": [...]}.
    #[arg(long)]
    pub json: bool,
    /// Folder for Fig. 7.9 (traded_accuracy.svg) and the results (traded.json).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

pub(super) fn traded(args: &TradedArgs) -> Result<(), Box<dyn std::error::Error>> {
    if args.commit_steps == 0 {
        return Err("--commit-steps must be at least 1".into());
    }
    let settings = TradedExperimentSettings {
        episodes: args.episodes as usize,
        seed: args.seed,
        loop_settings: TradedSettings {
            commit_steps: args.commit_steps,
            discard_steps: args.discard_steps,
            planning_latency: args.planning_latency,
            ..TradedSettings::default()
        },
        training_per_class: args.training as usize,
        predictor: if args.predictor == "posterior" { PredictorKind::Posterior } else { PredictorKind::Network },
        ..TradedExperimentSettings::default()
    };
    super::harness::run_in_harness(&settings, args.threads, args.json, args.out.clone())
}

/// Longest planning latency `--planning-latency` charges (s): an hour.
const MAX_PLANNING_LATENCY: f64 = 3600.0;
