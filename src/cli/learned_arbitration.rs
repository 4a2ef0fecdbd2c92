//! `tandem learn arbitration` (DDPG with the disagreement reward, the
//! seed's chapter 6) and `tandem experiment learned` (Table 6.1, Fig. 6.4,
//! Fig. 6.5).

use crate::data::Progress;
use crate::learn::arbitration_experiment::{
    LearnedExperimentSettings, LearnedMethod, LearnedResults, run_learned_experiment,
};
use crate::learn::{ArbitrationActor, DdpgReport, DdpgSettings, TrainingEpisode, figures, train_arbitration};
use crate::sim::RewardKind;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

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
    /// earned the most, as the seed does).
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

/// Trains one actor and writes it, its log and its curves.
fn train_and_save(settings: &DdpgSettings, out: &Path) -> Result<DdpgReport, Box<dyn std::error::Error>> {
    let report = train_arbitration(settings, &mut |_| {})?;
    report.actor.save(out)?;
    let json = out.with_extension("json");
    let log = serde_json::json!({ "seconds": report.seconds, "episodes": report.episodes });
    std::fs::write(&json, serde_json::to_string_pretty(&log)? + "\n")
        .map_err(|e| format!("cannot write {}: {e}", json.display()))?;
    let svg = out.with_extension("svg");
    let runs = vec![(settings.reward.as_str().to_string(), vec![report.episodes.clone()])];
    std::fs::write(&svg, figures::training_curves(&runs, 10)?)
        .map_err(|e| format!("cannot write {}: {e}", svg.display()))?;
    Ok(report)
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

/// Training logs per reward: one list of episodes per seed.
type TrainingLogs = Vec<(String, Vec<Vec<TrainingEpisode>>)>;

/// The actors of the table: loaded, or trained over several seeds (the
/// best by the return of its last 50 episodes). Returns them, the training
/// logs per reward, and the training seconds.
fn actors(
    args: &LearnedExperimentArgs,
    dir: &Path,
) -> Result<(Vec<LearnedMethod>, TrainingLogs, f64), Box<dyn std::error::Error>> {
    let mut methods = vec![];
    let mut logs = vec![];
    let mut seconds = 0.0;
    for (kind, given) in [(RewardKind::Combined, &args.combined), (RewardKind::Environment, &args.environment)] {
        let mut runs = vec![];
        let actor = if given.is_empty() {
            // One run per seed, side by side (each trains on one thread).
            let trained: Vec<Result<DdpgReport, String>> = (0..args.train_seeds as u64)
                .into_par_iter()
                .map(|seed| {
                    let settings =
                        DdpgSettings { episodes: args.train_episodes, reward: kind, seed, ..Default::default() };
                    let out = dir.join(format!("{}-{seed}.safetensors", kind.as_str()));
                    let report = train_and_save(&settings, &out).map_err(|e| e.to_string())?;
                    if !args.json {
                        eprintln!(
                            "trained {} (seed {seed}) in {:.0} s: {}",
                            kind.as_str(),
                            report.seconds,
                            out.display()
                        );
                    }
                    Ok(report)
                })
                .collect();
            let mut best = Best::default();
            for report in trained {
                let report = report?;
                seconds += report.seconds;
                best.offer(&report.episodes, report.actor);
                runs.push(report.episodes);
            }
            best.actor.ok_or("no training seed")?
        } else {
            let mut best = Best::default();
            for path in given {
                let actor = ArbitrationActor::load(path)?;
                match read_log(path) {
                    Some((episodes, trained)) => {
                        seconds += trained;
                        best.offer(&episodes, actor);
                        runs.push(episodes);
                    }
                    // Without a log, the first actor given.
                    None => best.offer(&[], actor),
                }
            }
            best.actor.ok_or("no actor given")?
        };
        if !runs.is_empty() {
            logs.push((kind.as_str().to_string(), runs));
        }
        methods.push(LearnedMethod { name: kind.as_str().into(), actor: Some(Arc::new(actor)) });
    }
    methods.push(LearnedMethod { name: "direct".into(), actor: None });
    Ok((methods, logs, seconds))
}

/// The actor whose last 50 training episodes earned the most.
#[derive(Default)]
struct Best {
    tail: f64,
    actor: Option<ArbitrationActor>,
}

impl Best {
    fn offer(&mut self, episodes: &[TrainingEpisode], actor: ArbitrationActor) {
        let tail: f64 = episodes.iter().rev().take(50).map(|e| e.episode_return).sum();
        if self.actor.is_none() || (!episodes.is_empty() && tail > self.tail) {
            *self = Best { tail, actor: Some(actor) };
        }
    }
}

/// The episodes and seconds of the training log beside `actor` (`None`
/// when absent or unreadable).
fn read_log(actor: &Path) -> Option<(Vec<TrainingEpisode>, f64)> {
    let text = std::fs::read_to_string(actor.with_extension("json")).ok()?;
    let log: serde_json::Value = serde_json::from_str(&text).ok()?;
    let episodes = serde_json::from_value(log.get("episodes")?.clone()).ok()?;
    Some((episodes, log.get("seconds")?.as_f64()?))
}

pub(super) fn experiment_learned(args: &LearnedExperimentArgs) -> Result<(), Box<dyn std::error::Error>> {
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new().num_threads(t.max(1)).build_global().ok();
    }
    let dir = args.out.clone().unwrap_or_else(|| std::env::temp_dir().join("tandem-learned"));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let (methods, logs, training_seconds) = actors(args, &dir)?;
    if !logs.is_empty() {
        let svg = dir.join("training_curves.svg");
        std::fs::write(&svg, figures::training_curves(&logs, 10)?)
            .map_err(|e| format!("cannot write {}: {e}", svg.display()))?;
    }
    let settings = LearnedExperimentSettings { episodes: args.episodes, seed: args.seed, ..Default::default() };
    let progress = if args.json { Progress::quiet() } else { Progress::auto() }.start_counting(
        args.episodes as u64,
        "episodes",
        false,
    );
    let results = run_learned_experiment(&settings, &methods, &|| progress.sample_done(true))?;
    progress.finish();
    let svg = dir.join("authority.svg");
    std::fs::write(&svg, figures::authority_curves(&results.curves)?)
        .map_err(|e| format!("cannot write {}: {e}", svg.display()))?;
    let json = summary_json(&results, args.train_episodes, training_seconds);
    std::fs::write(dir.join("learned.json"), serde_json::to_string_pretty(&json)? + "\n")?;
    if args.json {
        println!("{json}");
    } else {
        print_table(&results);
        println!("figures and results in {}", dir.display());
    }
    Ok(())
}

fn summary_json(results: &LearnedResults, train_episodes: usize, seconds: f64) -> serde_json::Value {
    let rows: Vec<serde_json::Value> = results
        .cells
        .iter()
        .map(|c| {
            serde_json::json!({
                "user": c.user, "method": c.method, "success": c.success,
                "collision": c.collision, "travel_cm": c.travel_cm, "tick_us": c.tick_us,
            })
        })
        .collect();
    serde_json::json!({
        "episodes": results.episodes,
        "results": rows,
        "training": { "episodes": train_episodes, "seconds": seconds },
        "fig_6_5": results.curves,
    })
}

fn print_table(results: &LearnedResults) {
    println!("Table 6.1 — {} episodes per cell (the seed's table had 15)", results.episodes);
    println!(
        "{:<10} {:<12} {:>8} {:>18} {:>10} {:>8}",
        "user", "method", "success", "travel (cm)", "collisions", "tick µs"
    );
    for c in &results.cells {
        println!(
            "{:<10} {:<12} {:>7.1}% {:>9.1} ± {:<6.1} {:>9.1}% {:>8.1}",
            c.user,
            c.method,
            100.0 * c.success,
            c.travel_cm[0],
            c.travel_cm[1],
            100.0 * c.collision,
            c.tick_us
        );
    }
}
