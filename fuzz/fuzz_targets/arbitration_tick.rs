//! One arbitration tick from arbitrary bytes: the mode, the command's kind
//! and length, the state, the velocity, the command and the beliefs all
//! come from the input (NaN, infinities, subnormals and wrong lengths
//! included). The arbiter (Panda, a table and two obstacles, two goals
//! with minimum-jerk references) is built once.
//!
//! Beyond "no panic": the command is finite and within the velocity limits
//! whatever the input, and from a collision-free state within the position
//! limits, one period of it stays within them and collision-free (checked
//! by sampling the motion every 2 mrad, independently of the arbiter's
//! certification).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::{Arc, Mutex, OnceLock};
use tandem::arbitration::{Arbiter, ArbiterGoal, ArbiterSettings, ArbiterWorkspace, ArbitrationMode, HumanCommand, TickInput};
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::scene::{Shape, Obstacle, Scene};
use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use tandem::trajectory::JointTrajectory;
use tandem::robot::RobotModel;

struct Setup {
    arbiter: Arbiter,
    ws: ArbiterWorkspace,
    model: Arc<CollisionModel>,
    cws: CollisionWorkspace,
}

fn setup() -> Setup {
    let panda = Arc::new(RobotModel::panda());
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04)).expect("table");
    scene.allow_contact("panda_link0", "table");
    let at = |x, y, z| nalgebra::IsometryMatrix3::translation(x, y, z);
    scene.add_obstacle(Obstacle::new("ball", Shape::sphere(0.08), at(0.5, 0.2, 0.4))).expect("ball");
    scene.add_obstacle(Obstacle::new("block", Shape::cuboid([0.1, 0.3, 0.2]), at(0.45, -0.3, 0.15))).expect("block");
    let model = Arc::new(CollisionModel::builder(panda.clone()).scene(&scene).build().expect("model"));
    let start = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let ends = [[0.5, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785], [-0.5, 0.1, 0.3, -1.8, 0.2, 1.9, 0.0]];
    let goals = ends
        .iter()
        .enumerate()
        .map(|(g, end)| {
            let reference =
                JointTrajectory::minimum_jerk(panda.joint_names().to_vec(), &start, end, 3.0, 0.1).expect("reference");
            let policy = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant).expect("policy");
            ArbiterGoal { name: format!("g{g}"), position: [0.5, 0.3 - 0.6 * g as f64, 0.3], policy: Arc::new(policy) }
        })
        .collect();
    let arbiter = Arbiter::new(model.clone(), "panda_hand_tcp", goals, ArbiterSettings::default()).expect("arbiter");
    let ws = arbiter.workspace();
    let cws = CollisionWorkspace::new(&model);
    Setup { arbiter, ws, model, cws }
}

/// Reads f64s from the input: 8 bytes each, or, one time in two, a small
/// value on the joint scale (so inputs reach the interesting states).
fn values(bytes: &mut &[u8], out: &mut [f64]) {
    for x in out.iter_mut() {
        let Some((&tag, rest)) = bytes.split_first() else { return };
        *bytes = rest;
        if tag & 1 == 0 || bytes.len() < 8 {
            *x = (f64::from(tag) - 128.0) / 40.0;
        } else {
            let (raw, rest) = bytes.split_at(8);
            *x = f64::from_le_bytes(raw.try_into().expect("eight bytes"));
            *bytes = rest;
        }
    }
}

fuzz_target!(|data: &[u8]| {
    static SETUP: OnceLock<Mutex<Setup>> = OnceLock::new();
    let mut guard = SETUP.get_or_init(|| Mutex::new(setup())).lock().unwrap_or_else(|e| e.into_inner());
    let Setup { arbiter, ws, model, cws } = &mut *guard;
    let [mode, kind, len, flags, ..] = *data else { return };
    let mut bytes = &data[4..];
    let (mut q, mut velocity, mut command, mut beliefs) = ([0.0; 7], [0.0; 7], [0.0; 8], [0.0; 2]);
    values(&mut bytes, &mut q);
    values(&mut bytes, &mut velocity);
    values(&mut bytes, &mut command);
    values(&mut bytes, &mut beliefs);
    if flags & 1 == 1 {
        arbiter.reset(ws);
    }
    ws.set_mode(ArbitrationMode::ALL[usize::from(mode) % ArbitrationMode::ALL.len()]);
    let values = &command[..usize::from(len) % 9];
    let human = [HumanCommand::Linear(values), HumanCommand::Twist(values), HumanCommand::Joint(values)]
        [usize::from(kind) % 3];
    let input = TickInput {
        q: &q,
        velocity: (flags & 2 == 2).then_some(&velocity[..]),
        command: human,
        beliefs: (flags & 4 == 4).then_some(&beliefs[..]),
    };
    let qdot: Vec<f64> = arbiter.tick(ws, &input).qdot.to_vec();
    let robot = arbiter.robot();
    for (v, l) in qdot.iter().zip(robot.limits()) {
        assert!(v.is_finite() && v.abs() <= l.velocity + 1e-9, "command {qdot:?} for {input:?}");
    }
    let within = |q: &[f64]| q.iter().zip(robot.limits()).all(|(x, l)| *x >= l.lower - 1e-9 && *x <= l.upper + 1e-9);
    if within(&q) && model.collision_free(cws, &q).unwrap_or(false) {
        let dt = arbiter.settings().period;
        let next: Vec<f64> = q.iter().zip(&qdot).map(|(x, v)| x + dt * v).collect();
        assert!(within(&next), "leaves the limits: {next:?} for {input:?}");
        assert!(model.motion_free(cws, &q, &next, 0.002).unwrap_or(false), "collides: {q:?} -> {next:?}");
    }
});
