//! The planar pick-and-place experiment of the seed's chapter 4 (Table 4.1,
//! Fig. 4.5) with the simulated users of §6.5.
//!
//! **Tasks** (fixed before any result was looked at): the planar gripper
//! (`builtin:planar_pick`) over a 50 × 50 cm table; two cylinders (red,
//! yellow; r = 2.5 cm) near the far edge (y ∈ [0.38, 0.45] m; red x ∈
//! [0.05, 0.2], yellow x ∈ [0.3, 0.45]); a pole (r = 3 cm) near the centre
//! (x ∈ [0.2, 0.3], y ∈ [0.18, 0.28]); the gripper starts behind the pole
//! (x ∈ [0.2, 0.3], y ∈ [0.02, 0.08]). The user picks one cylinder (drawn at
//! random) and brings it to a place position on the near side (x ∈ [0.05,
//! 0.45], y = 0.06, at least 10 cm from the start in x). Phase 1 reaches
//! the cylinder (within 1 cm) with both cylinders as goals (intent decides);
//! phase 2 carries it, attached, to the place position.
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

use super::episode::{Episode, EpisodeRecord, EpisodeSettings, Outcome};
use super::judge::TaskJudge;
use super::operator::{Biased, Noisy, Operator, Pace, PolicyFollower, Straightline};
use crate::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationError, ArbitrationMode, BlendingStyle, GoalObjects, GoalOptions, MetricSpace,
    ProblemGoal, problem_goals,
};
use crate::collision::CollisionWorkspace;
use crate::problem::{Goal, Problem};
use nalgebra::{IsometryMatrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// A simulated user of the planar task.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlanarUser {
    /// Straight at the goal.
    Straight,
    /// The optimal policy plus uniform noise of this many times the speed.
    Noisy(f64),
    /// Aims up to 5 cm off.
    Biased,
}

impl PlanarUser {
    /// The users of Table 6.1.
    pub const ALL: [PlanarUser; 4] =
        [PlanarUser::Noisy(0.5), PlanarUser::Noisy(1.0), PlanarUser::Straight, PlanarUser::Biased];

    /// `straight`, `noisy-0.5`, …
    pub fn name(&self) -> String {
        match self {
            PlanarUser::Straight => "straight".into(),
            PlanarUser::Noisy(s) => format!("noisy-{s}"),
            PlanarUser::Biased => "biased".into(),
        }
    }

    pub(crate) fn build(&self, speed: f64, seed: u64) -> Box<dyn Operator> {
        let pace = Pace { speed, slow_down: 0.03, arrive: 0.005 };
        let follower = PolicyFollower { pace };
        match *self {
            PlanarUser::Straight => Box::new(Straightline { pace }),
            PlanarUser::Noisy(s) => Box::new(Noisy::new(follower, s * speed, seed)),
            PlanarUser::Biased => Box::new(Biased::new(follower, 0.05, seed)),
        }
    }
}

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

/// A sampled planar task: the two phases' prepared goals.
#[derive(Debug, Clone)]
pub struct PlanarTask {
    /// Task index.
    pub index: usize,
    /// Phase 1: one goal per cylinder; `target` is the user's.
    pub reach: Vec<ProblemGoal>,
    /// Which of the goals the user means.
    pub target: usize,
    /// Phase 2: the place goal, the cylinder attached.
    pub place: ProblemGoal,
    /// The pole's position (m).
    pub pole: [f64; 2],
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

/// Samples planar task `index` and prepares both phases' references.
///
/// # Errors
/// A task whose references do not converge after 20 samples; setup errors.
pub fn sample_planar_task(base: &Problem, seed: u64, index: usize) -> Result<PlanarTask, ArbitrationError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index as u64);
    let mut last = None;
    for _ in 0..20 {
        match try_task(base, &mut rng, index) {
            Ok(task) => return Ok(task),
            Err(e @ (ArbitrationError::GoalNotReached { .. } | ArbitrationError::Pipeline(_))) => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or(ArbitrationError::GoalNotReached { goal: format!("planar task {index}"), status: "resampled" }))
}

fn try_task(base: &Problem, rng: &mut ChaCha8Rng, index: usize) -> Result<PlanarTask, ArbitrationError> {
    let mut problem = base.clone();
    let at = |x: f64, y: f64, z: f64| IsometryMatrix3::translation(x, y, z);
    let red = [rng.random_range(0.05..0.2), rng.random_range(0.38..0.45)];
    let yellow = [rng.random_range(0.3..0.45), rng.random_range(0.38..0.45)];
    let pole = [rng.random_range(0.2..0.3), rng.random_range(0.18..0.28)];
    problem.scene.set_object_pose("red", at(red[0], red[1], 0.075))?;
    problem.scene.set_object_pose("yellow", at(yellow[0], yellow[1], 0.075))?;
    let pole_obstacle = problem.scene.obstacles().iter().position(|o| o.name == "pole").unwrap_or(0);
    let mut obstacles = problem.scene.obstacles().to_vec();
    obstacles[pole_obstacle].pose = at(pole[0], pole[1], 0.15);
    let mut scene = crate::scene::Scene::new();
    for o in obstacles {
        scene.add_obstacle(o)?;
    }
    for o in problem.scene.objects() {
        scene.add_object(o.clone())?;
    }
    problem.scene = scene;
    let start_x = rng.random_range(0.2..0.3);
    problem.start = vec![start_x, rng.random_range(0.02..0.08), 0.0];
    let target = usize::from(rng.random_bool(0.5));
    let name = ["red", "yellow"][target];
    problem = problem.retarget_grasp(name)?;
    let seed: u64 = rng.random();
    let options = GoalOptions { seed: Some(seed), objects: GoalObjects::AllGraspable, ..GoalOptions::default() };
    let reach = problem_goals(&problem, &options)?;
    let target = reach.iter().position(|g| g.name == name).unwrap_or(0);
    // Phase 2: the cylinder attached, a place goal on the near side.
    let mut place_x = rng.random_range(0.05..0.45);
    if (place_x - start_x).abs() < 0.1 {
        place_x = if start_x < 0.25 { start_x + 0.15 } else { start_x - 0.15 };
    }
    let end = reach[target].policy.reference().goal().to_vec();
    let mut carry = problem.clone();
    carry.start = end;
    let grasp = carry.grasp_target().unwrap_or_else(IsometryMatrix3::identity);
    let object_pose = carry.scene.object(name).map(|o| o.pose).unwrap_or_else(IsometryMatrix3::identity);
    carry.scene.attach(name, "gripper_tcp", grasp.inverse() * object_pose)?;
    carry.goal = Goal::Pose {
        frame: "gripper_tcp".into(),
        position: Vector3::new(place_x, 0.06, 0.1),
        orientation: None,
        axis_alignment: None,
    };
    // The reach objective becomes a place objective: the gripper at the
    // place position at the end.
    for o in carry.optimizer.objectives.iter_mut().filter(|o| o.feature == "position_difference") {
        o.feature = "position".into();
        o.frames = vec!["gripper_tcp".into()];
        o.target = Some(vec![place_x, 0.06, 0.1]);
    }
    carry.name = format!("{}: place", carry.name);
    let place =
        problem_goals(&carry, &GoalOptions { seed: Some(seed), objects: GoalObjects::Goal, ..GoalOptions::default() })?
            .remove(0);
    Ok(PlanarTask { index, reach, target, place, pole })
}

/// Runs the planar experiment (parallel over tasks, deterministic).
///
/// # Errors
/// Setup failures.
pub fn run_planar(settings: &PlanarSettings, progress: &(dyn Fn() + Sync)) -> Result<PlanarResults, ArbitrationError> {
    let began = std::time::Instant::now();
    let base = Problem::builtin("planar_pick")?;
    let per_task: Vec<Result<(PlanarTask, Vec<PlanarEpisode>), ArbitrationError>> = (0..settings.tasks)
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

fn run_planar_task(task: &PlanarTask, settings: &PlanarSettings) -> Result<Vec<PlanarEpisode>, ArbitrationError> {
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
    let mut outcome = first.outcome;
    let mut records = vec![first];
    if outcome == Outcome::Success {
        let remaining = settings.max_time - records[0].duration;
        if remaining > 0.0 {
            let start = records[0].final_q.clone();
            let second = phase(place, &start, &task.place, 0, user, speed, seed ^ 0xABCD, remaining)?;
            outcome = second.outcome;
            records.push(second);
        } else {
            outcome = Outcome::Timeout;
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
    Ok(episode.run(&mut arbiter.workspace(), operator.as_mut(), &mut |q| judge.succeeded(q))?)
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

/// Mean and standard deviation of `values` (NaN-free ones).
pub fn mean_std(values: impl Iterator<Item = f64>) -> [f64; 2] {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return [f64::NAN, f64::NAN];
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64;
    [mean, var.sqrt()]
}
