//! Table 6.1 of the dissertation: the learned arbiters (combined and
//! environment-only reward) beside direct control, with every simulated
//! user of §6.5, on the planar reach task: the gripper behind a pole, two
//! cylinders near the far edge, the user heading for one. Success: the
//! gripper reaches the user's cylinder (the task judge, 1 cm) within the
//! timeout; collision: it touches anything first. The learned arbiters run
//! as [`ArbitrationMode::Learned`] under the hard constraints; direct
//! control has no collision avoidance (the dissertation's DC). Also the data of
//! Fig. 6.5: the distance of the executed command to the user's and to the
//! most likely goal's sub-policy along normalised episode time.

use super::figures::training_curves;
use super::{Context, Experiment, ExperimentError, mean_std};
use crate::arbitration::{Arbiter, ArbiterSettings, ArbitrationError, ArbitrationMode};
use crate::figures::{FigureError, Panel, Series, render_panels, share_y};
use crate::learn::{ArbitrationActor, DdpgReport, DdpgSettings, TrainingEpisode, train_arbitration};
use crate::problem::Problem;
use crate::sim::{
    Episode, EpisodeRecord, EpisodeSettings, Outcome, PlanarUser, RewardKind, TaskJudge, sample_planar_task,
};
use rayon::prelude::*;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Settings of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedExperimentSettings {
    /// Episodes (tasks) per user and method.
    pub episodes: usize,
    /// Seed of the tasks and the users.
    pub seed: u64,
    /// The users (default: noisy-0.5, noisy-1.0, straight, biased).
    pub users: Vec<PlanarUser>,
    /// User speed (m/s; default 0.05).
    pub speed: f64,
    /// Timeout (s; default 20).
    pub max_time: f64,
    /// The arbiters' settings (30 Hz).
    pub arbiter: ArbiterSettings,
}

impl Default for LearnedExperimentSettings {
    fn default() -> Self {
        LearnedExperimentSettings {
            episodes: 100,
            seed: 1,
            users: PlanarUser::ALL.to_vec(),
            speed: 0.05,
            max_time: 20.0,
            arbiter: ArbiterSettings { period: 1.0 / 30.0, ..ArbiterSettings::default() },
        }
    }
}

/// A method of the table: direct control or a learned actor.
#[derive(Debug, Clone)]
pub struct LearnedMethod {
    /// Its name in the table (`combined`, `environment`, `direct`).
    pub name: String,
    /// The actor; `None` for direct control.
    pub actor: Option<Arc<ArbitrationActor>>,
}

/// One cell of the table.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LearnedCell {
    /// The user's name.
    pub user: String,
    /// The method's name.
    pub method: String,
    /// Share of successful episodes.
    pub success: f64,
    /// Share of episodes that ended in a collision.
    pub collision: f64,
    /// Gripper travel (cm), mean and standard deviation.
    pub travel_cm: [f64; 2],
    /// Episodes.
    pub episodes: usize,
    /// Median wall-clock time of one arbiter tick over the cell's episodes (µs).
    pub tick_us: f64,
}

/// Fig. 6.5's curves for one method with the straight user: per tenth of
/// the normalised episode time, the mean distance between the direction of
/// the executed gripper velocity and that of the user's command, and of
/// the most likely goal's sub-policy (unit vectors, as the dissertation
/// normalises the actions: 0 = same direction, 2 = opposite).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AuthorityCurve {
    /// The method's name.
    pub method: String,
    /// Distance to the user's command, per tenth.
    pub to_user: Vec<f64>,
    /// Distance to the predicted sub-policy, per tenth.
    pub to_robot: Vec<f64>,
}

/// The experiment's results.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LearnedResults {
    /// Episodes per cell.
    pub episodes: usize,
    /// Every cell, by user then method.
    pub cells: Vec<LearnedCell>,
    /// Fig. 6.5 data (straight user), one per method.
    pub curves: Vec<AuthorityCurve>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

struct Run {
    user: usize,
    method: usize,
    outcome: Outcome,
    travel_cm: f64,
    to_user: [f64; 10],
    to_robot: [f64; 10],
    counts: [usize; 10],
    tick_us: Vec<f64>,
}

/// Runs the table (parallel over episodes; deterministic).
///
/// # Errors
/// A task that cannot be set up, an actor trained for another layout.
pub fn run_learned_experiment(
    settings: &LearnedExperimentSettings,
    methods: &[LearnedMethod],
    progress: &(dyn Fn() + Sync),
) -> Result<LearnedResults, ExperimentError> {
    let began = std::time::Instant::now();
    let base = Problem::builtin("planar_pick")?;
    let runs: Vec<Vec<Run>> = (0..settings.episodes)
        .into_par_iter()
        .map(|e| {
            let runs = episode_runs(&base, settings, methods, e);
            progress();
            runs
        })
        .collect::<Result<_, _>>()?;
    let runs: Vec<Run> = runs.into_iter().flatten().collect();
    let mut cells = vec![];
    for (u, user) in settings.users.iter().enumerate() {
        for (m, method) in methods.iter().enumerate() {
            let mine: Vec<&Run> = runs.iter().filter(|r| r.user == u && r.method == m).collect();
            let share = |o: Outcome| mine.iter().filter(|r| r.outcome == o).count() as f64 / mine.len().max(1) as f64;
            cells.push(LearnedCell {
                user: user.name(),
                method: method.name.clone(),
                success: share(Outcome::Success),
                collision: share(Outcome::Collision),
                travel_cm: mean_std(mine.iter().map(|r| r.travel_cm)),
                episodes: mine.len(),
                tick_us: crate::sim::percentiles(
                    &mine.iter().flat_map(|r| r.tick_us.iter().copied()).collect::<Vec<_>>(),
                )
                .0,
            });
        }
    }
    let straight = settings.users.iter().position(|u| *u == PlanarUser::Straight);
    let curves = methods
        .iter()
        .enumerate()
        .map(|(m, method)| {
            let (mut to_user, mut to_robot, mut counts) = ([0.0; 10], [0.0; 10], [0usize; 10]);
            for r in runs.iter().filter(|r| Some(r.user) == straight && r.method == m) {
                for k in 0..10 {
                    to_user[k] += r.to_user[k];
                    to_robot[k] += r.to_robot[k];
                    counts[k] += r.counts[k];
                }
            }
            let mean = |v: [f64; 10]| (0..10).map(|k| v[k] / counts[k].max(1) as f64).collect();
            AuthorityCurve { method: method.name.clone(), to_user: mean(to_user), to_robot: mean(to_robot) }
        })
        .collect();
    Ok(LearnedResults { episodes: settings.episodes, cells, curves, seconds: began.elapsed().as_secs_f64() })
}

fn episode_runs(
    base: &Problem,
    settings: &LearnedExperimentSettings,
    methods: &[LearnedMethod],
    e: usize,
) -> Result<Vec<Run>, ArbitrationError> {
    let task = sample_planar_task(base, settings.seed, e)?;
    let goal = &task.reach[task.target];
    let arbiter = Arbiter::for_problem(&goal.problem, &task.reach, settings.arbiter)?;
    let mut runs = vec![];
    for (m, method) in methods.iter().enumerate() {
        let mut s = settings.arbiter;
        let arbiter = match &method.actor {
            Some(actor) => {
                s.mode = ArbitrationMode::Learned;
                arbiter.with_arbitration_policy(actor.clone())?.with_settings(s)?
            }
            None => {
                s.mode = ArbitrationMode::DirectControl;
                s.safety.collisions = false;
                arbiter.with_settings(s)?
            }
        };
        for (u, user) in settings.users.iter().enumerate() {
            let seed = settings.seed ^ ((e as u64) << 20) ^ ((u as u64) << 8);
            let mut operator = user.build(settings.speed, seed);
            let mut judge = TaskJudge::new(goal);
            let episode = Episode {
                arbiter: &arbiter,
                start: &goal.problem.start,
                target: goal.position,
                true_goal: task.target,
                settings: EpisodeSettings { max_time: settings.max_time, record: true },
            };
            let record = episode.run(&mut arbiter.workspace(), operator.as_mut(), &mut judge)?;
            runs.push(summarise(&record, u, m, settings.speed));
        }
    }
    Ok(runs)
}

/// Outcome, travel and the Fig. 6.5 distances of one episode. The planar
/// gripper's x and y joints move its tool point along the world axes, so a
/// sub-policy's first two joint velocities are its gripper velocity.
fn summarise(record: &EpisodeRecord, user: usize, method: usize, speed: f64) -> Run {
    let mut run = Run {
        user,
        method,
        outcome: record.outcome,
        travel_cm: record.travel * 100.0,
        to_user: [0.0; 10],
        to_robot: [0.0; 10],
        counts: [0; 10],
        tick_us: record.tick_us.clone(),
    };
    let steps = record.executed.len();
    for (t, (executed, human)) in record.executed.iter().zip(&record.human).enumerate() {
        let Some(robot) = record.robot.get(t).filter(|r| r.len() >= 2) else { continue };
        let k = (10 * t / steps.max(1)).min(9);
        let unit = |v: [f64; 2]| {
            let n = v[0].hypot(v[1]);
            if n > 1e-3 * speed { [v[0] / n, v[1] / n] } else { [0.0, 0.0] }
        };
        let u = unit([executed[0], executed[1]]);
        let gap = |a: [f64; 2]| {
            let a = unit(a);
            (u[0] - a[0]).hypot(u[1] - a[1])
        };
        run.to_user[k] += gap([human[0], human[1]]);
        run.to_robot[k] += gap([robot[0], robot[1]]);
        run.counts[k] += 1;
    }
    run
}

/// Trains one actor with `settings` and writes it to `out` (safetensors),
/// its training log beside it (`.json`: seconds and episodes) and its
/// training curves (`.svg`).
///
/// # Errors
/// A file that cannot be written (checked before training), training.
pub fn train_and_save(settings: &DdpgSettings, out: &Path) -> Result<DdpgReport, ExperimentError> {
    for path in [out.to_path_buf(), out.with_extension("json"), out.with_extension("svg")] {
        crate::files::check_writable(&path)?;
    }
    let report = train_arbitration(settings, &mut |_| {})?;
    report.actor.save(out)?;
    let json = out.with_extension("json");
    let log = serde_json::json!({ "seconds": report.seconds, "episodes": report.episodes });
    std::fs::write(&json, serde_json::to_string_pretty(&log)? + "\n").map_err(crate::files::FileError::io(&json))?;
    let svg = out.with_extension("svg");
    let runs = vec![(settings.reward.as_str().to_string(), vec![report.episodes.clone()])];
    std::fs::write(&svg, training_curves(&runs, 10)?).map_err(crate::files::FileError::io(&svg))?;
    Ok(report)
}

/// Table 6.1 with its actors: given (trained before, with their logs
/// beside them), or trained here over several seeds into the output folder.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedExperiment {
    /// The table's settings.
    pub table: LearnedExperimentSettings,
    /// Trained combined-reward actors, one per training seed (empty: train
    /// them here). The table uses the one whose last 50 training episodes
    /// earned the most.
    pub combined: Vec<PathBuf>,
    /// Trained environment-reward actors, as `combined`.
    pub environment: Vec<PathBuf>,
    /// Training episodes of each actor trained here.
    pub train_episodes: usize,
    /// Training seeds per reward (0, 1, …), trained side by side.
    pub train_seeds: usize,
}

/// The table, the training logs per reward (one list of episodes per
/// seed; Fig. 6.4) and the training seconds.
#[derive(Debug, Clone)]
pub struct LearnedRun {
    /// Table 6.1 and Fig. 6.5.
    pub results: LearnedResults,
    /// Training logs per reward.
    pub logs: Vec<(String, Vec<Vec<TrainingEpisode>>)>,
    /// Seconds of training, summed over the actors.
    pub training_seconds: f64,
}

impl LearnedExperiment {
    /// The actors of the table: loaded, or trained into `dir`. Returns
    /// them, the training logs per reward, and the training seconds.
    fn actors(&self, cx: &Context<'_>, dir: &Path) -> Result<(Vec<LearnedMethod>, LearnedLogs, f64), ExperimentError> {
        let mut methods = vec![];
        let mut logs = vec![];
        let mut seconds = 0.0;
        for (kind, given) in [(RewardKind::Combined, &self.combined), (RewardKind::Environment, &self.environment)] {
            let mut runs = vec![];
            let mut best = Best::default();
            if given.is_empty() {
                // One run per seed, side by side (each trains on one thread).
                let trained: Vec<Result<DdpgReport, ExperimentError>> = (0..self.train_seeds as u64)
                    .into_par_iter()
                    .map(|seed| {
                        let settings =
                            DdpgSettings { episodes: self.train_episodes, reward: kind, seed, ..Default::default() };
                        let out = dir.join(format!("{}-{seed}.safetensors", kind.as_str()));
                        let report = train_and_save(&settings, &out)?;
                        cx.say(&format!(
                            "trained {} (seed {seed}) in {:.0} s: {}",
                            kind.as_str(),
                            report.seconds,
                            out.display()
                        ));
                        Ok(report)
                    })
                    .collect();
                for report in trained {
                    let report = report?;
                    seconds += report.seconds;
                    best.offer(&report.episodes, report.actor);
                    runs.push(report.episodes);
                }
            } else {
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
            }
            let actor = best.actor.ok_or_else(|| {
                ExperimentError::from(crate::settings::InvalidSetting::new(
                    "--train-seeds",
                    self.train_seeds,
                    "at least 1, or an actor given",
                ))
            })?;
            if !runs.is_empty() {
                logs.push((kind.as_str().to_string(), runs));
            }
            methods.push(LearnedMethod { name: kind.as_str().into(), actor: Some(Arc::new(actor)) });
        }
        methods.push(LearnedMethod { name: "direct".into(), actor: None });
        Ok((methods, logs, seconds))
    }
}

/// Training logs per reward: one list of episodes per seed.
type LearnedLogs = Vec<(String, Vec<Vec<TrainingEpisode>>)>;

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

impl Experiment for LearnedExperiment {
    const NAME: &'static str = "learned";
    type Results = LearnedRun;

    fn units(&self) -> (u64, &'static str) {
        (self.table.episodes as u64, "episodes")
    }

    /// Trains or loads the actors (into the output folder, which it needs),
    /// writes Fig. 6.4 (`training_curves.svg`), then runs the table.
    fn run(&self, cx: &Context<'_>) -> Result<LearnedRun, ExperimentError> {
        let dir = cx.out().map(Path::to_path_buf).unwrap_or_else(|| std::env::temp_dir().join("tandem-learned"));
        std::fs::create_dir_all(&dir).map_err(crate::files::FileError::io(&dir))?;
        let (methods, logs, training_seconds) = self.actors(cx, &dir)?;
        if !logs.is_empty() {
            cx.write("training_curves.svg", &training_curves(&logs, 10)?)?;
        }
        let results = run_learned_experiment(&self.table, &methods, &|| cx.done())?;
        Ok(LearnedRun { results, logs, training_seconds })
    }

    /// `{"episodes", "results": [{"user", "method", "success",
    /// "collision", "travel_cm": [mean, std], "tick_us"}], "training":
    /// {"episodes", "seconds"}, "fig_6_5"}`.
    fn json(&self, run: &LearnedRun) -> serde_json::Value {
        let results = &run.results;
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
            "training": { "episodes": self.train_episodes, "seconds": run.training_seconds },
            "fig_6_5": results.curves,
        })
    }

    fn table(&self, run: &LearnedRun) -> String {
        let results = &run.results;
        let mut out = String::new();
        let _ = writeln!(out, "Table 6.1 — {} episodes per cell (the dissertation's table had 15)", results.episodes);
        let _ = writeln!(
            out,
            "{:<10} {:<12} {:>8} {:>18} {:>10} {:>8}",
            "user", "method", "success", "travel (cm)", "collisions", "tick µs"
        );
        for c in &results.cells {
            let _ = writeln!(
                out,
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
        out
    }

    fn figures(&self, run: &LearnedRun) -> Result<Vec<(String, String)>, ExperimentError> {
        Ok(vec![("authority.svg".into(), authority_curves(&run.results.curves)?)])
    }
}

/// Fig. 6.5: distance of the executed command to the user's and to the
/// predicted sub-policy along normalised episode time, one panel per method.
///
/// # Errors
/// Plotting errors.
fn authority_curves(curves: &[AuthorityCurve]) -> Result<String, FigureError> {
    let at = |v: &[f64]| v.iter().enumerate().map(|(k, y)| (10.0 * k as f64 + 5.0, *y)).collect::<Vec<_>>();
    let mut panels: Vec<Panel> = curves
        .iter()
        .map(|c| {
            Panel::new(&c.method, "episode duration (%)", "‖û − â‖ (unit directions)")
                .with(Series::line("to the user", &at(&c.to_user), 0))
                .with(Series::line("to the predicted sub-policy", &at(&c.to_robot), 1))
        })
        .collect();
    // Compared across methods: one y axis from 0 (distances of unit vectors).
    share_y(&mut panels);
    for p in &mut panels {
        p.y_range = p.y_range.map(|(_, hi)| (0.0, hi));
    }
    render_panels("Who has authority along the episode (straight user)", &panels, 420, 380)
}
