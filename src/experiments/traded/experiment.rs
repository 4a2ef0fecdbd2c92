//! The traded-control experiment (the dissertation's Table 7.3, Fig. 7.9):
//! every user (Normal, Noisy, Biased) × planning mode (Early, Late,
//! Continuous) over seeded episodes of three picks, and the per-frame accuracy
//! of the intent predictors over normalised demonstration time.
//!
//! The classifier is trained once per run on demonstrations seeded apart
//! from the evaluation's. Episodes run in parallel; results do not depend on
//! the thread count (each episode has its own seed and its own planner).
//!
//! ```no_run
//! use tandem::experiments::traded::{TradedExperimentSettings, run_traded_experiment};
//! let r = run_traded_experiment(&TradedExperimentSettings { episodes: 4, ..Default::default() }, &|| {})?;
//! for row in &r.rows { println!("{} {} {:?}", row.user, row.mode, row.episode_s); }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::episode::{PlanningMode, TradedEpisode, TradedSettings, run_traded_episode};
use super::hand::{GraspDirection, HandUser, synthesize_reach};
use super::intent::{IntentPredictor, train_intent_classifier};
use super::robot::{TradedError, TradedScene};
use crate::arbitration::IntentSettings;
use crate::experiments::mean_std;
use rayon::prelude::*;

/// Which predictor drives the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PredictorKind {
    /// The candle classifier (the dissertation's).
    Network,
    /// The Bayesian goal posterior (baseline).
    Posterior,
}

/// Settings of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct TradedExperimentSettings {
    /// Episodes per user (each run in every mode; default 12).
    pub episodes: usize,
    /// Seed of everything.
    pub seed: u64,
    /// The loop's settings.
    pub loop_settings: TradedSettings,
    /// Training demonstrations per (object, direction) (default 60).
    pub training_per_class: usize,
    /// The predictor of the loop.
    pub predictor: PredictorKind,
    /// Demonstrations per user for the accuracy curve (default 60).
    pub curve_demonstrations: usize,
}

impl Default for TradedExperimentSettings {
    fn default() -> Self {
        TradedExperimentSettings {
            episodes: 12,
            seed: 0,
            loop_settings: TradedSettings::default(),
            training_per_class: 60,
            predictor: PredictorKind::Network,
            curve_demonstrations: 60,
        }
    }
}

/// One row of Table 7.3.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TradedRow {
    /// User name.
    pub user: &'static str,
    /// Mode name.
    pub mode: &'static str,
    /// Seconds from each demonstration's start to the robot's start, summed
    /// over the episode's three picks as in the dissertation (mean, std).
    pub time_until_execution_s: [f64; 2],
    /// Episode duration (three picks; mean, std).
    pub episode_s: [f64; 2],
    /// Fraction of picks whose object was predicted right.
    pub goal_accuracy: f64,
    /// Fraction of picks whose grasp direction was predicted right.
    pub direction_accuracy: f64,
    /// Measured wall-clock time per plan (s; mean, std).
    pub planning_s: [f64; 2],
    /// Plans per pick.
    pub plans_per_pick: f64,
    /// Fraction of plans that found a path.
    pub solved: f64,
}

/// Per-frame accuracy over normalised time (Fig. 7.9).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AccuracyCurve {
    /// Predictor name.
    pub predictor: &'static str,
    /// User name.
    pub user: &'static str,
    /// Bin centres of normalised time (0 = start, 1 = end).
    pub time: Vec<f64>,
    /// Object accuracy per bin.
    pub goal: Vec<f64>,
    /// Direction accuracy per bin.
    pub direction: Vec<f64>,
}

/// Results of the experiment.
#[derive(Debug, Clone)]
pub struct TradedResults {
    /// Episodes per user.
    pub episodes: usize,
    /// Table 7.3, users × modes.
    pub rows: Vec<TradedRow>,
    /// Fig. 7.9 curves, predictors × users.
    pub curves: Vec<AccuracyCurve>,
    /// The episodes, per user in order.
    pub runs: Vec<(HandUser, Vec<TradedEpisode>)>,
    /// Seconds to train the classifier.
    pub training_seconds: f64,
}

/// Bins of the accuracy curve.
pub const CURVE_BINS: usize = 20;

fn mix(seed: u64, a: u64, b: u64) -> u64 {
    let mut z = seed ^ a.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ b.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 30)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Runs the experiment; `progress` is called once per finished episode.
///
/// # Errors
/// Bad settings, planner setup or classifier errors.
pub fn run_traded_experiment(
    settings: &TradedExperimentSettings,
    progress: &(dyn Fn() + Sync),
) -> Result<TradedResults, TradedError> {
    if settings.episodes == 0 {
        return Err(crate::settings::InvalidSetting::new("episodes", 0, "at least 1").into());
    }
    let objects = settings.loop_settings.objects.len();
    if objects != 3 {
        return Err(crate::settings::InvalidSetting::new("loop_settings.objects", objects, "3 objects").into());
    }
    let objects = &settings.loop_settings.objects;
    let began = std::time::Instant::now();
    let network = IntentPredictor::Network(train_intent_classifier(
        objects,
        settings.training_per_class,
        mix(settings.seed, 1, 0),
    )?);
    let training_seconds = began.elapsed().as_secs_f64();
    let posterior = IntentPredictor::Posterior(IntentSettings::default());
    let scene = TradedScene::new(objects)?;
    let predictor = match settings.predictor {
        PredictorKind::Network => &network,
        PredictorKind::Posterior => &posterior,
    };
    let mut runs = vec![];
    let mut rows = vec![];
    for (u, user) in HandUser::ALL.into_iter().enumerate() {
        let per_episode: Result<Vec<Vec<TradedEpisode>>, TradedError> = (0..settings.episodes)
            .into_par_iter()
            .map(|e| {
                let seed = mix(settings.seed, 2 + u as u64, e as u64);
                let r = run_traded_episode(&scene, predictor, user, &PlanningMode::ALL, &settings.loop_settings, seed);
                progress();
                r
            })
            .collect();
        let episodes: Vec<TradedEpisode> = per_episode?.into_iter().flatten().collect();
        for mode in PlanningMode::ALL {
            rows.push(row(user, mode, episodes.iter().filter(|e| e.mode == mode)));
        }
        runs.push((user, episodes));
    }
    let mut curves = vec![];
    for p in [&network, &posterior] {
        for (u, user) in HandUser::ALL.into_iter().enumerate() {
            curves.push(accuracy_curve(
                p,
                user,
                objects,
                settings.curve_demonstrations,
                mix(settings.seed, 10 + u as u64, 0),
            )?);
        }
    }
    Ok(TradedResults { episodes: settings.episodes, rows, curves, runs, training_seconds })
}

fn row<'a>(user: HandUser, mode: PlanningMode, episodes: impl Iterator<Item = &'a TradedEpisode>) -> TradedRow {
    let episodes: Vec<&TradedEpisode> = episodes.collect();
    let picks: Vec<_> = episodes.iter().flat_map(|e| &e.picks).collect();
    let n = picks.len().max(1) as f64;
    let plans: Vec<f64> = episodes.iter().flat_map(|e| e.planning_seconds.iter().copied()).collect();
    TradedRow {
        user: user.as_str(),
        mode: mode.as_str(),
        time_until_execution_s: mean_std(episodes.iter().map(|e| e.picks.iter().map(|p| p.time_until_execution).sum())),
        episode_s: mean_std(episodes.iter().map(|e| e.episode_seconds)),
        goal_accuracy: picks.iter().filter(|p| p.grasped.0 == p.object).count() as f64 / n,
        direction_accuracy: picks.iter().filter(|p| p.grasped.1 == p.direction).count() as f64 / n,
        planning_s: mean_std(plans.iter().copied()),
        plans_per_pick: picks.iter().map(|p| p.plans as f64).sum::<f64>() / n,
        solved: picks.iter().filter(|p| p.solved).count() as f64 / n,
    }
}

/// Per-frame accuracy of `predictor` over normalised time, `count`
/// demonstrations of `user` (objects and directions cycled, all objects
/// available).
///
/// # Errors
/// Classifier errors.
pub fn accuracy_curve(
    predictor: &IntentPredictor,
    user: HandUser,
    objects: &[[f64; 3]],
    count: usize,
    seed: u64,
) -> Result<AccuracyCurve, TradedError> {
    let (mut hits, mut total) = ([[0.0; 2]; CURVE_BINS], [0.0; CURVE_BINS]);
    for i in 0..count {
        let (o, d) = (i % objects.len(), GraspDirection::ALL[(i / objects.len()) % 2]);
        let demo = synthesize_reach(objects, o, d, user, mix(seed, i as u64, 7));
        let predictions = predictor.predict(&demo, objects, &[])?;
        let len = predictions.len().max(1) as f64;
        for (k, p) in predictions.iter().enumerate() {
            let bin = ((k as f64 / len) * CURVE_BINS as f64) as usize;
            total[bin] += 1.0;
            hits[bin][0] += f64::from(u8::from(p.0 == o));
            hits[bin][1] += f64::from(u8::from(p.1 == d));
        }
    }
    let acc = |j: usize| (0..CURVE_BINS).map(|b| hits[b][j] / f64::max(total[b], 1.0)).collect();
    Ok(AccuracyCurve {
        predictor: predictor.as_str(),
        user: user.as_str(),
        time: (0..CURVE_BINS).map(|b| (b as f64 + 0.5) / CURVE_BINS as f64).collect(),
        goal: acc(0),
        direction: acc(1),
    })
}

impl crate::experiments::Experiment for TradedExperimentSettings {
    const NAME: &'static str = "traded";
    type Results = TradedResults;

    fn units(&self) -> (u64, &'static str) {
        (3 * self.episodes as u64, "episodes")
    }

    fn run(&self, cx: &crate::experiments::Context<'_>) -> Result<TradedResults, crate::experiments::ExperimentError> {
        Ok(run_traded_experiment(self, &|| cx.done())?)
    }

    /// `{"episodes", "results": [{"user", "mode", "time_until_execution_s":
    /// [mean, std], "episode_s", "goal_accuracy", "direction_accuracy",
    /// "planning_s", "plans_per_pick", "solved"}], "curves", "training_s"}`.
    fn json(&self, r: &TradedResults) -> serde_json::Value {
        serde_json::json!({
            "episodes": r.episodes,
            "results": r.rows,
            "curves": r.curves,
            "training_s": r.training_seconds,
        })
    }

    /// Table 7.3: per user and planning mode.
    fn table(&self, r: &TradedResults) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:<8} {:<11} {:>16} {:>16} {:>6} {:>6} {:>14} {:>6}",
            "user", "mode", "until exec (s)", "episode (s)", "goal", "dir", "plan (ms)", "plans"
        );
        for row in &r.rows {
            let _ = writeln!(
                out,
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
        let _ = writeln!(out, "{} episodes per user; classifier trained in {:.1} s", r.episodes, r.training_seconds);
        out
    }

    fn figures(&self, r: &TradedResults) -> Result<Vec<(String, String)>, crate::experiments::ExperimentError> {
        Ok(vec![("traded_accuracy.svg".into(), accuracy_figure(r)?)])
    }
}

/// Fig. 7.9: goal and direction accuracy over normalised demonstration
/// time, one panel per predictor, a line per user.
fn accuracy_figure(r: &TradedResults) -> Result<String, crate::figures::FigureError> {
    use crate::figures::{Panel, Series, render_panels};
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
    render_panels("grasp-intent accuracy over the demonstration (Fig. 7.9)", &panels, 420, 360)
}
