//! The planar pick-and-place experiment of the dissertation's chapter 4
//! (Table 4.1, Fig. 4.5) with the simulated users of §6.5.
//!
//! **Tasks**: [`sample_planar_task`].
//!
//! **Users** (§6.5): Straight (straight at the goal), Noisy-0.5 and
//! Noisy-1.0 (the robot's optimal policy toward the goal plus uniform noise
//! of that many times the speed on x and y each tick), Biased (the optimal
//! policy toward a goal up to 5 cm off); 5 cm/s.
//! **Methods**: DirectControl (the user's command alone, no collision
//! avoidance, as the seed's DC), NaturalGradient, LinearBlending (timid),
//! ObstacleAvoidance — the last three under the hard constraints.
//! **Metrics** (Table 4.1): duration, travel distance, smallest distance
//! between the gripper (or the carried cylinder) and the pole, cosine
//! distance between the user's and the executed command; success (both
//! phases done within 60 s) and collisions.

use super::{Context, Experiment, ExperimentError, mean_std};
use crate::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationError, ArbitrationMode, BlendingStyle, MetricSpace, ProblemGoal,
};
use crate::collision::CollisionWorkspace;
use crate::experiments::figures::{episode_path, outcome_legend};
use crate::figures::{Color, Marker, Panel, Series, render_panels};
use crate::problem::Problem;
use crate::sim::{
    Episode, EpisodeRecord, EpisodeSettings, Outcome, PlanarTask, PlanarUser, Reason, TaskJudge, sample_planar_task,
};
use rayon::prelude::*;
use std::fmt::Write;

/// The methods of Table 4.1.
pub const PLANAR_METHODS: [ArbitrationMode; 4] = [
    ArbitrationMode::DirectControl,
    ArbitrationMode::NaturalGradient(MetricSpace::Joint),
    ArbitrationMode::LinearBlending(BlendingStyle::Timid),
    ArbitrationMode::ObstacleAvoidance,
];

/// Settings of the planar experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarSettings {
    /// Tasks (per arm where there are two).
    pub tasks: usize,
    /// Seed of tasks and operators.
    pub seed: u64,
    /// The simulated users.
    pub users: Vec<PlanarUser>,
    /// The arbitration modes compared.
    pub methods: Vec<ArbitrationMode>,
    /// User speed (m/s; default 0.05).
    pub speed: f64,
    /// Timeout of the whole task (s; default 60).
    pub max_time: f64,
    /// The arbiters' settings (the method sets the mode).
    pub arbiter: ArbiterSettings,
}

impl Default for PlanarSettings {
    fn default() -> Self {
        PlanarSettings {
            tasks: 50,
            seed: 0,
            users: PlanarUser::ALL.to_vec(),
            methods: PLANAR_METHODS.to_vec(),
            speed: 0.05,
            max_time: 60.0,
            arbiter: ArbiterSettings { period: 1.0 / 30.0, ..ArbiterSettings::default() },
        }
    }
}

/// One planar episode (both phases).
#[derive(Debug, Clone)]
pub struct PlanarEpisode {
    /// Task index.
    pub task: usize,
    /// Index of the user in the settings.
    pub user: usize,
    /// Index of the method in the settings.
    pub method: usize,
    /// How it ended.
    pub outcome: Outcome,
    /// Why (the last phase's reason).
    pub reason: Reason,
    /// Seconds, centimetres, centimetres, and the mean cosine distance.
    pub duration: f64,
    /// Gripper path length (cm).
    pub travel_cm: f64,
    /// Smallest distance to the pole (cm).
    pub proximity_cm: f64,
    /// Mean cosine distance between the user's and the executed command.
    pub cosine_distance: f64,
    /// Executed steps that broke a hard constraint.
    pub hard_violations: usize,
    /// Gripper path (x, y), both phases.
    pub path: Vec<(f64, f64)>,
}

/// Results of the planar experiment.
#[derive(Debug, Clone)]
pub struct PlanarResults {
    /// The settings run.
    pub settings: PlanarSettings,
    /// Every episode, by task, method, user.
    pub episodes: Vec<PlanarEpisode>,
    /// The sampled tasks.
    pub tasks: Vec<PlanarTask>,
    /// Wall-clock time of the run (s).
    pub wall_seconds: f64,
}

/// Runs the planar experiment (parallel over tasks, deterministic).
///
/// # Errors
/// Setup failures.
pub fn run_planar(settings: &PlanarSettings, progress: &(dyn Fn() + Sync)) -> Result<PlanarResults, ExperimentError> {
    let began = std::time::Instant::now();
    let base = Problem::builtin("planar_pick")?;
    let per_task: Vec<Result<(PlanarTask, Vec<PlanarEpisode>), ExperimentError>> = (0..settings.tasks)
        .into_par_iter()
        .map(|index| {
            let task = sample_planar_task(&base, settings.seed, index)?;
            let episodes = run_planar_task(&task, settings)?;
            progress();
            Ok((task, episodes))
        })
        .collect();
    let mut results = PlanarResults { settings: settings.clone(), episodes: vec![], tasks: vec![], wall_seconds: 0.0 };
    for r in per_task {
        let (task, episodes) = r?;
        results.tasks.push(task);
        results.episodes.extend(episodes);
    }
    results.wall_seconds = began.elapsed().as_secs_f64();
    Ok(results)
}

fn run_planar_task(task: &PlanarTask, settings: &PlanarSettings) -> Result<Vec<PlanarEpisode>, ExperimentError> {
    let reach_base = Arbiter::for_problem(&task.reach[0].problem, &task.reach, settings.arbiter)?;
    let place_base = Arbiter::for_problem(&task.place.problem, std::slice::from_ref(&task.place), settings.arbiter)?;
    let mut out = vec![];
    for (m, mode) in settings.methods.iter().enumerate() {
        let mut s = settings.arbiter;
        s.mode = *mode;
        // The seed's direct control has no collision avoidance.
        s.safety.collisions = *mode != ArbitrationMode::DirectControl;
        let (reach, place) = (reach_base.with_settings(s)?, place_base.with_settings(s)?);
        for (u, user) in settings.users.iter().enumerate() {
            let seed = settings.seed ^ ((task.index as u64) << 20) ^ ((u as u64) << 8) ^ m as u64;
            out.push(run_phases(task, &reach, &place, *user, seed, settings, (u, m))?);
        }
    }
    Ok(out)
}

fn run_phases(
    task: &PlanarTask,
    reach: &Arbiter,
    place: &Arbiter,
    user: PlanarUser,
    seed: u64,
    settings: &PlanarSettings,
    (u, m): (usize, usize),
) -> Result<PlanarEpisode, ArbitrationError> {
    let first_goal = &task.reach[task.target];
    let speed = settings.speed;
    let first = phase(reach, &first_goal.problem.start, first_goal, task.target, user, speed, seed, settings.max_time)?;
    let (mut outcome, mut reason) = (first.outcome, first.reason.clone());
    let mut records = vec![first];
    if outcome == Outcome::Success {
        let remaining = settings.max_time - records[0].duration;
        if remaining > 0.0 {
            let start = records[0].final_q.clone();
            let second = phase(place, &start, &task.place, 0, user, speed, seed ^ 0xABCD, remaining)?;
            (outcome, reason) = (second.outcome, second.reason.clone());
            records.push(second);
        } else {
            outcome = Outcome::Timeout;
            let end = records[0].gripper.last().copied().unwrap_or_default();
            let to = task.place.position;
            let distance = ((end[0] - to[0]).powi(2) + (end[1] - to[1]).powi(2) + (end[2] - to[2]).powi(2)).sqrt();
            reason = Reason::Timeout { distance };
        }
    }
    let duration = records.iter().map(|r| r.duration).sum();
    let travel = records.iter().map(|r| r.travel).sum::<f64>();
    let (mut sum, mut count) = (0.0, 0);
    for r in &records {
        let d = r.mean_cosine_distance();
        if d.is_finite() {
            sum += d * r.steps as f64;
            count += r.steps;
        }
    }
    let proximity = proximity_to_pole(reach, place, &records)?;
    Ok(PlanarEpisode {
        task: task.index,
        user: u,
        method: m,
        outcome,
        reason,
        duration,
        travel_cm: travel * 100.0,
        proximity_cm: proximity * 100.0,
        cosine_distance: if count > 0 { sum / count as f64 } else { f64::NAN },
        hard_violations: records.iter().map(|r| r.hard_violations).sum(),
        path: records.iter().flat_map(|r| r.gripper.iter().map(|p| (p[0], p[1]))).collect(),
    })
}

#[allow(clippy::too_many_arguments)]
fn phase(
    arbiter: &Arbiter,
    start: &[f64],
    goal: &ProblemGoal,
    true_goal: usize,
    user: PlanarUser,
    speed: f64,
    seed: u64,
    max_time: f64,
) -> Result<EpisodeRecord, ArbitrationError> {
    let mut judge = TaskJudge::new(goal);
    let mut operator = user.build(speed, seed);
    let episode = Episode {
        arbiter,
        start,
        target: goal.position,
        true_goal,
        settings: EpisodeSettings { max_time, record: true },
    };
    Ok(episode.run(&mut arbiter.workspace(), operator.as_mut(), &mut judge)?)
}

/// Smallest distance (m) between the pole and the gripper (phase 1) or the
/// gripper with its cylinder (phase 2) over both phases.
fn proximity_to_pole(reach: &Arbiter, place: &Arbiter, records: &[EpisodeRecord]) -> Result<f64, ArbitrationError> {
    let mut best = f64::INFINITY;
    for (arbiter, record) in [reach, place].into_iter().zip(records) {
        let model = arbiter.collision_model();
        let mut ws = CollisionWorkspace::new(model);
        for q in &record.q {
            for d in model.distances(&mut ws, q, 0.5)? {
                if model.pair_names(d.pair).1 == "pole" {
                    best = best.min(d.signed.distance);
                }
            }
        }
    }
    Ok(best)
}

impl Experiment for PlanarSettings {
    const NAME: &'static str = "planar";
    type Results = PlanarResults;

    fn units(&self) -> (u64, &'static str) {
        (self.tasks as u64, "tasks")
    }

    fn run(&self, cx: &Context<'_>) -> Result<PlanarResults, ExperimentError> {
        run_planar(self, &|| cx.done())
    }

    /// `{"tasks", "seed", "results": [{"operator", "method", "success",
    /// "collision", "timeout", "failed", "duration_s": [mean, std],
    /// "travel_cm", "proximity_cm", "cosine_distance", "hard_violations"}],
    /// "seconds"}`.
    fn json(&self, r: &PlanarResults) -> serde_json::Value {
        let s = &r.settings;
        let mut rows = vec![];
        for (u, user) in s.users.iter().enumerate() {
            for (m, method) in s.methods.iter().enumerate() {
                let cell: Vec<_> = r.episodes.iter().filter(|e| e.user == u && e.method == m).collect();
                let count = |o: Outcome| cell.iter().filter(|e| e.outcome == o).count();
                rows.push(serde_json::json!({
                    "operator": user.name(),
                    "method": method.as_str(),
                    "success": count(Outcome::Success),
                    "collision": count(Outcome::Collision),
                    "timeout": count(Outcome::Timeout),
                    "failed": count(Outcome::Failed),
                    "duration_s": mean_std(cell.iter().map(|e| e.duration)),
                    "travel_cm": mean_std(cell.iter().map(|e| e.travel_cm)),
                    "proximity_cm": mean_std(cell.iter().map(|e| e.proximity_cm)),
                    "cosine_distance": mean_std(cell.iter().map(|e| e.cosine_distance)),
                    "hard_violations": cell.iter().map(|e| e.hard_violations).sum::<usize>(),
                    "reasons": reasons(&cell),
                }));
            }
        }
        serde_json::json!({"tasks": s.tasks, "seed": s.seed, "results": rows, "seconds": r.wall_seconds})
    }

    /// Table 4.1: per user and method, success, collisions and the
    /// metrics' mean ± std.
    fn table(&self, r: &PlanarResults) -> String {
        let json = self.json(r);
        let mut out = String::new();
        let _ = writeln!(
            out,
            "\n{:<12} {:<24} {:>8} {:>9} {:>14} {:>15} {:>15} {:>17}",
            "user",
            "method",
            "success",
            "collision",
            "duration (s)",
            "travel (cm)",
            "proximity (cm)",
            "cos dist (1e-2)"
        );
        for row in json["results"].as_array().into_iter().flatten() {
            let pm = |key: &str, scale: f64| {
                let v = &row[key];
                format!(
                    "{:.1} ± {:.1}",
                    v[0].as_f64().unwrap_or(f64::NAN) * scale,
                    v[1].as_f64().unwrap_or(f64::NAN) * scale
                )
            };
            let _ = writeln!(
                out,
                "{:<12} {:<24} {:>8} {:>9} {:>14} {:>15} {:>15} {:>17}",
                row["operator"].as_str().unwrap_or_default(),
                row["method"].as_str().unwrap_or_default(),
                format!("{}/{}", row["success"], r.settings.tasks),
                row["collision"],
                pm("duration_s", 1.0),
                pm("travel_cm", 1.0),
                pm("proximity_cm", 1.0),
                pm("cosine_distance", 100.0),
            );
        }
        let _ = writeln!(out, "\nfailures by reason, all users:");
        for (m, method) in r.settings.methods.iter().enumerate() {
            let cell: Vec<&PlanarEpisode> = r.episodes.iter().filter(|e| e.method == m).collect();
            let listed: Vec<String> = reasons(&cell).iter().map(|(reason, n)| format!("{reason} {n}")).collect();
            let listed = if listed.is_empty() { "none".to_string() } else { listed.join(", ") };
            let _ = writeln!(out, "{:<37}{listed}", method.as_str());
        }
        let violations: usize = r.episodes.iter().map(|e| e.hard_violations).sum();
        let _ = writeln!(
            out,
            "\n{} episodes in {:.1} s; hard-constraint violations: {violations}",
            r.episodes.len(),
            r.wall_seconds
        );
        out
    }

    fn figures(&self, r: &PlanarResults) -> Result<Vec<(String, String)>, ExperimentError> {
        Ok(figure(r)?.map(|svg| ("planar.svg".to_string(), svg)).into_iter().collect())
    }
}

/// The episodes of `cell` that did not succeed, by reason.
fn reasons(cell: &[&PlanarEpisode]) -> std::collections::BTreeMap<&'static str, usize> {
    let mut counts = std::collections::BTreeMap::new();
    for e in cell.iter().filter(|e| e.outcome != Outcome::Success) {
        *counts.entry(e.reason.as_str()).or_default() += 1;
    }
    counts
}

/// Fig. 4.5: the first task's gripper paths, one panel per method, every user.
fn figure(r: &PlanarResults) -> Result<Option<String>, ExperimentError> {
    let s = &r.settings;
    let Some(task) = r.tasks.first() else { return Ok(None) };
    let problem = &task.reach[task.target].problem;
    let pole = problem
        .scene
        .obstacle("pole")
        .map(|o| ((o.pose.translation.x, o.pose.translation.y), o.shape.extents().x.min(o.shape.extents().y) / 2.0));
    let objects: Vec<(f64, f64)> = task.reach.iter().map(|g| (g.position[0], g.position[1])).collect();
    let place = (task.place.position[0], task.place.position[1]);
    let panels: Vec<Panel> = s
        .methods
        .iter()
        .enumerate()
        .map(|(m, method)| {
            let mut panel = Panel::new(method.as_str(), "x (m)", "y (m)").ranges((0.0, 0.5), (0.0, 0.5)).equal();
            let mut outcomes = Vec::new();
            for (u, user) in s.users.iter().enumerate() {
                if let Some(e) = r.episodes.iter().find(|e| e.task == task.index && e.user == u && e.method == m) {
                    panel = episode_path(panel, &user.name(), &e.path, u, e.outcome);
                    outcomes.push(e.outcome);
                }
            }
            panel = outcome_legend(panel, outcomes);
            if let Some((centre, radius)) = pole {
                panel = panel.with(Series::discs("pole", &[centre], radius));
            }
            let start: Vec<(f64, f64)> = r
                .episodes
                .iter()
                .find(|e| e.task == task.index)
                .and_then(|e| e.path.first().copied())
                .into_iter()
                .collect();
            panel
                .with(Series::markers("start", &start, Color::Reference, Marker::Dot))
                .with(Series::markers("cylinders", &objects, Color::Reference, Marker::Ring))
                .with(Series::markers("place", &[place], Color::Reference, Marker::Diamond))
        })
        .collect();
    let title = "planar pick-and-place, task 0: gripper paths by method (top view)";
    Ok(Some(render_panels(title, &panels, 360, 400)?))
}
