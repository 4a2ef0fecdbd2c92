//! `tandem experiment traded`: Table 7.3 and Fig. 7.9 of the seed.

use crate::data::Progress;
use crate::figures::{Panel, Series, render_panels};
use crate::sim::traded::{
    PredictorKind, TradedExperimentSettings, TradedResults, TradedSettings, run_traded_experiment,
};
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
    /// (makes the times exactly reproducible; e.g. the seed's planner took
    /// seconds).
    #[arg(long, value_name = "SECONDS")]
    pub planning_latency: Option<f64>,
    /// The predictor driving the robot: the trained classifier (the seed's)
    /// or the Bayesian goal posterior over the palm path (baseline).
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
    if let Some(l) = args.planning_latency
        && !(l.is_finite() && l >= 0.0)
    {
        return Err(format!("--planning-latency must be a non-negative number of seconds, got {l}").into());
    }
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
    let total = 3 * settings.episodes as u64;
    let progress =
        if args.json { Progress::quiet() } else { Progress::auto() }.start_counting(total, "episodes", false);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(args.threads.unwrap_or(0)).build()?;
    let results = pool.install(|| run_traded_experiment(&settings, &|| progress.sample_done(true)))?;
    progress.finish();
    let json = traded_json(&results);
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
        };
        write("traded.json", serde_json::to_string_pretty(&json)?)?;
        write("traded_accuracy.svg", accuracy_figure(&results)?)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_table(&results);
        if let Some(dir) = &args.out {
            println!("wrote traded.json and traded_accuracy.svg to {}", dir.display());
        }
    }
    Ok(())
}

/// The `--json` object.
pub fn traded_json(r: &TradedResults) -> serde_json::Value {
    serde_json::json!({
        "episodes": r.episodes,
        "results": r.rows,
        "curves": r.curves,
        "training_s": r.training_seconds,
    })
}

fn print_table(r: &TradedResults) {
    println!(
        "{:<8} {:<11} {:>16} {:>16} {:>6} {:>6} {:>14} {:>6}",
        "user", "mode", "until exec (s)", "episode (s)", "goal", "dir", "plan (ms)", "plans"
    );
    for row in &r.rows {
        println!(
            "{:<8} {:<11} {:>7.2} ± {:<6.2} {:>7.2} ± {:<6.2} {:>6.2} {:>6.2} {:>6.1} ± {:<5.1} {:>6.2}",
            row.user,
            row.mode,
            row.time_until_execution_s[0],
            row.time_until_execution_s[1],
            row.episode_s[0],
            row.episode_s[1],
            row.goal_accuracy,
            row.direction_accuracy,
            1e3 * row.planning_s[0],
            1e3 * row.planning_s[1],
            row.plans_per_pick,
        );
    }
    println!("{} episodes per user; classifier trained in {:.1} s", r.episodes, r.training_seconds);
}

/// Fig. 7.9: goal and direction accuracy over normalised demonstration
/// time, one panel per predictor, a line per user.
fn accuracy_figure(r: &TradedResults) -> Result<String, Box<dyn std::error::Error>> {
    let mut panels = vec![];
    for predictor in ["network", "posterior"] {
        let mut panel = Panel::new(predictor, "normalised time", "accuracy").ranges((0.0, 1.0), (0.0, 1.05));
        for (i, c) in r.curves.iter().filter(|c| c.predictor == predictor).enumerate() {
            let goal: Vec<(f64, f64)> = c.time.iter().copied().zip(c.goal.iter().copied()).collect();
            let dir: Vec<(f64, f64)> = c.time.iter().copied().zip(c.direction.iter().copied()).collect();
            panel = panel.with(Series::line(&format!("{} goal", c.user), &goal, i));
            panel = panel.with(Series::dashed(&format!("{} direction", c.user), &dir, i));
        }
        panels.push(panel);
    }
    Ok(render_panels("grasp-intent accuracy over the demonstration (Fig. 7.9)", &panels, 420, 360)?)
}
