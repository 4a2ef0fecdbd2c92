//! The policy experiment (the dissertation's §3.3.3): tasks drawn from a
//! problem family, the learned policy and the LQR tracking policy each
//! followed alone from the task's start (the dissertation reached 92–97 %),
//! DAgger rounds, and shared control (an [`Arbiter`](crate::arbitration::Arbiter) in a given mode with a
//! simulated operator) on top of either policy.

use super::figures::{joint_histograms, success_by_distance};
use super::{Context, Experiment, ExperimentError};
use crate::arbitration::{ArbitrationMode, ModeSettings};
use crate::data::{GenerateSettings, Progress, dataset_parameters, generate};
use crate::learn::dagger::{DaggerSettings, expert_demonstrations, failure_states, restart};
use crate::learn::evaluate::{
    FailureBreakdown, OutcomeCounts, PairedOutcomes, Rollout, RolloutOutcome, RolloutSettings, Task, nearest_distances,
};
use crate::learn::{
    Demonstrations, LearnSettings, PolicyNetwork, SHIPPED_POLICY_PATH, TrainSettings, shipped_policy, train_on,
};
use crate::pipeline::PipelineSettings;
use crate::problem::ProblemFamily;
use crate::sim::Outcome;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

mod rollouts;
mod training;
pub use rollouts::{
    GoalPolicy, follow_learned, follow_lqr, learned_arbiter, rollouts_csv, sample_tasks, shared_control,
};
pub use training::{PolicyReport, train_and_save};

/// The policy experiment's settings; it needs an output folder (the
/// dataset, the policies of each round, the figures).
#[derive(Debug, Clone, PartialEq)]
pub struct PolicyExperiment {
    /// The problem family of the tasks and the data.
    pub family: PathBuf,
    /// Evaluation tasks (family samples 0 … N−1 of `seed`).
    pub tasks: usize,
    /// Seed of the evaluation tasks (another than the training data's).
    pub seed: u64,
    /// A trained policy (default: the shipped one, [`shipped_policy`]).
    pub policy: Option<PathBuf>,
    /// Train a policy in the output folder instead (on `data`, or on a
    /// generated dataset of `train_count` trajectories in `OUT/data`).
    pub train: bool,
    /// The policy's training data: for the joint histograms, the success
    /// by distance from the data and DAgger (default: none for a given or
    /// shipped policy; `OUT/data`, generated when missing, with `train`).
    pub data: Option<PathBuf>,
    /// Trajectories of the generated dataset (seed 0).
    pub train_count: u64,
    /// Epochs of the first training.
    pub epochs: usize,
    /// DAgger rounds after it.
    pub rounds: usize,
    /// Fresh tasks followed per DAgger round.
    pub round_tasks: usize,
    /// Epochs per DAgger round.
    pub round_epochs: usize,
    /// Tasks of the shared-control comparison (0: none).
    pub arbitration_tasks: usize,
    /// Follow the LQR tracking policy too (it optimizes a reference per task).
    pub lqr: bool,
    /// The arbiter's mode settings in the shared-control comparison (the
    /// centres κ of sum-of-squares and of the constrained mode; default:
    /// the dissertation's, κ = 0).
    pub modes: ModeSettings,
}

impl Default for PolicyExperiment {
    fn default() -> Self {
        PolicyExperiment {
            family: "problems/panda_grasp_family.toml".into(),
            tasks: 100,
            seed: 1000,
            policy: None,
            train: false,
            data: None,
            train_count: 2000,
            epochs: 30,
            rounds: 0,
            round_tasks: 200,
            round_epochs: 10,
            arbitration_tasks: 20,
            lqr: true,
            modes: ModeSettings::default(),
        }
    }
}

/// What the policy experiment found.
#[derive(Debug, Clone)]
pub struct PolicyResults {
    /// Evaluation tasks.
    pub tasks: usize,
    /// Success, collision, timeout, … rates of each policy followed alone.
    pub results: Vec<serde_json::Value>,
    /// How the policy was trained (`None` for a given policy without a report).
    pub training: Option<PolicyReport>,
    /// Each DAgger round's rates and sizes.
    pub rounds: Vec<serde_json::Value>,
    /// Shared control on top of each policy.
    pub arbitration: Vec<serde_json::Value>,
    /// Which policy was evaluated: `shipped`, `trained` or the file given.
    pub source: String,
    /// Median distance of the task starts from the training data (rad;
    /// NaN without the data).
    pub median_start_distance: f64,
    /// Why each policy's rollouts ended (`learned`, then `lqr` when it ran).
    pub failures: Vec<(String, FailureBreakdown)>,
    /// The learned (first) and the LQR (second) policy's outcomes task by
    /// task, when the LQR policy ran.
    pub paired: Option<PairedOutcomes>,
    /// Every rollout alone, task by task ([`rollouts_csv`]; `rollouts.csv`
    /// in the output folder).
    pub rollouts: String,
    /// The figures: joint values of the data against the limits (Fig. 3.8)
    /// and success by the start's distance from the data.
    pub figures: Vec<(String, String)>,
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

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn paired(distances: &[f64], rollouts: &[Rollout]) -> Vec<(f64, bool)> {
    distances.iter().zip(rollouts).map(|(d, r)| (*d, r.outcome == RolloutOutcome::Success)).collect()
}

/// Why the rollouts of each policy ended: reasons, collision phases and pairs.
fn failures_table(failures: &[(String, FailureBreakdown)]) -> String {
    let mut out = String::new();
    let list = |m: &std::collections::BTreeMap<String, usize>| {
        let mut v: Vec<_> = m.iter().collect();
        v.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
        v.iter().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ")
    };
    for (policy, b) in failures {
        let _ = writeln!(out, "  {policy:<8} ended: {}", list(&b.reasons));
        if !b.collision_phases.is_empty() {
            let _ = writeln!(out, "  {:<8} collisions by phase: {}", "", list(&b.collision_phases));
            let _ = writeln!(out, "  {:<8} collisions by pair: {}", "", list(&b.collision_pairs));
        }
    }
    out
}

fn rates_table(results: &[serde_json::Value]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "  {:<10} {:>9} {:>10} {:>9} {:>13}",
        "policy", "success", "collision", "timeout", "no reference"
    );
    for r in results {
        let pct = |k: &str| 100.0 * r[k].as_f64().unwrap_or(f64::NAN);
        let _ = writeln!(
            out,
            "  {:<10} {:>7.1} % {:>8.1} % {:>7.1} % {:>11.1} %",
            r["policy"].as_str().unwrap_or(""),
            pct("success"),
            pct("collision"),
            pct("timeout"),
            pct("no_reference")
        );
    }
    let _ =
        writeln!(out, "  {:<10} {:>9}   (§3.3.3, learned policy in configuration space)", "dissertation", "92–97 %");
    out
}

impl PolicyExperiment {
    /// DAgger rounds: fresh tasks (seed `seed + 1 + round`), expert
    /// trajectories from the states of failed rollouts and from the starts
    /// farthest from the data, training continued on everything; success on
    /// the evaluation tasks after each round.
    #[allow(clippy::too_many_arguments)]
    fn dagger(
        &self,
        cx: &Context<'_>,
        out: &Path,
        family: &ProblemFamily,
        options: &LearnSettings,
        network: &mut Arc<PolicyNetwork>,
        demos: &mut Demonstrations,
        tasks: &[Task],
        rollout: &RolloutSettings,
        expert: &GenerateSettings,
    ) -> Result<Vec<serde_json::Value>, ExperimentError> {
        let settings = DaggerSettings {
            rounds: self.rounds,
            tasks_per_round: self.round_tasks,
            epochs: self.round_epochs,
            ..DaggerSettings::default()
        };
        let mut rounds = Vec::new();
        let mut next_id = demos.items.iter().map(|d| d.id + 1).max().unwrap_or(0).max(1 << 40);
        for round in 1..=settings.rounds {
            let fresh = sample_tasks(family, self.seed + 1 + round as u64, settings.tasks_per_round, rollout.max_tilt)?;
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
            let generate = GenerateSettings { seed: self.seed + round as u64, ..expert.clone() };
            let (added, rejected) = expert_demonstrations(&problems, next_id, &generate);
            next_id += problems.len() as u64;
            let added_count = added.len();
            demos.items.extend(added);
            let continued = LearnSettings {
                train: TrainSettings {
                    epochs: settings.epochs,
                    seed: options.train.seed + round as u64,
                    ..options.train.clone()
                },
                // The input the network to continue from was trained with.
                obstacle_slots: network.meta().obstacle_slots,
                obstacle_frames: network.meta().obstacle_frames.clone(),
                ..options.clone()
            };
            let (trained, report) = train_on(demos, family, &continued, Some(&**network))?;
            *network = Arc::new(trained);
            network.save(&out.join(format!("policy-round{round}.safetensors")))?;
            let c = counts(&follow_learned(network, tasks, rollout)?);
            let fresh_success = counts(&followed).success_rate();
            cx.say(&format!(
                "DAgger round {round}: learned policy succeeded on {:.1} % of {} fresh tasks; {failed} failure states + {} thin starts -> {added_count} expert trajectories ({rejected} rejected); {:.1} s training; evaluation: success {:.1} %, collision {:.1} %, timeout {:.1} %",
                100.0 * fresh_success,
                fresh.len(),
                settings.thin_per_round.min(fresh.len()),
                report.seconds,
                100.0 * c.success_rate(),
                100.0 * c.collision as f64 / c.total().max(1) as f64,
                100.0 * c.timeout as f64 / c.total().max(1) as f64,
            ));
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
        &self,
        network: &Arc<PolicyNetwork>,
        tasks: &[Task],
    ) -> Result<Vec<serde_json::Value>, ExperimentError> {
        let tasks = &tasks[..self.arbitration_tasks.min(tasks.len())];
        let mut rows = Vec::new();
        if tasks.is_empty() {
            return Ok(rows);
        }
        for mode in [ArbitrationMode::Constrained, ArbitrationMode::SumOfSquares] {
            for which in [GoalPolicy::Learned, GoalPolicy::Lqr] {
                if which == GoalPolicy::Lqr && !self.lqr {
                    continue;
                }
                let outcomes = shared_control(network, tasks, mode, &self.modes, which, self.seed)?;
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
                row["center"] = match mode {
                    ArbitrationMode::Constrained => self.modes.constrained_center,
                    _ => self.modes.sum_of_squares_center,
                }
                .into();
                rows.push(row);
            }
        }
        Ok(rows)
    }
}

impl Experiment for PolicyExperiment {
    // Not `policy`: `policy.json` is the report beside `policy.safetensors`.
    const NAME: &'static str = "policy_results";
    type Results = PolicyResults;

    fn units(&self) -> (u64, &'static str) {
        (self.tasks as u64, "tasks")
    }

    fn run(&self, cx: &Context<'_>) -> Result<PolicyResults, ExperimentError> {
        let out = cx.out().ok_or_else(|| {
            ExperimentError::from(crate::settings::InvalidSetting::new(
                "--out",
                "none",
                "a folder for the dataset, the policies and the figures",
            ))
        })?;
        if self.tasks == 0 {
            return Err(ExperimentError::from(crate::settings::InvalidSetting::new("--tasks", 0, "at least 1")));
        }
        self.modes.validate().map_err(|e| ExperimentError::from(e.within("modes")))?;
        let family = ProblemFamily::from_file(&self.family)?;
        let invalid = |option: &str, value: &str, expected: &str| {
            ExperimentError::from(crate::settings::InvalidSetting::new(option, value, expected))
        };
        if self.train && self.policy.is_some() {
            return Err(invalid("--train", "with --policy", "one of them: train a policy, or evaluate one"));
        }
        let data = match (&self.data, self.train) {
            (Some(d), _) => Some(d.clone()),
            (None, true) => Some(out.join("data")),
            (None, false) => None,
        };
        if self.rounds > 0 && data.is_none() {
            return Err(invalid(
                "--rounds",
                &self.rounds.to_string(),
                "0 without --data (DAgger adds to the training data)",
            ));
        }
        if let Some(data) = data.as_ref().filter(|d| self.train && !d.join("_manifest.json").exists()) {
            cx.say(&format!("generating {} trajectories into {}", self.train_count, data.display()));
            let settings = GenerateSettings { count: self.train_count, seed: 0, ..GenerateSettings::default() };
            generate(&self.family, data, &settings, &Progress::quiet())?;
        }
        let options = LearnSettings {
            train: TrainSettings { epochs: self.epochs, progress: cx.verbose(), ..TrainSettings::default() },
            ..LearnSettings::default()
        };
        let (network, training) = match (&self.policy, &data) {
            (Some(path), _) => (PolicyNetwork::load(path)?, PolicyReport::read_beside(path)),
            (None, Some(data)) if self.train => {
                let path = out.join("policy.safetensors");
                cx.say(&format!("training {} epochs on {}", self.epochs, data.display()));
                let (network, report) = train_and_save(data, &family, &options, &path)?;
                cx.say(&format!("wrote {} ({:.1} s of training)", path.display(), report.seconds));
                (network, Some(report))
            }
            _ => {
                let network = shipped_policy()?;
                if network.meta().family != family.name {
                    return Err(invalid(
                        "--policy",
                        "none (the shipped policy)",
                        &format!(
                            "a policy for {} (the shipped one is for {}): --policy FILE or --train",
                            family.name,
                            network.meta().family
                        ),
                    ));
                }
                cx.say(&format!("the shipped policy ({SHIPPED_POLICY_PATH})"));
                (network, PolicyReport::of_shipped())
            }
        };
        let mut network = Arc::new(network);
        let mut demos = match &data {
            Some(d) => Some(Demonstrations::read(d)?),
            None => None,
        };
        let states: Vec<Vec<f64>> =
            demos.iter().flat_map(|d| d.items.iter().flat_map(|d| d.states.iter().cloned())).collect();
        let robot = &family.base.robot;
        let rollout = RolloutSettings::default();
        let began = Instant::now();
        let tasks = sample_tasks(&family, self.seed, self.tasks, rollout.max_tilt)?;
        let learned = follow_learned(&network, &tasks, &rollout)?;
        for _ in 0..tasks.len() {
            cx.done();
        }
        let learned_seconds = began.elapsed().as_secs_f64();
        let lqr = if self.lqr { Some(follow_lqr(&tasks, self.seed, &rollout)?) } else { None };
        let starts: Vec<Vec<f64>> = tasks.iter().map(|t| t.problem.start.clone()).collect();
        // Without the training data there is nothing to measure distances to.
        let distances = if demos.is_some() { nearest_distances(&starts, &states) } else { vec![] };
        let mut figures = vec![];
        if demos.is_some() {
            let mut by_distance = vec![("learned".to_string(), paired(&distances, &learned))];
            if let Some(lqr) = &lqr {
                by_distance.push(("lqr".to_string(), paired(&distances, lqr)));
            }
            figures.push((
                "joint_histograms.svg".to_string(),
                joint_histograms(&states, robot.joint_names(), robot.limits(), 40)?,
            ));
            figures.push(("success_by_distance.svg".to_string(), success_by_distance(&by_distance, 5)?));
        }
        let mut results = vec![rates("learned", &counts(&learned))];
        let mut failures = vec![("learned".to_string(), FailureBreakdown::of(&learned))];
        if let Some(lqr) = &lqr {
            results.push(rates("lqr", &counts(lqr)));
            failures.push(("lqr".to_string(), FailureBreakdown::of(lqr)));
        }
        let mut followed = vec![("learned", learned.as_slice())];
        if let Some(lqr) = &lqr {
            followed.push(("lqr", lqr.as_slice()));
        }
        let rollouts = rollouts_csv(&followed);
        cx.say(&format!("learned rollouts: {learned_seconds:.1} s for {} tasks", self.tasks));
        let rounds = match (demos.as_mut(), &data) {
            (Some(demos), Some(data)) => {
                // The expert's trajectories are made the way the data was.
                let pipeline =
                    PipelineSettings { initial_guess: dataset_parameters(data)?.initial_guess, ..Default::default() };
                let expert = GenerateSettings { pipeline, ..GenerateSettings::default() };
                self.dagger(cx, out, &family, &options, &mut network, demos, &tasks, &rollout, &expert)?
            }
            _ => vec![],
        };
        let arbitration = self.arbitrate(&network, &tasks)?;
        cx.say(&format!("{} tasks of {} (seed {}), followed alone at 15 Hz:", self.tasks, family.name, self.seed));
        Ok(PolicyResults {
            tasks: self.tasks,
            results,
            training,
            source: match (&self.policy, self.train) {
                (Some(path), _) => path.display().to_string(),
                (None, true) => "trained".into(),
                (None, false) => "shipped".into(),
            },
            rounds,
            arbitration,
            median_start_distance: median(&distances),
            failures,
            paired: lqr.as_ref().map(|lqr| PairedOutcomes::of(&learned, lqr)),
            rollouts,
            figures,
        })
    }

    /// `{"tasks", "policy", "results": [{"policy", "success", "collision",
    /// "timeout", "no_reference", "failed", "episodes"}], "training":
    /// {"samples", "pairs", "seconds"}, "rounds": [...], "arbitration":
    /// [...], "seed_success": [0.92, 0.97], "median_start_distance",
    /// "failures", "paired": {"both", "learned_only", "lqr_only",
    /// "neither"}}` (`paired` counts tasks by which policy succeeded on
    /// them; null without the LQR policy); rates are shares of the tasks.
    fn json(&self, r: &PolicyResults) -> serde_json::Value {
        let training = r.training.as_ref().map_or(
            serde_json::Value::Null,
            |t| serde_json::json!({"samples": t.trajectories, "pairs": t.pairs, "seconds": t.seconds}),
        );
        serde_json::json!({
            "tasks": r.tasks,
            "policy": r.source,
            "results": r.results,
            "training": training,
            "rounds": r.rounds,
            "arbitration": r.arbitration,
            "seed_success": [0.92, 0.97],
            "median_start_distance": r.median_start_distance,
            "failures": r.failures.iter().map(|(p, b)| (p.clone(), serde_json::json!(b))).collect::<serde_json::Map<_, _>>(),
            "paired": r.paired.map(|p| serde_json::json!({
                "both": p.both, "learned_only": p.first_only, "lqr_only": p.second_only, "neither": p.neither,
            })),
        })
    }

    fn table(&self, r: &PolicyResults) -> String {
        let mut out = rates_table(&r.results);
        out.push_str(&failures_table(&r.failures));
        if let Some(p) = r.paired {
            let _ = writeln!(
                out,
                "  by task: both succeeded {}, only learned {}, only lqr {}, neither {}",
                p.both, p.first_only, p.second_only, p.neither
            );
        }
        if !r.arbitration.is_empty() {
            let _ = writeln!(out, "shared control, Approach operator, {} tasks:", self.arbitration_tasks.min(r.tasks));
            for row in &r.arbitration {
                let pct = |k: &str| 100.0 * row[k].as_f64().unwrap_or(f64::NAN);
                // The dissertation's κ = 0 unnamed, as the tables have always read.
                let mode = match row["center"].as_f64() {
                    Some(k) if k != 0.0 => format!("{} κ {k}", row["mode"].as_str().unwrap_or("")),
                    _ => row["mode"].as_str().unwrap_or("").to_string(),
                };
                let _ = writeln!(
                    out,
                    "  {:<12} on {:<8} success {:>5.1} %, collision {:>5.1} %, timeout {:>5.1} %",
                    mode,
                    row["policy"].as_str().unwrap_or(""),
                    pct("success"),
                    pct("collision"),
                    pct("timeout")
                );
            }
        }
        out
    }

    fn data_files(&self, r: &PolicyResults) -> Vec<(String, String)> {
        vec![("rollouts.csv".into(), r.rollouts.clone())]
    }

    fn figures(&self, r: &PolicyResults) -> Result<Vec<(String, String)>, ExperimentError> {
        Ok(r.figures.clone())
    }
}
