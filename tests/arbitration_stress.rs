//! Random ticks: random scenes, states, modes and commands (malformed ones
//! included), the arm stepped by each command. Zero hard-constraint
//! violations (joint position and velocity limits, collisions along the
//! executed motion, checked by sampling it independently of the arbiter's
//! certification) and zero panics. 20,000 ticks in a debug build and
//! 1,000,000 in release; `TANDEM_STRESS_TICKS` overrides (`scripts/test.sh`
//! runs 1,000,000 on its debug build, with debug assertions on).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::sync::Arc;
use tandem::arbitration::{
    Arbiter, ArbiterGoal, ArbiterSettings, ArbitrationMode, HumanCommand, TickInput, TickStatus,
};
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use tandem::robot::RobotModel;
use tandem::scene::{Obstacle, Scene, Shape};
use tandem::trajectory::JointTrajectory;

const TICKS_PER_SCENE: usize = 1000;

#[derive(Default, Debug)]
struct Tally {
    ticks: usize,
    violations: usize,
    holds: usize,
    constrained: usize,
    /// Commands past an acceleration or jerk limit (finite differences at
    /// the period, from rest after each reset) that are not a category-0
    /// stop, and those that are (`halted` with zero: the braking step was
    /// not certified).
    limit_violations: usize,
    emergency_stops: usize,
    statuses: std::collections::BTreeMap<&'static str, usize>,
}

impl Tally {
    fn add(mut self, other: Tally) -> Tally {
        self.ticks += other.ticks;
        self.violations += other.violations;
        self.holds += other.holds;
        self.constrained += other.constrained;
        self.limit_violations += other.limit_violations;
        self.emergency_stops += other.emergency_stops;
        for (k, v) in other.statuses {
            *self.statuses.entry(k).or_default() += v;
        }
        self
    }
}

fn random_scene(rng: &mut ChaCha8Rng) -> Scene {
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04)).unwrap();
    scene.allow_contact("panda_link0", "table");
    for k in 0..rng.random_range(0..5) {
        let at = nalgebra::IsometryMatrix3::translation(
            rng.random_range(0.2..0.8),
            rng.random_range(-0.5..0.5),
            rng.random_range(0.05..0.8),
        );
        let shape = if rng.random_bool(0.5) {
            Shape::sphere(rng.random_range(0.03..0.12))
        } else {
            Shape::cuboid([rng.random_range(0.03..0.3), rng.random_range(0.03..0.3), rng.random_range(0.03..0.3)])
        };
        scene.add_obstacle(Obstacle::new(format!("o{k}"), shape, at)).unwrap();
    }
    scene
}

fn random_q(panda: &RobotModel, rng: &mut ChaCha8Rng) -> Vec<f64> {
    panda.limits().iter().map(|l| rng.random_range(l.lower..l.upper)).collect()
}

/// A random collision-free configuration (the last try if none in 100).
fn free_q(panda: &RobotModel, model: &CollisionModel, cws: &mut CollisionWorkspace, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut q = random_q(panda, rng);
    for _ in 0..100 {
        if model.collision_free(cws, &q).unwrap() {
            break;
        }
        q = random_q(panda, rng);
    }
    q
}

/// A random command: mostly well-formed with speeds from 1 mm/s to 2 m/s,
/// sometimes NaN, infinite, huge or of the wrong length.
fn random_command(rng: &mut ChaCha8Rng, buffer: &mut [f64; 8]) -> (usize, usize) {
    let kind = rng.random_range(0..3usize);
    let mut len = [3, 6, 7][kind];
    let scale = 10f64.powf(rng.random_range(-3.0..0.3));
    for x in buffer.iter_mut() {
        *x = scale * rng.random_range(-1.0..1.0);
    }
    match rng.random_range(0..100) {
        0 => buffer[rng.random_range(0..len)] = f64::NAN,
        1 => buffer[rng.random_range(0..len)] = f64::INFINITY,
        2 => buffer[0] = 1e300,
        3 => len = rng.random_range(0..8),
        _ => {}
    }
    (kind, len)
}

fn run_scene(seed: u64, ticks: usize) -> Tally {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let panda = Arc::new(RobotModel::panda());
    let scene = random_scene(&mut rng);
    let model = Arc::new(CollisionModel::builder(panda.clone()).scene(&scene).build().unwrap());
    let mut cws = CollisionWorkspace::new(&model);
    // A collision-free start; two goals with minimum-jerk references from it.
    let mut q = free_q(&panda, &model, &mut cws, &mut rng);
    let goals = (0..2)
        .map(|g| {
            let end = random_q(&panda, &mut rng);
            let reference = JointTrajectory::minimum_jerk(panda.joint_names().to_vec(), &q, &end, 3.0, 0.1).unwrap();
            let policy = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant).unwrap();
            let position = [rng.random_range(0.2..0.8), rng.random_range(-0.5..0.5), rng.random_range(0.0..0.6)];
            ArbiterGoal { name: format!("g{g}"), position, policy: Arc::new(policy) }
        })
        .collect();
    let arbiter = Arbiter::new(model.clone(), "panda_hand_tcp", goals, ArbiterSettings::default()).unwrap();
    let dt = arbiter.settings().period;
    let mut ws = arbiter.workspace();
    let mut tally = Tally::default();
    let (mut velocity, mut next, mut command) = (vec![0.0; 7], vec![0.0; 7], [0.0; 8]);
    let mut acceleration = [0.0; 7];
    for _ in 0..ticks {
        ws.set_mode(ArbitrationMode::ALL[rng.random_range(0..ArbitrationMode::ALL.len())]);
        let (kind, len) = random_command(&mut rng, &mut command);
        let values = &command[..len];
        let human = [HumanCommand::Linear(values), HumanCommand::Twist(values), HumanCommand::Joint(values)][kind];
        let beliefs = match rng.random_range(0..10) {
            0 => Some([0.3, 0.7]),
            1 => Some([f64::NAN, 1.0]),
            _ => None,
        };
        let given_velocity = if rng.random_range(0..100) == 0 { vec![f64::NAN; 7] } else { velocity.clone() };
        let was_free = model.collision_free(&mut cws, &q).unwrap();
        let input = TickInput {
            q: &q,
            velocity: Some(&given_velocity),
            command: human,
            beliefs: beliefs.as_ref().map(|b| &b[..]),
        };
        let out = arbiter.tick(&mut ws, &input);
        tally.ticks += 1;
        *tally.statuses.entry(out.status.as_str()).or_default() += 1;
        tally.holds += usize::from(out.status.is_hold());
        tally.constrained += usize::from(out.status == TickStatus::Constrained);
        if out.status == TickStatus::SolverFailed && std::env::var_os("TANDEM_STRESS_DEBUG").is_some() {
            eprintln!("solver failed: {:?} q {q:?} command {human:?}", out.diagnostics);
        }
        let mut past_limits = false;
        for (j, l) in panda.motion_limits().iter().enumerate() {
            let a = (out.qdot[j] - velocity[j]) / dt;
            let jerk = (a - acceleration[j]) / dt;
            past_limits |=
                a.abs() > l.acceleration.max(l.deceleration) * (1.0 + 1e-9) || jerk.abs() > l.jerk * (1.0 + 1e-9);
            acceleration[j] = a;
        }
        if past_limits && out.status == TickStatus::Halted && out.qdot.iter().all(|v| *v == 0.0) {
            tally.emergency_stops += 1;
            acceleration = [0.0; 7];
        } else {
            tally.limit_violations += usize::from(past_limits);
            if past_limits && std::env::var_os("TANDEM_STRESS_DEBUG").is_some() {
                eprintln!(
                    "past the motion limits: {:?} {:?}\n q {q:?}\n before {velocity:?}\n qdot {:?}",
                    out.status, out.diagnostics, out.qdot
                );
            }
        }
        velocity.copy_from_slice(out.qdot);
        let mut violated = false;
        for (j, l) in panda.limits().iter().enumerate() {
            next[j] = q[j] + dt * velocity[j];
            violated |= !(next[j] >= l.lower - 1e-9 && next[j] <= l.upper + 1e-9);
            violated |= velocity[j].abs() > l.velocity + 1e-9 || !velocity[j].is_finite();
        }
        if was_free && !model.motion_free(&mut cws, &q, &next, 0.002).unwrap() {
            violated = true;
        }
        tally.violations += usize::from(violated);
        // Occasionally teleport, so the walk covers the whole space.
        if rng.random_range(0..200) == 0 {
            q = free_q(&panda, &model, &mut cws, &mut rng);
            arbiter.reset(&mut ws);
            velocity.fill(0.0);
            acceleration = [0.0; 7];
        } else {
            q.copy_from_slice(&next);
        }
    }
    tally
}

#[test]
fn random_ticks_never_violate_hard_constraints() {
    let ticks: usize = std::env::var("TANDEM_STRESS_TICKS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if cfg!(debug_assertions) { 20_000 } else { 1_000_000 });
    let scenes = ticks.div_ceil(TICKS_PER_SCENE);
    let began = std::time::Instant::now();
    let tally = (0..scenes as u64)
        .into_par_iter()
        .map(|s| run_scene(s, TICKS_PER_SCENE.min(ticks - s as usize * TICKS_PER_SCENE)))
        .reduce(Tally::default, Tally::add);
    eprintln!(
        "{} ticks in {} scenes, {:.1} s: {} hard-constraint violations, {} motion-limit violations ({} category-0 stops), {} holds, {} constrained; statuses {:?}",
        tally.ticks,
        scenes,
        began.elapsed().as_secs_f64(),
        tally.violations,
        tally.limit_violations,
        tally.emergency_stops,
        tally.holds,
        tally.constrained,
        tally.statuses
    );
    assert_eq!(tally.ticks, ticks);
    assert_eq!(tally.violations, 0, "{tally:?}");
    assert_eq!(tally.limit_violations, 0, "{tally:?}");
    // The walk must reach the constraints, not just drift in free space.
    assert!(tally.constrained * 20 > tally.ticks, "only {} of {} ticks constrained", tally.constrained, tally.ticks);
}
