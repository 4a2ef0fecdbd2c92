//! `tandem experiment policy`: the learned policy followed alone (beside
//! the LQR tracking policy and the dissertation's 92–97 %), DAgger rounds,
//! and shared control on top of either policy.

use crate::experiments::policy::PolicyExperiment;
use std::path::PathBuf;

/// Arguments of `tandem experiment policy`.
#[derive(Debug, clap::Args)]
pub struct PolicyExperimentArgs {
    /// Evaluation tasks (family samples 0 … N−1 of --seed).
    #[arg(long, default_value_t = 100, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub tasks: usize,
    /// Seed of the evaluation tasks (use another than the training data's).
    #[arg(long, default_value_t = 1000)]
    pub seed: u64,
    /// The problem family of the tasks and the data.
    #[arg(long, default_value = "problems/panda_grasp_family.toml", value_name = "FAMILY.toml")]
    pub family: PathBuf,
    /// A trained policy (default: the shipped one,
    /// policies/panda_grasp_family.safetensors, embedded in tandem).
    #[arg(long, value_name = "FILE", conflicts_with = "train")]
    pub policy: Option<PathBuf>,
    /// Train a policy in --out and evaluate it (on --data, or on a dataset
    /// of --train-count trajectories generated into OUT/data).
    #[arg(long)]
    pub train: bool,
    /// The policy's training data: joint histograms, success by distance
    /// from the data, DAgger (default: none; OUT/data with --train).
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Folder for the dataset, policy and figures.
    #[arg(long, default_value = "policy-experiment", value_name = "DIR")]
    pub out: PathBuf,
    /// Trajectories of the dataset --train generates (seed 0).
    #[arg(long, default_value_t = 2000, value_parser = |s: &str| super::number_in(s, 1u64..=crate::data::MAX_COUNT))]
    pub train_count: u64,
    /// Epochs of --train's training.
    #[arg(long, default_value_t = 30, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub epochs: usize,
    /// DAgger rounds after it (needs --data or --train).
    #[arg(long, default_value_t = 0, value_parser = |s: &str| super::number_in(s, 0usize..=100))]
    pub rounds: usize,
    /// Fresh tasks followed per DAgger round.
    #[arg(long, default_value_t = 200, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub round_tasks: usize,
    /// Epochs per DAgger round.
    #[arg(long, default_value_t = 10, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub round_epochs: usize,
    /// Tasks of the shared-control comparison (0: none).
    #[arg(long, default_value_t = 20, value_parser = |s: &str| super::number_in(s, 0usize..=100_000))]
    pub arbitration_tasks: usize,
    /// Skip the LQR policy (it optimizes a reference per task).
    #[arg(long)]
    pub no_lqr: bool,
    /// The shared-control arbiter's centres.
    #[command(flatten)]
    pub centers: super::arbiter_args::CenterArgs,
    /// Print one JSON object: {"tasks", "policy" ("shipped", "trained" or
    /// the file), "results": [{"policy", "success", "collision", "timeout",
    /// "no_reference", "failed"}], "failures": {"learned": {"reasons",
    /// "collision_phases", "collision_pairs"}, "lqr": {...}}, "training":
    /// {"samples", "pairs", "seconds"} (the shipped policy's from its
    /// provenance), "rounds": [...], "arbitration":
    /// [{"mode", "center" (κ), "policy", "success", ...}], "seed_success":
    /// [0.92, 0.97]}; rates are shares of the tasks.
    #[arg(long)]
    pub json: bool,
}

/// Runs `tandem experiment policy`.
pub(super) fn run_policy(args: &PolicyExperimentArgs) -> Result<(), Box<dyn std::error::Error>> {
    let experiment = PolicyExperiment {
        family: args.family.clone(),
        tasks: args.tasks,
        seed: args.seed,
        policy: args.policy.clone(),
        train: args.train,
        data: args.data.clone(),
        train_count: args.train_count,
        epochs: args.epochs,
        rounds: args.rounds,
        round_tasks: args.round_tasks,
        round_epochs: args.round_epochs,
        arbitration_tasks: args.arbitration_tasks,
        lqr: !args.no_lqr,
        modes: args.centers.apply(crate::arbitration::ModeSettings::default()),
    };
    super::harness::run_in_harness(&experiment, None, args.json, Some(args.out.clone()))
}
