//! One arbitration tick from arbitrary bytes, on one of a pool of robots.
//!
//! The first byte picks one of [`POOL`] setups: setup 0 is the Panda (a
//! table, two obstacles, two goals); the others are generated from their
//! index — a serial chain of 1 to 12 revolute and prismatic joints (axes
//! along the frame axes or anywhere, offsets and tilts varied, limits wide
//! or as narrow as a few mrad or mm, velocity limits 0.05–3), its links
//! capsules, cylinders, boxes or spheres (some without geometry), with or
//! without a gripper on a fixed tool frame, written as URDF text and loaded
//! through tandem's URDF loader; a scene of 0–4 spheres and boxes (and
//! sometimes a table) around it; 1–4 goals, each a minimum-jerk reference
//! tracked by a [`TrackingPolicy`]. Setups 1 and 2 are arms of one and two
//! joints. The arbiter's task frame is the tool frame (the last link
//! without a gripper). Each setup is built on first use and kept.
//!
//! The rest of the input gives the mode, the command's kind and length, the
//! state (joint values mostly within the limits, or any f64), the velocity,
//! the command and the beliefs (NaN, infinities, subnormals and wrong
//! lengths included).
//!
//! Beyond "no panic": the command is finite and within the velocity limits
//! whatever the input, and from a collision-free state within the position
//! limits, one period of it stays within them and collision-free (checked
//! by sampling the motion every 2 mrad (or mm), independently of the
//! arbiter's certification).
//!
//! Flag 16 continues the motion instead of reading a state: the arm is
//! where the last command took it. Along such a chain, begun at rest (flag
//! 1) from a collision-free state within the limits, every command keeps
//! the robot's acceleration, deceleration and jerk limits by finite
//! differences at the period (`|Δq̇|/dt` and `|Δq̈|/dt`, computed here from
//! the commands, not read from the arbiter), except a category-0 stop — a
//! `halted` zero command, the documented last resort when not even the
//! braking step can be certified.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nalgebra::{IsometryMatrix3, Vector3};
use std::f64::consts::PI;
use std::fmt::Write;
use std::sync::{Arc, Mutex, OnceLock};
use tandem::arbitration::{
    Arbiter, ArbiterGoal, ArbiterSettings, ArbiterWorkspace, ArbitrationMode, HumanCommand, TickInput, TickStatus,
};
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use tandem::robot::{MeshSearchPath, RobotDescription, RobotModel};
use tandem::scene::{Obstacle, Scene, Shape};
use tandem::trajectory::JointTrajectory;

/// Setups in the pool (the first input byte, modulo this).
const POOL: usize = 48;
/// The most joints a generated arm has.
const MAX_JOINTS: usize = 12;
/// The most goals a setup has.
const MAX_GOALS: usize = 4;

struct Setup {
    arbiter: Arbiter,
    ws: ArbiterWorkspace,
    model: Arc<CollisionModel>,
    cws: CollisionWorkspace,
    /// The last tick: where its command took the arm, the command and the
    /// acceleration that reached it, and whether it is part of a chain
    /// begun at rest from a free state (see the module docs).
    last_q: Vec<f64>,
    last_qdot: Vec<f64>,
    last_acceleration: Vec<f64>,
    chain: bool,
}

impl Setup {
    fn new(robot: Arc<RobotModel>, scene: &Scene, tool: &str, goals: Vec<ArbiterGoal>) -> Setup {
        let model = Arc::new(CollisionModel::builder(robot).scene(scene).build().expect("collision model"));
        let arbiter = Arbiter::new(model.clone(), tool, goals, ArbiterSettings::default()).expect("arbiter");
        let ws = arbiter.workspace();
        let cws = CollisionWorkspace::new(&model);
        let n = arbiter.robot().nq();
        Setup {
            arbiter,
            ws,
            model,
            cws,
            last_q: vec![0.0; n],
            last_qdot: vec![0.0; n],
            last_acceleration: vec![0.0; n],
            chain: false,
        }
    }
}

/// A goal tracking a minimum-jerk reference from `start` to `end`.
fn goal(robot: &RobotModel, g: usize, start: &[f64], end: &[f64], duration: f64, position: [f64; 3]) -> ArbiterGoal {
    let reference =
        JointTrajectory::minimum_jerk(robot.joint_names().to_vec(), start, end, duration, 0.1).expect("reference");
    let policy = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant).expect("policy");
    ArbiterGoal { name: format!("g{g}"), position, policy: Arc::new(policy) }
}

/// The Panda, a table and two obstacles, two goals.
fn panda() -> Setup {
    let panda = Arc::new(RobotModel::panda());
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04)).expect("table");
    scene.allow_contact("panda_link0", "table");
    let at = |x, y, z| IsometryMatrix3::translation(x, y, z);
    scene.add_obstacle(Obstacle::new("ball", Shape::sphere(0.08), at(0.5, 0.2, 0.4))).expect("ball");
    scene.add_obstacle(Obstacle::new("block", Shape::cuboid([0.1, 0.3, 0.2]), at(0.45, -0.3, 0.15))).expect("block");
    let start = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let ends = [[0.5, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785], [-0.5, 0.1, 0.3, -1.8, 0.2, 1.9, 0.0]];
    let goals = (0..2).map(|g| goal(&panda, g, &start, &ends[g], 3.0, [0.5, 0.3 - 0.6 * g as f64, 0.3])).collect();
    Setup::new(panda, &scene, "panda_hand_tcp", goals)
}

/// SplitMix64: the generated setups' random stream.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// True with probability `p`.
    fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }

    /// Uniform in `0..n`.
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// A unit vector: a frame axis (either sign) or, one time in three, any direction.
    fn axis(&mut self) -> Vector3<f64> {
        if self.chance(1.0 / 3.0) {
            loop {
                let v = Vector3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
                if v.norm() > 0.1 {
                    return v.normalize();
                }
            }
        }
        let mut v = Vector3::zeros();
        v[self.below(3)] = if self.chance(0.5) { 1.0 } else { -1.0 };
        v
    }
}

/// A URDF `<collision>` element for a link spanning from its origin to
/// `tip` (a capsule, cylinder or box along it, or a sphere at its middle),
/// or nothing one time in ten.
fn link_geometry(rng: &mut Rng, tip: Vector3<f64>) -> String {
    if rng.chance(0.1) {
        return String::new();
    }
    let length = tip.norm().max(0.02);
    let radius = rng.range(0.01, 0.04);
    let mid = tip / 2.0;
    // The rotation taking z onto the link (URDF rpy: yaw about z after pitch about y).
    let pitch = (tip.x.hypot(tip.y)).atan2(tip.z);
    let yaw = tip.y.atan2(tip.x);
    let geometry = match rng.below(4) {
        0 => format!(r#"<capsule radius="{radius}" length="{length}"/>"#),
        1 => format!(r#"<cylinder radius="{radius}" length="{length}"/>"#),
        2 => format!(r#"<box size="{} {} {length}"/>"#, 2.0 * radius, rng.range(0.5, 2.0) * 2.0 * radius),
        _ => format!(r#"<sphere radius="{}"/>"#, radius.max(length / 3.0)),
    };
    format!(
        r#"<collision><origin xyz="{} {} {}" rpy="0 {pitch} {yaw}"/><geometry>{geometry}</geometry></collision>"#,
        mid.x, mid.y, mid.z
    )
}

/// A serial chain as URDF text: its active joints' limits are varied, its
/// links carry simple shapes. Returns the text and the tool frame's name.
fn chain_urdf(rng: &mut Rng, n: usize, gripper: bool) -> (String, String) {
    // The offsets from each joint to the next (and to the tool frame).
    let offsets: Vec<Vector3<f64>> = (0..=n)
        .map(|i| if i == 0 { Vector3::new(0.0, 0.0, rng.range(0.03, 0.12)) } else { rng.axis() * rng.range(0.05, 0.3) })
        .collect();
    let mut urdf = String::from(r#"<robot name="chain"><link name="base">"#);
    urdf.push_str(r#"<collision><origin xyz="0 0 0.025"/><geometry><box size="0.1 0.1 0.05"/></geometry></collision>"#);
    urdf.push_str("</link>");
    for i in 1..=n {
        let revolute = rng.chance(0.7);
        let axis = rng.axis();
        let o = offsets[i - 1];
        let rpy = if rng.chance(0.3) { [rng.range(-PI, PI), rng.range(-PI, PI), rng.range(-PI, PI)] } else { [0.0; 3] };
        let narrow = rng.chance(0.2);
        let (lower, upper) = if revolute {
            let centre = rng.range(-1.0, 1.0);
            let half = if narrow { rng.range(0.002, 0.05) } else { rng.range(0.3, 3.0) };
            (centre - half, centre + half)
        } else {
            let lower = rng.range(-0.2, 0.1);
            (lower, lower + if narrow { rng.range(0.002, 0.02) } else { rng.range(0.05, 0.4) })
        };
        let velocity = rng.range(0.05, 3.0);
        let kind = if revolute { "revolute" } else { "prismatic" };
        let parent = if i == 1 { "base".to_string() } else { format!("l{}", i - 1) };
        write!(
            urdf,
            r#"<joint name="j{i}" type="{kind}"><parent link="{parent}"/><child link="l{i}"/><origin xyz="{} {} {}" rpy="{} {} {}"/><axis xyz="{} {} {}"/><limit lower="{lower}" upper="{upper}" effort="10" velocity="{velocity}"/></joint>"#,
            o.x, o.y, o.z, rpy[0], rpy[1], rpy[2], axis.x, axis.y, axis.z
        )
        .expect("writing to a String");
        let geometry = if i < n || gripper { link_geometry(rng, offsets[i]) } else { String::new() };
        write!(urdf, r#"<link name="l{i}">{geometry}</link>"#).expect("writing to a String");
    }
    let tool = if gripper {
        let o = offsets[n];
        write!(
            urdf,
            r#"<joint name="tool_joint" type="fixed"><parent link="l{n}"/><child link="tool"/><origin xyz="{} {} {}"/></joint><link name="tool"><collision><origin xyz="0 0 -0.02"/><geometry><box size="0.03 0.08 0.04"/></geometry></collision></link>"#,
            o.x, o.y, o.z
        )
        .expect("writing to a String");
        "tool".to_string()
    } else {
        format!("l{n}")
    };
    urdf.push_str("</robot>");
    (urdf, tool)
}

/// Generated setup `index` (≥ 1): an arm of 1–12 joints (1 and 2 for
/// indices 1 and 2), its scene and goals.
fn generated(index: usize) -> Setup {
    let mut rng = Rng((index as u64).wrapping_mul(0x1234_5678_9ABC_DEF1));
    let n = match index {
        1 | 2 => index,
        _ => 1 + rng.below(MAX_JOINTS),
    };
    let gripper = index % 2 == 0 || rng.chance(0.5);
    let (urdf, tool) = chain_urdf(&mut rng, n, gripper);
    let description = RobotDescription::from_urdf_str(&urdf, &MeshSearchPath::default()).expect("generated URDF");
    let robot = Arc::new(RobotModel::builder(Arc::new(description)).build().expect("generated robot"));
    assert_eq!(robot.nq(), n, "the generated chain's joints");
    // Reach: the chain's length.
    let reach = 0.1 + 0.3 * n as f64;
    let mut scene = Scene::new();
    if rng.chance(0.3) {
        scene.add_obstacle(Obstacle::table("table", [0.0, 0.0, 0.0], [2.0 * reach, 2.0 * reach], 0.04)).expect("table");
        scene.allow_contact("base", "table");
    }
    let point = |rng: &mut Rng| [rng.range(-reach, reach), rng.range(-reach, reach), rng.range(0.0, reach)];
    for k in 0..rng.below(5) {
        let size = rng.range(0.03, 0.15);
        // Clear of the base, which cannot move away.
        let mut p = point(&mut rng);
        let d = Vector3::from(p).norm();
        if d < 0.2 + size {
            p = p.map(|x| x * (0.2 + size) / d.max(1e-3));
        }
        let shape = if rng.chance(0.5) {
            Shape::sphere(size)
        } else {
            Shape::cuboid([2.0 * size, rng.range(0.03, 0.3), rng.range(0.03, 0.3)])
        };
        let pose = IsometryMatrix3::translation(p[0], p[1], p[2]);
        scene.add_obstacle(Obstacle::new(format!("o{k}"), shape, pose)).expect("obstacle");
    }
    let start: Vec<f64> = robot.limits().iter().map(|l| 0.5 * (l.lower + l.upper)).collect();
    let goals = (0..1 + rng.below(MAX_GOALS))
        .map(|g| {
            let end: Vec<f64> = robot.limits().iter().map(|l| rng.range(l.lower, l.upper)).collect();
            let duration = rng.range(1.0, 4.0);
            goal(&robot, g, &start, &end, duration, point(&mut rng))
        })
        .collect();
    Setup::new(robot, &scene, &tool, goals)
}

/// Setup `index` of the pool, built on first use.
fn setup(index: usize) -> &'static Mutex<Setup> {
    static SETUPS: OnceLock<Vec<OnceLock<Mutex<Setup>>>> = OnceLock::new();
    let pool = SETUPS.get_or_init(|| (0..POOL).map(|_| OnceLock::new()).collect());
    pool[index].get_or_init(|| Mutex::new(if index == 0 { panda() } else { generated(index) }))
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
            *x = take_f64(bytes);
        }
    }
}

/// Eight bytes as an f64 (the caller checked there are eight).
fn take_f64(bytes: &mut &[u8]) -> f64 {
    let (raw, rest) = bytes.split_at(8);
    *bytes = rest;
    f64::from_le_bytes(raw.try_into().expect("eight bytes"))
}

/// Reads joint values: one time in two a point of the joint's range (64
/// steps from lower to upper), else as [`values`] (any f64, or small).
fn joint_values(bytes: &mut &[u8], limits: &[tandem::robot::JointLimits], out: &mut [f64]) {
    for (x, l) in out.iter_mut().zip(limits) {
        let Some((&tag, rest)) = bytes.split_first() else { return };
        *bytes = rest;
        *x = match tag & 3 {
            0 | 1 => l.lower + (l.upper - l.lower) * f64::from(tag >> 2) / 63.0,
            2 if bytes.len() >= 8 => take_f64(bytes),
            _ => (f64::from(tag) - 128.0) / 40.0,
        };
    }
}

fuzz_target!(|data: &[u8]| {
    let [index, mode, kind, len, flags, ..] = *data else { return };
    let mut guard = setup(usize::from(index) % POOL).lock().unwrap_or_else(|e| e.into_inner());
    let Setup { arbiter, ws, model, cws, last_q, last_qdot, last_acceleration, chain } = &mut *guard;
    let robot = arbiter.robot().clone();
    let (n, goals) = (robot.nq(), arbiter.goals().len());
    let mut bytes = &data[5..];
    let (mut q, mut velocity) = ([0.0; MAX_JOINTS], [0.0; MAX_JOINTS]);
    let (mut command, mut beliefs) = ([0.0; MAX_JOINTS + 2], [0.0; MAX_GOALS + 1]);
    let (q, velocity) = (&mut q[..n], &mut velocity[..n]);
    joint_values(&mut bytes, robot.limits(), q);
    values(&mut bytes, velocity);
    values(&mut bytes, &mut command);
    values(&mut bytes, &mut beliefs);
    let dt = arbiter.settings().period;
    let within = |q: &[f64]| q.iter().zip(robot.limits()).all(|(x, l)| *x >= l.lower - 1e-9 && *x <= l.upper + 1e-9);
    let continues = flags & 16 == 16;
    if continues {
        for ((x, last), v) in q.iter_mut().zip(last_q.iter()).zip(last_qdot.iter()) {
            *x = last + dt * v;
        }
    }
    if flags & 1 == 1 {
        arbiter.reset(ws);
        last_qdot.fill(0.0);
        last_acceleration.fill(0.0);
        *chain = within(q) && model.collision_free(cws, q).unwrap_or(false);
    } else if !continues {
        *chain = false;
    }
    ws.set_mode(ArbitrationMode::ALL[usize::from(mode) % ArbitrationMode::ALL.len()]);
    let values = &command[..usize::from(len) % (MAX_JOINTS + 3)];
    let human =
        [HumanCommand::Linear(values), HumanCommand::Twist(values), HumanCommand::Joint(values)][usize::from(kind) % 3];
    // Flag 8: one belief too many.
    let beliefs = &beliefs[..goals + usize::from(flags & 8 == 8)];
    let input = TickInput {
        q,
        velocity: (flags & 2 == 2).then_some(&velocity[..]),
        command: human,
        beliefs: (flags & 4 == 4).then_some(beliefs),
    };
    let out = arbiter.tick(ws, &input);
    let (qdot, status): (Vec<f64>, TickStatus) = (out.qdot.to_vec(), out.status);
    assert_eq!(qdot.len(), n, "one velocity per joint");
    for (v, l) in qdot.iter().zip(robot.limits()) {
        assert!(v.is_finite() && v.abs() <= l.velocity + 1e-9, "command {qdot:?} for {input:?}");
    }
    let category_0_stop = status == TickStatus::Halted && qdot.iter().all(|v| *v == 0.0);
    for (j, l) in robot.motion_limits().iter().enumerate() {
        let a = (qdot[j] - last_qdot[j]) / dt;
        let jerk = (a - last_acceleration[j]) / dt;
        let past = a.abs() > l.acceleration.max(l.deceleration) * (1.0 + 1e-9) || jerk.abs() > l.jerk * (1.0 + 1e-9);
        assert!(
            !(*chain && past) || category_0_stop,
            "joint {j}: acceleration {a}, jerk {jerk} past {l:?} along a chain from rest: {input:?} -> {qdot:?}"
        );
        (last_qdot[j], last_acceleration[j]) = (qdot[j], if category_0_stop { 0.0 } else { a });
    }
    last_q.copy_from_slice(q);
    if within(q) && model.collision_free(cws, q).unwrap_or(false) {
        let next: Vec<f64> = q.iter().zip(&qdot).map(|(x, v)| x + dt * v).collect();
        assert!(within(&next), "leaves the limits: {next:?} for {input:?}");
        assert!(model.motion_free(cws, q, &next, 0.002).unwrap_or(false), "collides: {q:?} -> {next:?}");
    }
});
