//! The reach-and-grasp experiment of the seed's §5.5 (Table 5.1): two
//! Pandas side by side, a 6 × 6 × 12 cm box on the table at a random pose,
//! a random start; simulated operators × arbitration methods on the same
//! sampled tasks.
//!
//! **Tasks** (fixed before any result was looked at). Each arm stands at
//! the origin of its own frame; the other Panda, held at the ready pose,
//! stands 0.6 m to its side (+y for the RIGHT arm, −y for the LEFT) as
//! collision spheres. The box stands on the table with its centre at x ∈
//! [0.4, 0.6] m, y ∈ [−0.2, 0.2] m, yaw ∈ [−π/2, π/2]; the start is the
//! ready pose plus U(−0.3, 0.3) rad per joint, collision-free. The robot's
//! reference comes from the optimizer (`panda_grasp_box`'s objectives:
//! approach above, then the grasp pointing down); its LQR tracking policy
//! is the robot policy. A task whose reference does not converge is
//! resampled (counted).
//!
//! **Operators** (§5.5.2): Straightline, Approach (10 cm above, then
//! down), Noisy-0.1 and Noisy-0.2, Biased (≤ 5 cm), Laggy-5 and Laggy-10,
//! the last four disturbing Approach; 10 cm/s, 3-D linear velocity only.
//! **Methods**: NoAssist (the operator's command through the damped
//! pseudo-inverse, joint limits only: the seed's baseline), Constrained,
//! SumOfSquares, NaturalGradient (joint space), LinearBlending (timid),
//! ObstacleAvoidance — all but NoAssist under the hard constraints.
//! **Outcome**: the episode ends when the operator believes it has reached
//! the grasp point (then [`TaskJudge`](super::TaskJudge) decides success
//! or failure), on a collision, or after 20 s.

use super::episode::{Episode, EpisodeSettings, Outcome};
use super::judge::TaskJudge;
use super::operator::{Approach, Biased, Laggy, Noisy, Operator, Pace, Straightline};
use crate::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationError, ArbitrationMode, BlendingStyle, GoalObjects, GoalOptions, MetricSpace,
    ProblemGoal, problem_goals,
};
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::problem::Problem;
use crate::robot::KinematicsWorkspace;
use crate::scene::Obstacle;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The Panda's ready pose (rad).
const READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

/// Which of the two arms does the task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Arm {
    /// The right arm: the other stands 0.6 m to its left (+y).
    Right,
    /// The left arm: the other stands 0.6 m to its right (−y).
    Left,
}

impl Arm {
    /// `right` or `left`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Arm::Right => "right",
            Arm::Left => "left",
        }
    }

    fn other_arm_offset(&self) -> f64 {
        match self {
            Arm::Right => 0.6,
            Arm::Left => -0.6,
        }
    }
}

/// A simulated operator of the experiment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OperatorKind {
    /// Straight at the grasp point.
    Straightline,
    /// Via a point 10 cm above the grasp point.
    Approach,
    /// Approach with joint noise of this size (rad/s).
    Noisy(f64),
    /// Approach aiming up to 5 cm off.
    Biased,
    /// Approach acting on what it saw this many ticks ago.
    Laggy(usize),
}

impl OperatorKind {
    /// The seven operators of Table 5.1, in its order.
    pub const TABLE_5_1: [OperatorKind; 7] = [
        OperatorKind::Straightline,
        OperatorKind::Approach,
        OperatorKind::Noisy(0.1),
        OperatorKind::Noisy(0.2),
        OperatorKind::Biased,
        OperatorKind::Laggy(5),
        OperatorKind::Laggy(10),
    ];

    /// The name in tables and JSON (`noisy-0.1`, …).
    pub fn name(&self) -> String {
        match self {
            OperatorKind::Straightline => "straightline".into(),
            OperatorKind::Approach => "approach".into(),
            OperatorKind::Noisy(k) => format!("noisy-{k}"),
            OperatorKind::Biased => "biased".into(),
            OperatorKind::Laggy(m) => format!("laggy-{m}"),
        }
    }

    /// The operator at `speed` (m/s), its randomness from `seed`.
    pub fn build(&self, speed: f64, seed: u64) -> Box<dyn Operator> {
        let approach = Approach::at_speed(speed);
        match *self {
            OperatorKind::Straightline => Box::new(Straightline { pace: Pace { speed, ..Pace::default() } }),
            OperatorKind::Approach => Box::new(approach),
            OperatorKind::Noisy(k) => Box::new(Noisy::new(approach, k, seed)),
            OperatorKind::Biased => Box::new(Biased::new(approach, 0.05, seed)),
            OperatorKind::Laggy(m) => Box::new(Laggy::new(approach, m)),
        }
    }
}

/// An arbitration method of the experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// The operator's command alone, joint limits only (no collision avoidance).
    NoAssist,
    /// An arbitration mode under the hard constraints.
    Mode(ArbitrationMode),
}

impl Method {
    /// The six methods of the experiment: the seed's three, then NG, LB, OA.
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
    /// Write every episode, tick by tick, to `DIR/<arm>-<task>.parquet`
    /// (see [`write_episodes`](crate::data::write_episodes)).
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
            record_dir: None,
        }
    }
}

/// One sampled task with its reference.
#[derive(Debug, Clone)]
pub struct Task {
    /// The arm.
    pub arm: Arm,
    /// Task index.
    pub index: usize,
    /// The prepared goal: problem, reference, policy.
    pub goal: ProblemGoal,
    /// Samples rejected before this one (reference did not converge).
    pub resampled: usize,
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
    /// |cos| between the gripper's x, y axes and the box's, and cos between
    /// the gripper's z and the box's −z, at the end.
    pub cos: [f64; 3],
    /// Simulated duration (s).
    pub duration: f64,
    /// Tick times (µs).
    pub tick_us: Vec<f64>,
    /// Executed steps that broke a hard constraint.
    pub hard_violations: usize,
    /// Smallest signed distance over the episode (m).
    pub min_clearance: f64,
    /// The gripper path (first task of each arm, when kept).
    pub path: Vec<[f64; 3]>,
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

/// Samples task `index` for `arm` and optimizes its reference; resamples
/// (up to 20 times) while the optimizer does not converge.
///
/// # Errors
/// The base problem or the arbiter pieces failing (not a bad sample).
pub fn sample_task(base: &Problem, arm: Arm, seed: u64, index: usize) -> Result<Task, ArbitrationError> {
    let mut rng = ChaCha8Rng::seed_from_u64(mix(seed, index as u64, arm as u64, 0));
    let other = other_arm_obstacles(base, arm.other_arm_offset())?;
    for resampled in 0..20 {
        let mut problem = base.clone();
        for o in &other {
            problem.scene.add_obstacle(o.clone())?;
        }
        let yaw = rng.random_range(-std::f64::consts::FRAC_PI_2..std::f64::consts::FRAC_PI_2);
        let pose = IsometryMatrix3::from_parts(
            Translation3::new(rng.random_range(0.4..0.6), rng.random_range(-0.2..0.2), 0.06),
            Rotation3::from_axis_angle(&Vector3::z_axis(), yaw),
        );
        problem.scene.set_object_pose("box", pose)?;
        problem.start = free_start(&problem, &mut rng)?;
        let options = GoalOptions { seed: Some(rng.random()), objects: GoalObjects::Goal, ..GoalOptions::default() };
        match problem_goals(&problem, &options) {
            Ok(mut goals) => return Ok(Task { arm, index, goal: goals.remove(0), resampled }),
            Err(ArbitrationError::GoalNotReached { .. } | ArbitrationError::Pipeline(_)) => continue,
            Err(e) => return Err(e),
        }
    }
    Err(ArbitrationError::GoalNotReached {
        goal: format!("task {index} ({})", arm.as_str()),
        status: "resampled 20 times",
    })
}

/// The ready pose plus U(−0.3, 0.3) rad per joint, within limits and
/// collision-free (the ready pose itself after 100 tries).
fn free_start(problem: &Problem, rng: &mut ChaCha8Rng) -> Result<Vec<f64>, ArbitrationError> {
    let model = problem.collision_model()?;
    let mut ws = CollisionWorkspace::new(&model);
    for _ in 0..100 {
        let q: Vec<f64> = READY.iter().map(|x| x + rng.random_range(-0.3..0.3)).collect();
        if problem.robot.within_limits(&q) && model.collision_free(&mut ws, &q)? {
            return Ok(q);
        }
    }
    Ok(READY.to_vec())
}

/// The other Panda at the ready pose, `offset` m along y, as its
/// collision shapes.
fn other_arm_obstacles(base: &Problem, offset: f64) -> Result<Vec<Obstacle>, ArbitrationError> {
    let model = CollisionModel::builder(base.robot.clone()).build()?;
    let mut ws = CollisionWorkspace::new(&model);
    model.place(&mut ws, &READY)?;
    let shift = IsometryMatrix3::translation(0.0, offset, 0.0);
    Ok((0..model.object_count())
        .map(|k| {
            let pose = shift * model.object_world_pose(&ws, k);
            Obstacle::new(format!("other_arm_{k}"), model.object_shape(k).clone(), pose)
        })
        .collect())
}

/// A seed from several numbers (SplitMix64 rounds).
fn mix(a: u64, b: u64, c: u64, d: u64) -> u64 {
    let mut x = a;
    for v in [b, c, d] {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15).wrapping_add(v);
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^= x >> 31;
    }
    x
}

/// Runs the experiment: every task (in parallel over tasks; the results do
/// not depend on the thread count), every operator × method on it.
/// `progress` is called once per finished task.
///
/// # Errors
/// Setup failures (the base problem, a task resampled 20 times).
pub fn run_reach_grasp(
    settings: &ReachGraspSettings,
    progress: &(dyn Fn() + Sync),
) -> Result<ReachGraspResults, ArbitrationError> {
    let began = std::time::Instant::now();
    let base = Problem::builtin("panda_grasp_box")?;
    let units: Vec<(Arm, usize)> =
        settings.arms.iter().flat_map(|&arm| (0..settings.tasks).map(move |i| (arm, i))).collect();
    type TaskRun = (Task, Vec<EpisodeSummary>, f64, f64);
    let per_task: Vec<Result<TaskRun, ArbitrationError>> = units
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
fn run_task(task: &Task, settings: &ReachGraspSettings) -> Result<Vec<EpisodeSummary>, ArbitrationError> {
    let problem = &task.goal.problem;
    let base = Arbiter::for_problem(problem, std::slice::from_ref(&task.goal), settings.arbiter)?;
    let mut judge = TaskJudge::new(&task.goal);
    let mut kin = KinematicsWorkspace::new(&problem.robot);
    let box_pose = problem.scene.object("box").map(|o| o.pose).unwrap_or_else(IsometryMatrix3::identity);
    let gripper = problem.robot.frame_id(problem.robot_spec.gripper.as_deref().unwrap_or_default())?;
    let mut out = vec![];
    let record = settings.record_dir.is_some();
    let mut records = vec![];
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
                settings: EpisodeSettings { max_time: settings.max_time, record },
            };
            let mut record = episode.run(&mut ws, operator.as_mut(), &mut |q| judge.succeeded(q))?;
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
                cos,
                duration: record.duration,
                tick_us: std::mem::take(&mut record.tick_us),
                hard_violations: record.hard_violations,
                min_clearance: record.min_clearance,
                path: if keep { std::mem::take(&mut record.gripper) } else { vec![] },
            });
            if settings.record_dir.is_some() {
                let label = format!("{}/{}/{}/{}", task.arm.as_str(), kind.name(), method.name(), task.index);
                records.push((label, record));
            }
        }
    }
    if let Some(dir) = &settings.record_dir {
        let rows: Vec<(String, &super::EpisodeRecord, f64)> =
            records.iter().map(|(label, r)| (label.clone(), r, settings.arbiter.period)).collect();
        let path = dir.join(format!("{}-{:05}.parquet", task.arm.as_str(), task.index));
        crate::data::write_episodes(&path, &rows).map_err(|e| ArbitrationError::Io(e.to_string()))?;
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
            count += 1;
        }
        if count > 0 {
            c.cos = c.cos.map(|x| x / count as f64);
        }
        c
    }

    /// Average cosine similarities of method `m` on `arm` over all operators.
    pub fn method_cos(&self, arm: Arm, m: usize) -> [f64; 3] {
        let eps: Vec<&EpisodeSummary> = self.episodes.iter().filter(|e| e.arm == arm && e.method == m).collect();
        let n = eps.len().max(1) as f64;
        [0, 1, 2].map(|k| eps.iter().map(|e| e.cos[k]).sum::<f64>() / n)
    }
}
