//! `tandem experiment policy` (split from `experiment.rs`, the seed's
//! shared-control experiments): the learned policy followed alone (beside
//! the LQR tracking policy and the seed's 92–97 %), DAgger rounds, and
//! shared control on top of either policy.

use super::learn::{PolicyReport, train_and_save};
use crate::arbitration::ArbitrationMode;
use crate::data::{GenerateSettings, Progress, generate};
use crate::learn::dagger::{DaggerSettings, expert_demonstrations, failure_states, restart};
use crate::learn::evaluate::{OutcomeCounts, Rollout, RolloutSettings, Task, nearest_distances};
use crate::learn::experiment::{GoalPolicy, follow_learned, follow_lqr, sample_tasks, shared_control};
use crate::learn::{Demonstrations, LearnOptions, PolicyNetwork, TrainSettings, figures, train_on};
use crate::problem::ProblemFamily;
use crate::sim::Outcome;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

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
    /// A trained policy (default: train one in --out).
    #[arg(long, value_name = "FILE")]
    pub policy: Option<PathBuf>,
    /// Its training data (default: OUT/data, generated when missing).
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Folder for the dataset, policy and figures.
    #[arg(long, default_value = "policy-experiment", value_name = "DIR")]
    pub out: PathBuf,
    /// Trajectories of the generated dataset (seed 0).
    #[arg(long, default_value_t = 2000, value_parser = |s: &str| super::number_in(s, 1u64..=crate::data::MAX_COUNT))]
    pub train_count: u64,
    /// Epochs of the first training.
    #[arg(long, default_value_t = 30, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub epochs: usize,
    /// DAgger rounds after it.
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
    /// Print one JSON object: {"tasks", "results": [{"policy", "success",
    /// "collision", "timeout", "no_reference", "failed"}], "training": {"samples",
    /// "pairs", "seconds"}, "rounds": [...], "arbitration": [...],
    /// "seed_success": [0.92, 0.97]}; rates are shares of the tasks.
    #[arg(long)]
    pub json: bool,
}

fn write(path: &Path, text: &str) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()).into())
}

fn rates(policy: &str, c: &OutcomeCounts) -> serde_json::Value {
    let n = c.total().max(1) as f64;
    serde_json::json!({
        "policy": policy,
        "success": c.success as f64 / n,
        "collision": c.collision as f64 / n,
        "timeout": c.timeout as f64 / n,
        "no_reference": c.no_policy as f64 / n,
        "failed": c.failed as f64 / n,
        "episodes": c.total(),
    })
}

fn counts(rollouts: &[Rollout]) -> OutcomeCounts {
    OutcomeCounts::from_outcomes(rollouts.iter().map(|r| r.outcome))
}

/// Runs `tandem experiment policy`.
pub(super) fn run_policy(args: &PolicyExperimentArgs) -> Result<(), Box<dyn std::error::Error>> {
    if args.tasks == 0 {
        return Err("--tasks must be at least 1".into());
    }
    let family = ProblemFamily::from_file(&args.family)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let say = |line: String| {
        if !args.json {
            println!("{line}");
        }
    };
    let data = args.data.clone().unwrap_or_else(|| args.out.join("data"));
    let progress = if args.json { Progress::quiet() } else { Progress::auto() };
    if args.policy.is_none() && !data.join("_manifest.json").exists() {
        say(format!("generating {} trajectories into {}", args.train_count, data.display()));
        let settings = GenerateSettings { count: args.train_count, seed: 0, ..GenerateSettings::default() };
        generate(&args.family, &data, &settings, &progress)?;
    }
    let options = LearnOptions {
        train: TrainSettings { epochs: args.epochs, progress: !args.json, ..TrainSettings::default() },
        ..LearnOptions::default()
    };
    let (network, report) = match &args.policy {
        Some(path) => (PolicyNetwork::load(path)?, PolicyReport::read_beside(path)),
        None => {
            let path = args.out.join("policy.safetensors");
            say(format!("training {} epochs on {}", args.epochs, data.display()));
            let (network, report) = train_and_save(&data, &family, &options, &path)?;
            say(format!("wrote {} ({:.1} s of training)", path.display(), report.seconds));
            (network, Some(report))
        }
    };
    let mut network = Arc::new(network);
    let mut demos = Demonstrations::read(&data)?;
    let states: Vec<Vec<f64>> = demos.items.iter().flat_map(|d| d.states.iter().cloned()).collect();
    let robot = &family.base.robot;
    write(
        &args.out.join("joint_histograms.svg"),
        &figures::joint_histograms(&states, robot.joint_names(), robot.limits(), 40)?,
    )?;
    let rollout = RolloutSettings::default();
    let began = Instant::now();
    let tasks = sample_tasks(&family, args.seed, args.tasks, rollout.max_tilt)?;
    let learned = follow_learned(&network, &tasks, &rollout)?;
    let learned_seconds = began.elapsed().as_secs_f64();
    let lqr = if args.no_lqr { None } else { Some(follow_lqr(&tasks, args.seed, &rollout)?) };
    let starts: Vec<Vec<f64>> = tasks.iter().map(|t| t.problem.start.clone()).collect();
    let distances = nearest_distances(&starts, &states);
    let mut by_distance = vec![("learned".to_string(), paired(&distances, &learned))];
    if let Some(lqr) = &lqr {
        by_distance.push(("lqr".to_string(), paired(&distances, lqr)));
    }
    write(&args.out.join("success_by_distance.svg"), &figures::success_by_distance(&by_distance, 5)?)?;
    let mut results = vec![rates("learned", &counts(&learned))];
    if let Some(lqr) = &lqr {
        results.push(rates("lqr", &counts(lqr)));
    }
    say(format!("{} tasks of {} (seed {}), followed alone at 15 Hz:", args.tasks, family.name, args.seed));
    print_table(args, &results);
    say(format!("learned rollouts: {learned_seconds:.1} s for {} tasks", args.tasks));
    let rounds = dagger(args, &family, &options, &mut network, &mut demos, &tasks, &rollout)?;
    let arbitration = arbitrate(args, &network, &tasks)?;
    if args.json {
        let training = report.as_ref().map_or(
            serde_json::Value::Null,
            |r| serde_json::json!({"samples": r.trajectories, "pairs": r.pairs, "seconds": r.seconds}),
        );
        let json = serde_json::json!({
            "tasks": args.tasks,
            "results": results,
            "training": training,
            "rounds": rounds,
            "arbitration": arbitration,
            "seed_success": [0.92, 0.97],
            "median_start_distance": median(&distances),
        });
        println!("{json}");
    } else {
        println!(
            "figures: {}, {}",
            args.out.join("joint_histograms.svg").display(),
            args.out.join("success_by_distance.svg").display()
        );
    }
    Ok(())
}

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn paired(distances: &[f64], rollouts: &[Rollout]) -> Vec<(f64, bool)> {
    distances
        .iter()
        .zip(rollouts)
        .map(|(d, r)| (*d, r.outcome == crate::learn::evaluate::RolloutOutcome::Success))
        .collect()
}

fn print_table(args: &PolicyExperimentArgs, results: &[serde_json::Value]) {
    if args.json {
        return;
    }
    println!("  {:<10} {:>9} {:>10} {:>9} {:>13}", "policy", "success", "collision", "timeout", "no reference");
    for r in results {
        let pct = |k: &str| 100.0 * r[k].as_f64().unwrap_or(f64::NAN);
        println!(
            "  {:<10} {:>7.1} % {:>8.1} % {:>7.1} % {:>11.1} %",
            r["policy"].as_str().unwrap_or(""),
            pct("success"),
            pct("collision"),
            pct("timeout"),
            pct("no_reference")
        );
    }
    println!("  {:<10} {:>9}   (seed §3.3.3, learned policy in configuration space)", "seed", "92–97 %");
}

/// DAgger rounds: fresh tasks (seed `args.seed + 1 + round`), expert
/// trajectories from the states of failed rollouts and from the starts
/// farthest from the data, training continued on everything; success on
/// the evaluation tasks after each round.
fn dagger(
    args: &PolicyExperimentArgs,
    family: &ProblemFamily,
    options: &LearnOptions,
    network: &mut Arc<PolicyNetwork>,
    demos: &mut Demonstrations,
    tasks: &[Task],
    rollout: &RolloutSettings,
) -> Result<Vec<serde_json::Value>, Box<dyn std::error::Error>> {
    let settings = DaggerSettings {
        rounds: args.rounds,
        tasks_per_round: args.round_tasks,
        epochs: args.round_epochs,
        ..DaggerSettings::default()
    };
    let mut rounds = Vec::new();
    let mut next_id = demos.items.iter().map(|d| d.id + 1).max().unwrap_or(0).max(1 << 40);
    for round in 1..=settings.rounds {
        let fresh = sample_tasks(family, args.seed + 1 + round as u64, settings.tasks_per_round, rollout.max_tilt)?;
        let followed = follow_learned(network, &fresh, rollout)?;
        let mut problems = Vec::new();
        for (task, r) in fresh.iter().zip(&followed) {
            for start in failure_states(r, settings.states_per_failure) {
                problems.push(restart(&task.problem, &start));
            }
        }
        let failed = problems.len();
        let states: Vec<Vec<f64>> = demos.items.iter().flat_map(|d| d.states.iter().cloned()).collect();
        let starts: Vec<Vec<f64>> = fresh.iter().map(|t| t.problem.start.clone()).collect();
        let distances = nearest_distances(&starts, &states);
        let mut order: Vec<usize> = (0..fresh.len()).collect();
        order.sort_by(|a, b| distances[*b].total_cmp(&distances[*a]));
        problems.extend(order.iter().take(settings.thin_per_round).map(|&k| fresh[k].problem.clone()));
        let generate = GenerateSettings { seed: args.seed + round as u64, ..GenerateSettings::default() };
        let (added, rejected) = expert_demonstrations(&problems, next_id, &generate);
        next_id += problems.len() as u64;
        let added_count = added.len();
        demos.items.extend(added);
        let continued = LearnOptions {
            train: TrainSettings {
                epochs: settings.epochs,
                seed: options.train.seed + round as u64,
                ..options.train.clone()
            },
            ..options.clone()
        };
        let (trained, report) = train_on(demos, family, &continued, Some(&**network))?;
        *network = Arc::new(trained);
        let path = args.out.join(format!("policy-round{round}.safetensors"));
        network.save(&path)?;
        let c = counts(&follow_learned(network, tasks, rollout)?);
        let fresh_success = counts(&followed).success_rate();
        if !args.json {
            println!(
                "DAgger round {round}: learned policy succeeded on {:.1} % of {} fresh tasks; {failed} failure states + {} thin starts -> {added_count} expert trajectories ({rejected} rejected); {:.1} s training; evaluation: success {:.1} %, collision {:.1} %, timeout {:.1} %",
                100.0 * fresh_success,
                fresh.len(),
                settings.thin_per_round.min(fresh.len()),
                report.seconds,
                100.0 * c.success_rate(),
                100.0 * c.collision as f64 / c.total().max(1) as f64,
                100.0 * c.timeout as f64 / c.total().max(1) as f64,
            );
        }
        let mut row = rates("learned", &c);
        row["round"] = round.into();
        row["added_trajectories"] = added_count.into();
        row["expert_rejected"] = rejected.into();
        row["training_seconds"] = report.seconds.into();
        row["trajectories"] = demos.items.len().into();
        rounds.push(row);
    }
    Ok(rounds)
}

/// Constrained and sum-of-squares arbitration on top of each policy.
fn arbitrate(
    args: &PolicyExperimentArgs,
    network: &Arc<PolicyNetwork>,
    tasks: &[Task],
) -> Result<Vec<serde_json::Value>, Box<dyn std::error::Error>> {
    let tasks = &tasks[..args.arbitration_tasks.min(tasks.len())];
    if tasks.is_empty() {
        return Ok(vec![]);
    }
    let mut rows = Vec::new();
    if !args.json {
        println!("shared control, Approach operator, {} tasks:", tasks.len());
    }
    for mode in [ArbitrationMode::Constrained, ArbitrationMode::SumOfSquares] {
        for which in [GoalPolicy::Learned, GoalPolicy::Lqr] {
            if which == GoalPolicy::Lqr && args.no_lqr {
                continue;
            }
            let outcomes = shared_control(network, tasks, mode, which, args.seed)?;
            let mut c = OutcomeCounts::default();
            for o in outcomes {
                match o {
                    Outcome::Success => c.success += 1,
                    Outcome::Collision => c.collision += 1,
                    Outcome::Timeout => c.timeout += 1,
                    Outcome::Failed => c.failed += 1,
                }
            }
            let mut row = rates(which.as_str(), &c);
            row["mode"] = mode.as_str().into();
            if !args.json {
                println!(
                    "  {:<12} on {:<8} success {:>5.1} %, collision {:>5.1} %, timeout {:>5.1} %",
                    mode.as_str(),
                    which.as_str(),
                    100.0 * c.success_rate(),
                    100.0 * c.collision as f64 / c.total() as f64,
                    100.0 * c.timeout as f64 / c.total() as f64
                );
            }
            rows.push(row);
        }
    }
    Ok(rows)
}
