//! The reach-and-grasp experiment of the dissertation's §5.5 (Table 5.1):
//! two Pandas side by side, a 6 × 6 × 12 cm box on the table at a random
//! pose, a random start ([`sample_task`]); simulated operators ×
//! arbitration methods on the same sampled tasks.
//!
//! **Operators** (§5.5.2): Straightline, Approach (10 cm above, then
//! down), Noisy-0.1 and Noisy-0.2, Biased (≤ 5 cm), Laggy-5 and Laggy-10,
//! the last four disturbing Approach; 10 cm/s, 3-D linear velocity only.
//! **Methods**: NoAssist (the operator's command through the damped
//! pseudo-inverse, joint limits only: the dissertation's baseline),
//! Constrained, SumOfSquares, NaturalGradient (joint space), LinearBlending
//! (timid), ObstacleAvoidance — all but NoAssist under the hard constraints.
//! **Outcome**: the episode ends when the operator believes it has reached
//! the grasp point (then [`TaskJudge`] decides success or failure), on a
//! collision, or after 20 s.

mod figures;
mod physics;

pub use physics::{Agreement, PhysicsOutcome, Simulator};

use super::{Context, Experiment, ExperimentError};
use crate::arbitration::{Arbiter, ArbiterSettings, ArbitrationMode, BlendingStyle, MetricSpace};
use crate::problem::Problem;
use crate::robot::KinematicsWorkspace;
use crate::sim::{
    Arm, Episode, EpisodeRecord, EpisodeSettings, OperatorKind, Outcome, Reason, Task, TaskJudge, mix, percentiles,
    sample_task,
};
use nalgebra::{IsometryMatrix3, Rotation3};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write;

/// An arbitration method of the experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// The operator's command alone, joint limits only (no collision avoidance).
    NoAssist,
    /// An arbitration mode under the hard constraints.
    Mode(ArbitrationMode),
}

impl Method {
    /// The six methods of the experiment: the dissertation's three, then NG, LB, OA.
    pub const ALL: [Method; 6] = [
        Method::NoAssist,
        Method::Mode(ArbitrationMode::Constrained),
        Method::Mode(ArbitrationMode::SumOfSquares),
        Method::Mode(ArbitrationMode::NaturalGradient(MetricSpace::Joint)),
        Method::Mode(ArbitrationMode::LinearBlending(BlendingStyle::Timid)),
        Method::Mode(ArbitrationMode::ObstacleAvoidance),
    ];

    /// `noassist`, or the mode's name.
    pub fn name(&self) -> &'static str {
        match self {
            Method::NoAssist => "noassist",
            Method::Mode(m) => m.as_str(),
        }
    }

    /// The arbiter settings of this method.
    pub fn settings(&self, base: &ArbiterSettings) -> ArbiterSettings {
        let mut s = *base;
        match self {
            Method::NoAssist => {
                s.mode = ArbitrationMode::DirectControl;
                s.safety.collisions = false;
            }
            Method::Mode(m) => s.mode = *m,
        }
        s
    }
}

/// Settings of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct ReachGraspSettings {
    /// Tasks (per arm where there are two).
    pub tasks: usize,
    /// Seed of tasks and operators.
    pub seed: u64,
    /// Which arms do the tasks.
    pub arms: Vec<Arm>,
    /// The simulated operators.
    pub operators: Vec<OperatorKind>,
    /// The methods compared.
    pub methods: Vec<Method>,
    /// Operator speed (m/s; default 0.1).
    pub speed: f64,
    /// Timeout (s; default 20).
    pub max_time: f64,
    /// The arbiters' settings (the method sets the mode and safety).
    pub arbiter: ArbiterSettings,
    /// Keep the gripper paths of the first task per arm (for the figure).
    pub keep_paths: bool,
    /// Which simulator moves the arm (default: the kinematic one).
    pub simulator: Simulator,
    /// Write every episode, tick by tick, to `DIR/<arm>-<task>.parquet`
    /// (see [`write_episodes`](crate::sim::write_episodes)); created if
    /// missing.
    pub record_dir: Option<std::path::PathBuf>,
}

impl Default for ReachGraspSettings {
    fn default() -> Self {
        ReachGraspSettings {
            tasks: 100,
            seed: 0,
            arms: vec![Arm::Right, Arm::Left],
            operators: OperatorKind::TABLE_5_1.to_vec(),
            methods: Method::ALL.to_vec(),
            speed: 0.1,
            max_time: 20.0,
            arbiter: ArbiterSettings::default(),
            keep_paths: true,
            simulator: Simulator::Kinematic,
            record_dir: None,
        }
    }
}

/// One episode's summary.
#[derive(Debug, Clone)]
pub struct EpisodeSummary {
    /// The arm.
    pub arm: Arm,
    /// Task index.
    pub task: usize,
    /// Index of the operator in the settings.
    pub operator: usize,
    /// Index of the method in the settings.
    pub method: usize,
    /// How it ended.
    pub outcome: Outcome,
    /// Why.
    pub reason: Reason,
    /// |cos| between the gripper's x, y axes and the box's, and cos between
    /// the gripper's z and the box's −z, at the end.
    pub cos: [f64; 3],
    /// Simulated duration (s).
    pub duration: f64,
    /// Tick times (µs).
    pub tick_us: Vec<f64>,
    /// Executed steps that broke a hard constraint.
    pub hard_violations: usize,
    /// Executed commands that broke an acceleration, deceleration or jerk
    /// limit, and the largest ratios to those limits (see
    /// [`EpisodeRecord::limit_violations`]).
    pub limit_violations: usize,
    /// The largest `|q̈| / limit` of the episode.
    pub peak_acceleration_ratio: f64,
    /// The largest `|q⃛| / limit` of the episode.
    pub peak_jerk_ratio: f64,
    /// Smallest signed distance over the episode (m).
    pub min_clearance: f64,
    /// The gripper path (first task of each arm, when kept; m, world).
    pub path: Vec<[f64; 3]>,
    /// The gripper's approach axis (its z, world) at the last
    /// `approach.len()` points of `path` (kept with it).
    pub approach: Vec<[f64; 3]>,
    /// What physics adds (the kinematic judge's verdict, steps).
    pub physics: PhysicsOutcome,
}

/// Every episode, in (arm, task, operator, method) order, and the tasks.
#[derive(Debug, Clone)]
pub struct ReachGraspResults {
    /// The settings run.
    pub settings: ReachGraspSettings,
    /// Every episode, by arm, task, method, operator.
    pub episodes: Vec<EpisodeSummary>,
    /// The sampled tasks.
    pub tasks: Vec<Task>,
    /// Seconds spent preparing tasks (sampling, planning, optimizing) and
    /// running episodes, summed over threads, and the wall-clock total.
    pub prepare_seconds: f64,
    /// CPU seconds in episodes.
    pub episode_seconds: f64,
    /// Wall-clock time of the run (s).
    pub wall_seconds: f64,
}

/// Runs the experiment: every task (in parallel over tasks; the results do
/// not depend on the thread count), every operator × method on it.
/// `progress` is called once per finished task.
///
/// # Errors
/// Setup failures (the base problem, a task resampled 20 times), an
/// episode recording that cannot be written.
pub fn run_reach_grasp(
    settings: &ReachGraspSettings,
    progress: &(dyn Fn() + Sync),
) -> Result<ReachGraspResults, ExperimentError> {
    let began = std::time::Instant::now();
    if let Some(dir) = &settings.record_dir {
        std::fs::create_dir_all(dir).map_err(crate::files::FileError::io(dir))?;
    }
    let base = Problem::builtin("panda_grasp_box")?;
    let units: Vec<(Arm, usize)> =
        settings.arms.iter().flat_map(|&arm| (0..settings.tasks).map(move |i| (arm, i))).collect();
    type TaskRun = (Task, Vec<EpisodeSummary>, f64, f64);
    let per_task: Vec<Result<TaskRun, ExperimentError>> = units
        .par_iter()
        .map(|&(arm, index)| {
            let t0 = std::time::Instant::now();
            let task = sample_task(&base, arm, settings.seed, index)?;
            let prepared = t0.elapsed().as_secs_f64();
            let episodes = run_task(&task, settings)?;
            progress();
            Ok((task, episodes, prepared, t0.elapsed().as_secs_f64() - prepared))
        })
        .collect();
    let mut results = ReachGraspResults {
        settings: settings.clone(),
        episodes: vec![],
        tasks: vec![],
        prepare_seconds: 0.0,
        episode_seconds: 0.0,
        wall_seconds: 0.0,
    };
    for r in per_task {
        let (task, episodes, prepared, ran) = r?;
        results.tasks.push(task);
        results.episodes.extend(episodes);
        results.prepare_seconds += prepared;
        results.episode_seconds += ran;
    }
    results.wall_seconds = began.elapsed().as_secs_f64();
    Ok(results)
}

/// Every operator × method on one task.
fn run_task(task: &Task, settings: &ReachGraspSettings) -> Result<Vec<EpisodeSummary>, ExperimentError> {
    let problem = &task.goal.problem;
    let base = Arbiter::for_problem(problem, std::slice::from_ref(&task.goal), settings.arbiter)?;
    let mut judge = TaskJudge::new(&task.goal);
    let mut kin = KinematicsWorkspace::new(&problem.robot);
    let box_pose = problem.scene.object("box").map(|o| o.pose).unwrap_or_else(IsometryMatrix3::identity);
    let gripper = problem.robot.frame_id(problem.robot_spec.gripper.as_deref().unwrap_or_default())?;
    let mut out = vec![];
    let record = settings.record_dir.is_some();
    let mut records = vec![];
    let mut physics = match &settings.simulator {
        Simulator::Kinematic => None,
        Simulator::Mujoco(p) => Some(physics::Runner::new(task, &base, p)?),
    };
    for (m, method) in settings.methods.iter().enumerate() {
        let arbiter = base.with_settings(method.settings(&settings.arbiter))?;
        let mut ws = arbiter.workspace();
        for (o, kind) in settings.operators.iter().enumerate() {
            let mut operator =
                kind.build(settings.speed, mix(settings.seed, task.index as u64, task.arm as u64, o as u64 + 1));
            let keep = settings.keep_paths && task.index == 0;
            let episode = Episode {
                arbiter: &arbiter,
                start: &problem.start,
                target: task.goal.position,
                true_goal: 0,
                settings: EpisodeSettings { max_time: settings.max_time, record: record || keep },
            };
            let (mut record, physical) = match physics.as_mut() {
                Some(runner) => runner.run(&episode, &mut ws, operator.as_mut(), &mut judge)?,
                None => (episode.run(&mut ws, operator.as_mut(), &mut judge)?, PhysicsOutcome::default()),
            };
            let mut approach = vec![];
            if keep {
                for q in &record.q {
                    problem.robot.forward_kinematics(&mut kin, q)?;
                    let z = problem.robot.frame_pose(&kin, gripper).rotation.matrix().column(2).into_owned();
                    approach.push([z.x, z.y, z.z]);
                }
            }
            problem.robot.forward_kinematics(&mut kin, &record.final_q)?;
            let g = problem.robot.frame_pose(&kin, gripper).rotation;
            let b = box_pose.rotation;
            let axis = |r: &Rotation3<f64>, k: usize| r.matrix().column(k).into_owned();
            let cos = [
                axis(&g, 0).dot(&axis(&b, 0)).abs(),
                axis(&g, 1).dot(&axis(&b, 1)).abs(),
                axis(&g, 2).dot(&(-axis(&b, 2))),
            ];
            out.push(EpisodeSummary {
                arm: task.arm,
                task: task.index,
                operator: o,
                method: m,
                outcome: record.outcome,
                reason: record.reason.clone(),
                cos,
                duration: record.duration,
                tick_us: std::mem::take(&mut record.tick_us),
                hard_violations: record.hard_violations,
                limit_violations: record.limit_violations,
                peak_acceleration_ratio: record.peak_acceleration_ratio,
                peak_jerk_ratio: record.peak_jerk_ratio,
                min_clearance: record.min_clearance,
                path: if keep { std::mem::take(&mut record.gripper) } else { vec![] },
                approach,
                physics: physical,
            });
            if settings.record_dir.is_some() {
                let label = format!("{}/{}/{}/{}", task.arm.as_str(), kind.name(), method.name(), task.index);
                records.push((label, record));
            }
        }
    }
    if let Some(dir) = &settings.record_dir {
        let rows: Vec<(String, &EpisodeRecord, f64)> =
            records.iter().map(|(label, r)| (label.clone(), r, settings.arbiter.period)).collect();
        let path = dir.join(format!("{}-{:05}.parquet", task.arm.as_str(), task.index));
        crate::sim::write_episodes(&path, &rows)?;
    }
    Ok(out)
}

/// Counts of one (arm, operator, method) cell.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Cell {
    /// Episodes that succeeded.
    pub success: usize,
    /// Episodes the operator ended where the task was not done.
    pub failed: usize,
    /// Episodes that ended in a collision.
    pub collision: usize,
    /// Episodes that timed out.
    pub timeout: usize,
    /// Mean |cos| of the gripper's x and y axes with the box's, and cos of z with −z.
    pub cos: [f64; 3],
    /// Executed steps that broke a hard constraint.
    pub hard_violations: usize,
    /// Executed commands that broke a motion limit (acceleration,
    /// deceleration, jerk).
    pub limit_violations: usize,
    /// The largest ratios to the acceleration and jerk limits.
    pub peak_ratios: [f64; 2],
    /// The episodes that did not succeed, by reason.
    pub reasons: BTreeMap<&'static str, usize>,
    /// Mean duration of the successful episodes (s): the time to grasp;
    /// `None` without a success.
    pub time_to_grasp: Option<f64>,
}

impl ReachGraspResults {
    /// The cell of `arm`, operator `o`, method `m` (cos averaged over its episodes).
    pub fn cell(&self, arm: Arm, o: usize, m: usize) -> Cell {
        let mut c = Cell::default();
        let mut count = 0;
        for e in self.episodes.iter().filter(|e| e.arm == arm && e.operator == o && e.method == m) {
            match e.outcome {
                Outcome::Success => c.success += 1,
                Outcome::Failed => c.failed += 1,
                Outcome::Collision => c.collision += 1,
                Outcome::Timeout => c.timeout += 1,
            }
            for k in 0..3 {
                c.cos[k] += e.cos[k];
            }
            c.hard_violations += e.hard_violations;
            c.limit_violations += e.limit_violations;
            c.peak_ratios[0] = c.peak_ratios[0].max(e.peak_acceleration_ratio);
            c.peak_ratios[1] = c.peak_ratios[1].max(e.peak_jerk_ratio);
            if e.outcome != Outcome::Success {
                *c.reasons.entry(e.reason.as_str()).or_default() += 1;
            } else {
                *c.time_to_grasp.get_or_insert(0.0) += e.duration;
            }
            count += 1;
        }
        if count > 0 {
            c.cos = c.cos.map(|x| x / count as f64);
        }
        c.time_to_grasp = c.time_to_grasp.map(|t| t / c.success as f64);
        c
    }

    /// Average cosine similarities of method `m` on `arm` over all operators.
    pub fn method_cos(&self, arm: Arm, m: usize) -> [f64; 3] {
        let eps: Vec<&EpisodeSummary> = self.episodes.iter().filter(|e| e.arm == arm && e.method == m).collect();
        let n = eps.len().max(1) as f64;
        [0, 1, 2].map(|k| eps.iter().map(|e| e.cos[k]).sum::<f64>() / n)
    }
}

impl Experiment for ReachGraspSettings {
    const NAME: &'static str = "reach_grasp";
    type Results = ReachGraspResults;

    fn units(&self) -> (u64, &'static str) {
        ((self.tasks * self.arms.len()) as u64, "tasks")
    }

    fn run(&self, cx: &Context<'_>) -> Result<ReachGraspResults, ExperimentError> {
        run_reach_grasp(self, &|| cx.done())
    }

    /// `{"tasks", "seed", "simulator", "physics": {"steps",
    /// "step_seconds"}, "results": [{"arm", "operator", "method",
    /// "success", "collision", "timeout", "failed", "cos_sim": [x, y, z],
    /// "hard_violations", "limit_violations", "peak_acceleration_ratio",
    /// "peak_jerk_ratio", "time_to_grasp_s" (the successes' mean duration,
    /// null without one), "reasons", and with physics "kinematic_judge":
    /// {"both", "kinematic_only", "physics_only", "neither",
    /// "never_closed"}}], "resampled_tasks", "seconds", "tick_us"}`.
    fn json(&self, r: &ReachGraspResults) -> serde_json::Value {
        let s = &r.settings;
        let mut rows = vec![];
        for &arm in &s.arms {
            for (o, op) in s.operators.iter().enumerate() {
                for (m, method) in s.methods.iter().enumerate() {
                    let c = r.cell(arm, o, m);
                    let mut row = serde_json::json!({
                        "arm": arm.as_str(), "operator": op.name(), "method": method.name(),
                        "success": c.success, "collision": c.collision, "timeout": c.timeout, "failed": c.failed,
                        "cos_sim": c.cos, "hard_violations": c.hard_violations,
                        "limit_violations": c.limit_violations, "peak_acceleration_ratio": c.peak_ratios[0],
                        "peak_jerk_ratio": c.peak_ratios[1], "time_to_grasp_s": c.time_to_grasp,
                        "reasons": c.reasons,
                    });
                    if s.simulator != Simulator::Kinematic {
                        let cell = r.episodes.iter().filter(|e| e.arm == arm && e.operator == o && e.method == m);
                        row["kinematic_judge"] = Agreement::of(cell).json();
                    }
                    rows.push(row);
                }
            }
        }
        let ticks: Vec<f64> = r.episodes.iter().flat_map(|e| e.tick_us.iter().copied()).collect();
        let (median, p99, max) = percentiles(&ticks);
        let (steps, seconds) = physics::physics_totals(&r.episodes);
        serde_json::json!({
            "tasks": s.tasks,
            "seed": s.seed,
            "simulator": s.simulator.name(),
            "physics": {"steps": steps, "step_seconds": seconds},
            "results": rows,
            "resampled_tasks": r.tasks.iter().map(|t| t.resampled).sum::<usize>(),
            "seconds": {"wall": r.wall_seconds, "prepare_cpu": r.prepare_seconds, "episodes_cpu": r.episode_seconds},
            "tick_us": {"median": median, "p99": p99, "max": max},
        })
    }

    /// Table 5.1's layout: per arm, a row per method, collision / timeout /
    /// failed / success per operator, and the average cosine similarities.
    fn table(&self, r: &ReachGraspResults) -> String {
        let s = &r.settings;
        let mut out = String::new();
        for &arm in &s.arms {
            let _ = write!(out, "\n{:<24}", arm.as_str().to_uppercase());
            for op in &s.operators {
                let _ = write!(out, "{:^19}", op.name());
            }
            let _ = writeln!(out, "   avg. cos sim");
            let _ = write!(out, "{:<24}", "");
            for _ in &s.operators {
                let _ = write!(out, "{:^19}", "col t/o fail succ");
            }
            let _ = writeln!(out, "   x     y     z");
            for (m, method) in s.methods.iter().enumerate() {
                let _ = write!(out, "{:<24}", method.name());
                for o in 0..s.operators.len() {
                    let c = r.cell(arm, o, m);
                    let _ = write!(out, " {:>3} {:>3} {:>4} {:>4} ", c.collision, c.timeout, c.failed, c.success);
                }
                let cos = r.method_cos(arm, m);
                let _ = writeln!(out, "  {:.2}  {:.2}  {:.2}", cos[0], cos[1], cos[2]);
            }
            let _ = writeln!(out, "  failures by reason, all operators:");
            for (m, method) in s.methods.iter().enumerate() {
                let mut reasons: BTreeMap<&str, usize> = BTreeMap::new();
                for o in 0..s.operators.len() {
                    for (reason, n) in r.cell(arm, o, m).reasons {
                        *reasons.entry(reason).or_default() += n;
                    }
                }
                let listed: Vec<String> = reasons.iter().map(|(reason, n)| format!("{reason} {n}")).collect();
                let listed = if listed.is_empty() { "none".to_string() } else { listed.join(", ") };
                let _ = writeln!(out, "  {:<24}{listed}", method.name());
            }
        }
        let _ = writeln!(
            out,
            "\ncol: collision, t/o: timeout (20 s), fail: the operator stopped where the task is not done, succ: success"
        );
        let resampled: usize = r.tasks.iter().map(|t| t.resampled).sum();
        let _ = writeln!(
            out,
            "\n{} tasks per arm ({} resampled: reference not converged), {} episodes in {:.1} s \
             (task preparation {:.1} s and episodes {:.1} s of CPU)",
            s.tasks,
            resampled,
            r.episodes.len(),
            r.wall_seconds,
            r.prepare_seconds,
            r.episode_seconds
        );
        let violations: usize = r.episodes.iter().map(|e| e.hard_violations).sum();
        let _ = writeln!(out, "hard-constraint violations: {violations}");
        let limits: usize = r.episodes.iter().map(|e| e.limit_violations).sum();
        let peak = |f: fn(&EpisodeSummary) -> f64| r.episodes.iter().map(f).fold(0.0, f64::max);
        let _ = writeln!(
            out,
            "motion-limit violations: {limits} (largest acceleration {:.2} and jerk {:.2} of the limits)",
            peak(|e| e.peak_acceleration_ratio),
            peak(|e| e.peak_jerk_ratio)
        );
        if s.simulator != Simulator::Kinematic {
            out.push_str(&physics::table(r));
        }
        out
    }

    fn figures(&self, r: &ReachGraspResults) -> Result<Vec<(String, String)>, ExperimentError> {
        let mut out = vec![("reach_grasp_success.svg".to_string(), figures::success(r)?)];
        out.extend(figures::paths(r)?.map(|svg| ("reach_grasp.svg".to_string(), svg)));
        Ok(out)
    }
}
