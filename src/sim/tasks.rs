//! The dissertation's tasks, sampled from a seed: reach-and-grasp with a
//! Panda beside a second one (§5.5, Table 5.1) and planar pick-and-place
//! (chapter 4, Table 4.1). Each task comes with its goals prepared: the
//! reference optimized by the [pipeline](crate::pipeline) and its LQR
//! tracking policy. The experiments run them with simulated operators, the
//! teleoperation page with a person.
//!
//! **Reach-and-grasp** (fixed before any result was looked at). Each arm
//! stands at the origin of its own frame; the other Panda, held at the
//! ready pose, stands 0.6 m to its side (+y for the RIGHT arm, −y for the
//! LEFT) as collision spheres. The 6 × 6 × 12 cm box stands on the table
//! with its centre at x ∈ [0.4, 0.6] m, y ∈ [−0.2, 0.2] m, yaw ∈ [−π/2,
//! π/2]; the start is the ready pose plus U(−0.3, 0.3) rad per joint,
//! collision-free. The robot's reference comes from the optimizer
//! (`panda_grasp_box`'s objectives: approach above, then the grasp pointing
//! down). A task whose reference does not converge is resampled (counted).
//!
//! **Planar pick-and-place**: the planar gripper (`builtin:planar_pick`)
//! over a 50 × 50 cm table; two cylinders (red, yellow; r = 2.5 cm) near
//! the far edge (y ∈ [0.38, 0.45] m; red x ∈ [0.05, 0.2], yellow x ∈ [0.3,
//! 0.45]); a pole (r = 3 cm) near the centre (x ∈ [0.2, 0.3], y ∈ [0.18,
//! 0.28]); the gripper starts behind the pole (x ∈ [0.2, 0.3], y ∈ [0.02,
//! 0.08]). The user picks one cylinder (drawn at random) and brings it to a
//! place position on the near side (x ∈ [0.05, 0.45], y = 0.06, at least
//! 10 cm from the start in x). Phase 1 reaches the cylinder (within 1 cm)
//! with both cylinders as goals (intent decides); phase 2 carries it,
//! attached, to the place position.

use crate::arbitration::{ArbitrationError, GoalObjects, GoalSettings, ProblemGoal, problem_goals};
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::problem::{Goal, Problem};
use crate::scene::Obstacle;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

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
        let options = GoalSettings { seed: Some(rng.random()), objects: GoalObjects::Goal, ..GoalSettings::default() };
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
pub(crate) fn mix(a: u64, b: u64, c: u64, d: u64) -> u64 {
    let mut x = a;
    for v in [b, c, d] {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15).wrapping_add(v);
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^= x >> 31;
    }
    x
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
    let options = GoalSettings { seed: Some(seed), objects: GoalObjects::AllGraspable, ..GoalSettings::default() };
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
    let place = problem_goals(
        &carry,
        &GoalSettings { seed: Some(seed), objects: GoalObjects::Goal, ..GoalSettings::default() },
    )?
    .remove(0);
    Ok(PlanarTask { index, reach, target, place, pole })
}
