//! `tandem learn arbitration` (DDPG with the disagreement reward, the
//! dissertation's chapter 6) and `tandem experiment learned` (Table 6.1,
//! Fig. 6.4, Fig. 6.5).

use crate::experiments::learned::{LearnedExperiment, LearnedExperimentSettings, train_and_save};
use crate::learn::{DdpgSettings, TrainingEpisode};
use crate::sim::RewardKind;
use std::path::PathBuf;

/// Arguments of `tandem learn arbitration`.
#[derive(Debug, clap::Args)]
pub struct LearnArbitrationArgs {
    /// Training episodes.
    #[arg(long, default_value_t = 300, value_parser = |s: &str| super::number_in(s, 1usize..=1_000_000))]
    pub episodes: usize,
    /// The reward: `combined` (r_agree + r_env, Algorithm 5) or
    /// `environment` (r_env only).
    #[arg(long, default_value = "combined", value_parser = ["combined", "environment"])]
    pub reward: String,
    /// Seed of the weights, tasks, users, noise and minibatches.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The actor file to write (safetensors); the training log goes to FILE
    /// with extension .json, the training curves to .svg.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Print a summary as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Arguments of `tandem experiment learned`.
#[derive(Debug, clap::Args)]
pub struct LearnedExperimentArgs {
    /// Episodes per user and method (1 … 100000).
    #[arg(long, default_value_t = 100, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub episodes: usize,
    /// Seed of the evaluation tasks and users (training uses 0, 1, …).
    #[arg(long, default_value_t = 1000)]
    pub seed: u64,
    /// Trained combined-reward actors, one per training seed (else they are
    /// trained here). The training logs `tandem learn arbitration` wrote
    /// beside them (FILE.json) feed Fig. 6.4; the table uses the actor whose
    /// last 50 training episodes earned the most.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    pub combined: Vec<PathBuf>,
    /// Trained environment-reward actors, as for --combined.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    pub environment: Vec<PathBuf>,
    /// Training episodes of each actor trained here.
    #[arg(long, default_value_t = 300, value_parser = |s: &str| super::number_in(s, 1usize..=1_000_000))]
    pub train_episodes: usize,
    /// Training seeds per reward, trained side by side on the cores (Fig.
    /// 6.4 averages them; the table uses the seed whose last 50 episodes
    /// earned the most, as the dissertation does).
    #[arg(long, default_value_t = 2, value_parser = |s: &str| super::number_in(s, 1usize..=100))]
    pub train_seeds: usize,
    /// Worker threads for the evaluation (default: all cores); results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object: {"episodes", "results": [{"user", "method",
    /// "success", "collision", "travel_cm": [mean, std]}, ...],
    /// "training": {"episodes", "seconds"}}.
    #[arg(long)]
    pub json: bool,
    /// Folder for the actors, the training logs, Fig. 6.4
    /// (training_curves.svg), Fig. 6.5 (authority.svg) and learned.json.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

fn reward_kind(name: &str) -> RewardKind {
    if name == "environment" { RewardKind::Environment } else { RewardKind::Combined }
}

pub(super) fn learn_arbitration(args: &LearnArbitrationArgs) -> Result<(), Box<dyn std::error::Error>> {
    let settings = DdpgSettings {
        episodes: args.episodes,
        reward: reward_kind(&args.reward),
        seed: args.seed,
        progress: !args.quiet && !args.json,
        ..DdpgSettings::default()
    };
    let report = train_and_save(&settings, &args.out)?;
    let last: Vec<&TrainingEpisode> = report.episodes.iter().rev().take(50).collect();
    let success = last.iter().filter(|e| e.outcome == "success").count() as f64 / last.len().max(1) as f64;
    if args.json {
        let summary = serde_json::json!({
            "episodes": args.episodes, "reward": args.reward, "seconds": report.seconds,
            "last_50_success": success, "out": args.out,
        });
        println!("{summary}");
        return Ok(());
    }
    println!(
        "trained the {} arbiter for {} episodes in {:.1} s; success over the last {} episodes {:.0} %",
        args.reward,
        args.episodes,
        report.seconds,
        last.len(),
        100.0 * success
    );
    println!(
        "wrote {}, {} and {}",
        args.out.display(),
        args.out.with_extension("json").display(),
        args.out.with_extension("svg").display()
    );
    Ok(())
}

pub(super) fn experiment_learned(args: &LearnedExperimentArgs) -> Result<(), Box<dyn std::error::Error>> {
    let experiment = LearnedExperiment {
        table: LearnedExperimentSettings { episodes: args.episodes, seed: args.seed, ..Default::default() },
        combined: args.combined.clone(),
        environment: args.environment.clone(),
        train_episodes: args.train_episodes,
        train_seeds: args.train_seeds,
    };
    let out = args.out.clone().unwrap_or_else(|| std::env::temp_dir().join("tandem-learned"));
    super::harness::run_in_harness(&experiment, args.threads, args.json, Some(out))
}
