//! `tandem ros2`'s control loop without the middleware: holds on stale or
//! malformed input (duplicate joint names and non-finite commands among
//! them, named in the diagnostics), allocation-free ticks, and a million
//! ticks of the loop's bookkeeping under hostile input, allocating nothing
//! and never waiting for a log whose writer is stuck. The node on DDS
//! against Cyclone DDS peers is tests/ros2_node.rs.
#![cfg(feature = "ros2")]

mod common;

use common::alloc::{CountingAllocator, allocations};
use std::io::Write;
use std::time::{Duration, Instant};
use tandem::arbitration::{Arbiter, ArbiterSettings, GoalSettings, problem_goals};
use tandem::problem::Problem;
use tandem::ros2::log::NodeLog;
use tandem::ros2::messages::{Header, JointJog, JointState, Time, Twist, TwistStamped, Vector3};
use tandem::ros2::ticker::Ticker;
use tandem::ros2::{COMMAND_STALE, ControlLoop, HOLDS, NodeSettings, STATE_STALE};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn panda_loop(settings: &NodeSettings) -> ControlLoop {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let goals = problem_goals(&problem, &GoalSettings { seed: Some(0), ..GoalSettings::default() }).unwrap();
    let arbiter = Arbiter::for_problem(&problem, &goals, ArbiterSettings::default()).unwrap();
    ControlLoop::new(&arbiter, settings).unwrap()
}

fn state(names: &[String], q: &[f64]) -> JointState {
    let mut name = names.to_vec();
    let mut position = q.to_vec();
    // A finger the node does not drive, as a Panda's /joint_states has.
    name.push("panda_finger_joint1".into());
    position.push(0.04);
    JointState { header: Header::default(), name, position, velocity: vec![], effort: vec![] }
}

fn twist(frame: &str, v: [f64; 3]) -> TwistStamped {
    TwistStamped {
        header: Header { stamp: Time { sec: 1, nanosec: 500 }, frame_id: frame.into() },
        twist: Twist { linear: Vector3 { x: v[0], y: v[1], z: v[2] }, angular: Vector3::default() },
    }
}

#[test]
fn the_control_loop_holds_on_stale_or_malformed_input_and_ticks_without_allocating() {
    let settings = NodeSettings { rate_hz: 100.0, ..NodeSettings::default() };
    let mut control = panda_loop(&settings);
    let names = control.arbiter().robot().joint_names().to_vec();
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let t0 = Instant::now();
    let at = |s: f64| t0 + Duration::from_secs_f64(s);
    // Nothing yet: stale state.
    assert_eq!(control.tick(at(0.0)).code, STATE_STALE);
    control.joint_state(&state(&names, &problem.start), at(0.0));
    // A state but no command: stale command, a hold at the measured position.
    let out = control.tick(at(0.01));
    assert_eq!(out.code, COMMAND_STALE);
    assert!(out.qdot.iter().all(|v| *v == 0.0));
    assert_eq!(out.positions, problem.start);
    // A fresh command moves the arm along it, and reports its stamp once.
    control.twist(&twist("panda_link0", [0.05, 0.0, 0.0]), at(0.02));
    control.joint_state(&state(&names, &problem.start), at(0.02));
    let out = control.tick(at(0.02));
    assert!(out.status.is_some_and(|s| !s.is_hold()), "{:?}", out.status);
    assert!(out.qdot.iter().any(|v| *v != 0.0));
    assert!((out.command_stamp - (1.0 + 500e-9)).abs() < 1e-12, "{}", out.command_stamp);
    assert!(control.tick(at(0.03)).command_stamp.is_nan());
    // The command ages past the timeout (0.1 s): hold.
    control.joint_state(&state(&names, &problem.start), at(0.12));
    assert_eq!(control.tick(at(0.125)).code, COMMAND_STALE);
    // The state ages past its timeout: hold.
    control.twist(&twist("", [0.05, 0.0, 0.0]), at(0.3));
    assert_eq!(control.tick(at(0.3)).code, STATE_STALE);
    control.joint_state(&state(&names, &problem.start), at(0.3));
    let moving = control.tick(at(0.3));
    // After a hold the command ramps up within the acceleration limits: 10
    // (constrained) while a limit binds.
    assert!(matches!(moving.code, 0 | 10), "{}", moving.code);
    let moving = moving.qdot.to_vec();
    // NaN, a frame the node does not know, an unknown joint: -1, a hold
    // (the arbiter's braking step: slower than the motion, within its limits).
    for bad in [twist("", [f64::NAN, 0.0, 0.0]), twist("camera_link", [0.05, 0.0, 0.0])] {
        control.twist(&bad, at(0.31));
        let out = control.tick(at(0.31));
        assert_eq!(out.code, -1, "{bad:?}");
        assert!(out.qdot.iter().zip(&moving).all(|(v, m)| v.abs() <= m.abs() + 1e-12), "{:?}", out.qdot);
    }
    let jog = JointJog { joint_names: vec!["elbow".into()], velocities: vec![0.1], ..JointJog::default() };
    control.joint_jog(&jog, at(0.32));
    assert_eq!(control.tick(at(0.32)).code, -1);
    // A state without one of the arm's joints, or with NaN: -1, a hold.
    let mut missing = state(&names, &problem.start);
    missing.name.remove(3);
    missing.position.remove(3);
    control.twist(&twist("", [0.05, 0.0, 0.0]), at(0.33));
    control.joint_state(&missing, at(0.33));
    assert_eq!(control.tick(at(0.33)).code, -1);
    let mut nan = state(&names, &problem.start);
    nan.position[0] = f64::NAN;
    control.joint_state(&nan, at(0.34));
    assert_eq!(control.tick(at(0.34)).code, -1);
    // A joint command for two joints moves only those.
    control.joint_state(&state(&names, &problem.start), at(0.35));
    let jog = JointJog {
        joint_names: vec![names[0].clone(), names[3].clone()],
        velocities: vec![0.1, -0.1],
        ..JointJog::default()
    };
    control.joint_jog(&jog, at(0.35));
    control.set_mode("direct").unwrap();
    let out = control.tick(at(0.35));
    assert!(out.status.is_some_and(|s| !s.is_hold()));
    assert!((out.qdot[0] - 0.1).abs() < 1e-9 && (out.qdot[3] + 0.1).abs() < 1e-9, "{:?}", out.qdot);
    assert!(control.set_mode("learned").is_err(), "learned without an actor");
    assert!(control.set_mode("fast").is_err());
    // A twist in the gripper frame is the world twist rotated by the
    // gripper's orientation: in direct mode both give the same joint
    // velocity, each the first tick of a fresh loop at the start.
    let robot = control.arbiter().robot().clone();
    let mut kin = tandem::robot::KinematicsWorkspace::new(&robot);
    robot.forward_kinematics(&mut kin, &problem.start).unwrap();
    let r = robot.frame_pose(&kin, control.arbiter().gripper_frame()).rotation;
    let local = [0.03, -0.02, 0.04];
    let world = r * nalgebra::Vector3::from(local);
    let first_tick = |frame: &str, v: [f64; 3]| {
        let mut fresh = panda_loop(&settings);
        fresh.set_mode("direct").unwrap();
        fresh.joint_state(&state(&names, &problem.start), at(0.36));
        fresh.twist(&twist(frame, v), at(0.36));
        fresh.tick(at(0.36)).qdot.clone()
    };
    let from_local = first_tick("panda_hand_tcp", local);
    let from_world = first_tick("panda_link0", [world.x, world.y, world.z]);
    assert!(from_local.iter().any(|v| *v != 0.0), "the twist moves the arm");
    let gap = from_local.iter().zip(&from_world).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(gap < 1e-9, "gripper-frame twist differs from its world twist by {gap}");

    // Allocation-free: after a warm-up, reading the same messages and
    // ticking in sos mode allocates nothing.
    control.set_mode("sos").unwrap();
    let msg = state(&names, &problem.start);
    let cmd = twist("", [0.05, 0.0, -0.02]);
    for i in 0..20 {
        control.joint_state(&msg, at(0.4 + i as f64 * 0.01));
        control.twist(&cmd, at(0.4 + i as f64 * 0.01));
        control.tick(at(0.4 + i as f64 * 0.01));
    }
    let before = allocations();
    for i in 20..220 {
        let now = at(0.4 + i as f64 * 0.01);
        control.joint_state(&msg, now);
        control.twist(&cmd, now);
        let out = control.tick(now);
        assert!(out.status.is_some(), "tick {i}");
    }
    assert_eq!(allocations() - before, 0, "the loop allocated while ticking");
}

/// The node's loop without DDS — a joint state, a command, a mode name
/// from the topic, the control tick, the bookkeeping (tick statistics, the
/// log, the watchdog's heartbeat) — a million times under the counting
/// allocator, with hostile input throughout (a 10,000-character unknown
/// mode name every tick, duplicate joint names, infinite twists) and a log
/// whose writer never returns: nothing allocated after the warm-up,
/// nothing waited for, the lines that did not fit counted.
///
/// The arbiter's full tick (a QP) runs in the nominal quarter of the ticks
/// (250,000), the node's holds (forward kinematics) in the others: a
/// million full ticks would take about 40 s in the test build; the
/// bookkeeping runs every tick.
#[test]
fn a_million_ticks_of_the_loop_allocate_nothing_and_never_wait_for_the_log() {
    struct Stuck;
    impl Write for Stuck {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            loop {
                std::thread::park();
            }
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let settings = NodeSettings { rate_hz: 100.0, ..NodeSettings::default() };
    let period = Duration::from_secs_f64(settings.period());
    let mut control = panda_loop(&settings);
    let names = control.arbiter().robot().joint_names().to_vec();
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let good = state(&names, &problem.start);
    let mut twice = good.clone();
    twice.name.insert(0, names[0].clone());
    twice.position.insert(0, problem.start[0] + 1.0);
    let slow = twist("", [0.02, 0.0, -0.01]);
    let infinite = twist("", [f64::INFINITY, 0.0, 0.0]);
    let jog = JointJog {
        joint_names: vec![names[0].clone(), names[0].clone()],
        velocities: vec![0.1, -0.1],
        ..JointJog::default()
    };
    let hostile = format!("fastest-{}", "x".repeat(10_000));
    let t0 = Instant::now();
    let mut ticker = Ticker::new(NodeLog::spawn(Box::new(Stuck)).unwrap(), period, t0).unwrap();
    let mut held = [0u64; 4];
    let step = |i: u64, control: &mut ControlLoop, ticker: &mut Ticker, held: &mut [u64; 4]| {
        // Simulated time at 100 Hz: the rate limit sees 10,000 s go by.
        let now = t0 + period * (i as u32);
        let phase = ((i / 50) % 4) as usize;
        control.joint_state(if phase == 1 { &twice } else { &good }, now);
        match phase {
            2 => control.twist(&infinite, now),
            3 => control.joint_jog(&jog, now),
            _ => control.twist(&slow, now),
        }
        assert!(ticker.mode_name(control, &hostile, now).is_none());
        let out = control.tick(now);
        if out.hold_reason.is_some() {
            held[phase] += 1;
        }
        ticker.ticked(out, &names, Instant::now() + period, now);
    };
    for i in 0..1_000 {
        step(i, &mut control, &mut ticker, &mut held);
    }
    let before = allocations();
    let began = Instant::now();
    for i in 1_000..1_001_000 {
        step(i, &mut control, &mut ticker, &mut held);
    }
    let allocated = allocations() - before;
    let seconds = began.elapsed().as_secs_f64();
    assert_eq!(allocated, 0, "the loop allocated {allocated} times in a million ticks");
    let report = ticker.finish();
    eprintln!("a million ticks of the loop in {seconds:.1} s: {report:?}, holds by phase {held:?}");
    // Every phase but the nominal one held every tick; the nominal one never.
    assert!(held[1] == held[2] && held[2] == held[3] && held[1] == 250_250, "{held:?}");
    assert_eq!(held[0], 0, "{held:?}");
    // The writer never returned: the lines beyond the queue were dropped,
    // counted; the rest of the refusals suppressed by the rate limit.
    assert!(report.log.dropped > 5_000, "{report:?}");
    assert!(report.log.suppressed > 980_000, "{report:?}");
    assert!(
        report.tick_us[0] > 0.0 && report.tick_us[1] >= report.tick_us[0] && report.tick_us[2] >= report.tick_us[1]
    );
}

/// Duplicate joint names and non-finite commands hold with -1, naming the
/// reason and the joint (in the output and the diagnostics); a good
/// message after them moves the arm again.
#[test]
fn duplicate_names_and_infinite_commands_hold_naming_the_joint() {
    let settings = NodeSettings { rate_hz: 100.0, ..NodeSettings::default() };
    let mut control = panda_loop(&settings);
    control.set_mode("direct").unwrap();
    let names = control.arbiter().robot().joint_names().to_vec();
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let t0 = Instant::now();
    let at = |s: f64| t0 + Duration::from_secs_f64(s);
    let good = state(&names, &problem.start);
    let hold_index = |reason: &str| (HOLDS.iter().position(|h| *h == reason).unwrap() + 1) as f64;
    // panda_joint1 twice, the first 1 rad off: which is the arm's? Neither.
    let mut twice = good.clone();
    twice.name.insert(0, names[0].clone());
    twice.position.insert(0, problem.start[0] + 1.0);
    control.joint_state(&twice, at(0.0));
    control.twist(&twist("", [0.05, 0.0, 0.0]), at(0.0));
    let out = control.tick(at(0.0));
    assert_eq!((out.code, out.hold_joint), (-1, Some(0)));
    assert_eq!(out.hold_reason, Some("joint states invalid: one of the arm's joints named twice"));
    assert_eq!(out.diagnostics[16], hold_index("joint states invalid: one of the arm's joints named twice"));
    assert_eq!(out.diagnostics[17], 0.0);
    assert!(out.qdot.iter().all(|v| *v == 0.0));
    // A finger named twice is not the arm's business.
    let mut fingers = good.clone();
    fingers.name.push("panda_finger_joint1".into());
    fingers.position.push(0.04);
    control.joint_state(&fingers, at(0.01));
    let out = control.tick(at(0.01));
    assert!(out.status.is_some_and(|s| !s.is_hold()), "{:?}", out.hold_reason);
    assert_eq!(out.diagnostics[16], 0.0);
    // A JointJog naming joint 4 twice, the last value executed before: a hold now.
    let jog = JointJog {
        joint_names: vec![names[3].clone(), names[3].clone()],
        velocities: vec![0.1, -0.1],
        ..JointJog::default()
    };
    control.joint_state(&good, at(0.02));
    control.joint_jog(&jog, at(0.02));
    let out = control.tick(at(0.02));
    assert_eq!(
        (out.code, out.hold_reason, out.hold_joint),
        (-1, Some("command invalid: a joint named twice"), Some(3))
    );
    assert!(out.qdot.iter().all(|v| *v == 0.0));
    // Infinite (and NaN) twists, in any component, and infinite jogs hold
    // like NaN ones; the arm moved at max_speed along an infinite axis before.
    for v in [[f64::INFINITY, 0.0, 0.0], [0.0, f64::NEG_INFINITY, 0.0], [f64::NAN, 0.0, 0.0]] {
        control.twist(&twist("", v), at(0.03));
        let out = control.tick(at(0.03));
        assert_eq!((out.code, out.hold_reason), (-1, Some("command invalid: not finite (NaN or infinite)")), "{v:?}");
        assert!(out.qdot.iter().all(|v| *v == 0.0));
    }
    let mut angular = twist("", [0.01, 0.0, 0.0]);
    angular.twist.angular.z = f64::INFINITY;
    control.twist(&angular, at(0.04));
    assert_eq!(control.tick(at(0.04)).code, -1);
    let jog = JointJog { joint_names: vec![names[1].clone()], velocities: vec![f64::INFINITY], ..JointJog::default() };
    control.joint_jog(&jog, at(0.05));
    let out = control.tick(at(0.05));
    assert_eq!((out.code, out.hold_joint), (-1, Some(1)));
    // A finite but huge twist keeps its direction at max_speed, as in the library.
    control.twist(&twist("", [1e300, 0.0, 0.0]), at(0.06));
    let out = control.tick(at(0.06));
    assert!(out.status.is_some_and(|s| !s.is_hold()) && out.qdot.iter().any(|v| *v != 0.0));
    // A mode name of any length is refused without echoing it here.
    assert_eq!(control.parse_mode(&"x".repeat(100_000)), Err(tandem::ros2::ModeRefusal::Unknown));
    assert_eq!(control.parse_mode(" direct "), Ok(tandem::arbitration::ArbitrationMode::DirectControl));
}
