//! Commands a real arm accepts: the recorded commands of every method and
//! operator checked against the Franka Panda's published limits by an
//! independent checker (python_ref/franka_limits_check.py, the limits
//! written out there from libfranka, finite differences at the recording's
//! own period) at 15 Hz, 100 Hz and 1 kHz; holds that brake within the
//! limits and then stand exactly still; joints that stop before their
//! position limits; joint_limits.yaml read through a problem file.

mod common;

use std::sync::Arc;
use tandem::arbitration::{
    Arbiter, ArbiterGoal, ArbiterSettings, ArbiterWorkspace, HumanCommand, MotionAudit, SafetySettings, TickInput,
    TickStatus,
};
use tandem::collision::CollisionModel;
use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use tandem::experiments::{ReachGraspSettings, run_reach_grasp};
use tandem::robot::{LimitSource, RobotModel};
use tandem::scene::Scene;
use tandem::sim::Arm;
use tandem::trajectory::JointTrajectory;

/// Runs every operator and method of the reach-and-grasp experiment on one
/// task at `rate` (Hz), records the episodes, and returns the checker's
/// summary with the experiment's own audit (violations, peak acceleration
/// and jerk ratios).
fn check_experiment(rate: f64, motion_limits: bool) -> (serde_json::Value, (usize, f64, f64)) {
    let dir = tempfile::tempdir().unwrap();
    let defaults = ArbiterSettings::default();
    let settings = ReachGraspSettings {
        tasks: 1,
        seed: 2026,
        arms: vec![Arm::Right],
        record_dir: Some(dir.path().join("episodes")),
        arbiter: ArbiterSettings {
            period: 1.0 / rate,
            safety: SafetySettings { motion_limits, ..defaults.safety },
            ..defaults
        },
        ..ReachGraspSettings::default()
    };
    let results = run_reach_grasp(&settings, &|| {}).expect("experiment runs");
    let episodes = dir.path().join("episodes");
    let out = common::run_python("franka_limits_check.py", &[episodes.to_str().unwrap()], "");
    let summary: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(summary["episodes"], results.episodes.len(), "{summary}");
    let audit = results.episodes.iter().fold((0, 0.0_f64, 0.0_f64), |(n, a, j), e| {
        (n + e.limit_violations, a.max(e.peak_acceleration_ratio), j.max(e.peak_jerk_ratio))
    });
    (summary, audit)
}

#[test]
fn every_method_and_operator_meets_the_panda_limits_at_15_100_and_1000_hz() {
    for rate in [15.0, 100.0, 1000.0] {
        let (summary, (violations, acc, jerk)) = check_experiment(rate, true);
        let period = summary["period_s"][0].as_f64().unwrap();
        assert!((period - 1.0 / rate).abs() < 1e-9, "{summary}");
        assert!(summary["commands"].as_u64().unwrap() > 1000, "{summary}");
        for what in ["velocity", "acceleration", "jerk"] {
            assert_eq!(summary["violations"][what], 0, "{rate} Hz: {what} limits broken: {summary}");
            let peak = summary["peak_ratio"][what].as_f64().unwrap();
            assert!(peak <= 1.0 + 1e-9, "{rate} Hz: {what} at {peak} of the limit: {summary}");
        }
        // tandem's own audit sees the same sequence.
        assert_eq!(violations, 0, "{rate} Hz");
        let checker = |w: &str| summary["peak_ratio"][w].as_f64().unwrap();
        assert!((acc - checker("acceleration")).abs() <= 1e-9 * acc.max(1.0), "{rate} Hz: {acc} vs {summary}");
        assert!((jerk - checker("jerk")).abs() <= 1e-9 * jerk.max(1.0), "{rate} Hz: {jerk} vs {summary}");
        // At 1 kHz the limits bind: commands reach them, not stay far below.
        if rate == 1000.0 {
            assert!(checker("acceleration") > 0.99 && checker("jerk") > 0.99, "{summary}");
        }
    }
}

#[test]
fn without_the_limits_the_checker_sees_what_a_panda_would_refuse() {
    // The control: tandem before the limits (and the checker's ability to fail).
    let (summary, (violations, acc, _)) = check_experiment(100.0, false);
    let broken = summary["violations"]["acceleration"].as_u64().unwrap();
    assert!(broken > 0 && violations > 0, "{summary}");
    let peak = summary["peak_ratio"]["acceleration"].as_f64().unwrap();
    assert!(peak > 2.0 && (acc - peak).abs() <= 1e-9 * peak, "{acc} vs {summary}");
}

const READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
const GOAL: [f64; 7] = [0.5, -0.3, -0.2, -2.0, 0.1, 1.9, 0.5];

fn free_arbiter(rate: f64, motion_limits: bool) -> Arbiter {
    let panda = Arc::new(RobotModel::panda());
    let reference = JointTrajectory::minimum_jerk(panda.joint_names().to_vec(), &READY, &GOAL, 3.0, 0.05).unwrap();
    let policy =
        Arc::new(TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::TimeVarying).unwrap());
    let goals = vec![ArbiterGoal { name: "a".into(), position: [0.5, 0.3, 0.2], policy }];
    let model = Arc::new(CollisionModel::builder(panda).scene(&Scene::new()).build().unwrap());
    let defaults = ArbiterSettings::default();
    let settings =
        ArbiterSettings { period: 1.0 / rate, safety: SafetySettings { motion_limits, ..defaults.safety }, ..defaults };
    Arbiter::new(model, "panda_hand_tcp", goals, settings).unwrap()
}

/// Ticks `ws` at `q` with `command`, moving `q` by the command; returns the
/// status and checks every command with `audit`.
fn step(
    arbiter: &Arbiter,
    ws: &mut ArbiterWorkspace,
    q: &mut [f64],
    command: HumanCommand<'_>,
    audit: &mut MotionAudit,
) -> (TickStatus, Vec<f64>) {
    let dt = arbiter.settings().period;
    let tick = arbiter.tick(ws, &TickInput::new(q, command));
    let qdot = tick.qdot.to_vec();
    audit.observe(&qdot, dt, arbiter.robot().motion_limits());
    for (x, v) in q.iter_mut().zip(&qdot) {
        *x += v * dt;
    }
    (tick.status, qdot)
}

#[test]
fn a_hold_brakes_within_the_limits_and_then_stands_exactly_still() {
    for rate in [1000.0, 100.0] {
        let arbiter = free_arbiter(rate, true);
        let mut ws = arbiter.workspace();
        let mut q = READY;
        let mut audit = MotionAudit::new(7);
        let moving = [0.0, 0.15, -0.1];
        let ticks = |seconds: f64| (seconds * rate) as usize;
        let mut speed = 0.0_f64;
        for _ in 0..ticks(0.5) {
            let (status, qdot) = step(&arbiter, &mut ws, &mut q, HumanCommand::Linear(&moving), &mut audit);
            assert!(!status.is_hold(), "{status:?}");
            speed = qdot.iter().fold(0.0, |m, v| m.max(v.abs()));
        }
        assert!(speed > 0.1, "the arm moves before the hold ({speed} rad/s)");
        // A NaN command: a hold, a controlled stop (never a jump to zero).
        let nan = [f64::NAN, 0.0, 0.0];
        let mut stopped_after = None;
        let mut last = vec![];
        for k in 0..ticks(1.0) {
            let (status, qdot) = step(&arbiter, &mut ws, &mut q, HumanCommand::Linear(&nan), &mut audit);
            assert_eq!(status, TickStatus::InvalidCommand);
            if k == 0 {
                assert!(qdot.iter().any(|v| v.abs() > 0.5 * speed.min(0.1)), "the first hold tick brakes, not stops");
            }
            if stopped_after.is_none() && qdot.iter().all(|v| *v == 0.0) {
                stopped_after = Some(k);
            }
            if stopped_after.is_some() {
                assert!(qdot.iter().all(|v| *v == 0.0), "still once stopped, tick {k}: {qdot:?}");
                assert!(last.is_empty() || last == q.to_vec(), "the configuration does not change once stopped");
                last = q.to_vec();
            }
        }
        let k = stopped_after.expect("the hold stops within 1 s");
        // Stopping from `speed` at the slowest joint's 7.5 rad/s², with the jerk ramp.
        assert!((k as f64) / rate <= speed / 7.5 + 0.02, "{rate} Hz: stopped after {k} ticks from {speed} rad/s");
        assert_eq!(audit.violations, 0, "{rate} Hz: {audit:?}");
        // The same without the limits jumps to zero: what a Panda refuses.
        let plain = free_arbiter(rate, false);
        let (mut ws, mut q, mut audit) = (plain.workspace(), READY, MotionAudit::new(7));
        for _ in 0..ticks(0.5) {
            step(&plain, &mut ws, &mut q, HumanCommand::Linear(&moving), &mut audit);
        }
        let (_, qdot) = step(&plain, &mut ws, &mut q, HumanCommand::Linear(&nan), &mut audit);
        assert!(qdot.iter().all(|v| *v == 0.0) && audit.violations > 0, "{audit:?}");
    }
}

#[test]
fn a_mode_switch_and_a_reversal_stay_within_the_limits() {
    let arbiter = free_arbiter(1000.0, true);
    let mut ws = arbiter.workspace();
    let mut q = READY;
    let mut audit = MotionAudit::new(7);
    let modes = tandem::arbitration::ArbitrationMode::ALL;
    for (i, mode) in modes.iter().enumerate() {
        ws.set_mode(*mode);
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        let command = [0.0, sign * 0.2, 0.05];
        for _ in 0..150 {
            step(&arbiter, &mut ws, &mut q, HumanCommand::Linear(&command), &mut audit);
        }
    }
    assert_eq!(audit.violations, 0, "{audit:?}");
    assert!(audit.peak_acceleration_ratio > 0.5, "the reversals use the limits: {audit:?}");
}

/// New goals mid-motion (the ROS 2 node's PoseArray, a lift after the
/// approach): a new arbiter's workspace that continues the old one's
/// motion starts within the limits from the last command; a fresh one
/// would bound its first command relative to rest.
#[test]
fn a_new_arbiter_mid_motion_continues_the_commanded_motion() {
    let arbiter = free_arbiter(1000.0, true);
    let mut ws = arbiter.workspace();
    let mut q = READY;
    let mut audit = MotionAudit::new(7);
    let moving = [0.0, 0.15, -0.1];
    let mut speed = 0.0_f64;
    for _ in 0..400 {
        let (_, qdot) = step(&arbiter, &mut ws, &mut q, HumanCommand::Linear(&moving), &mut audit);
        speed = qdot.iter().fold(0.0, |m, v| m.max(v.abs()));
    }
    assert!(speed > 0.1, "moving at {speed} rad/s");
    let replanned = free_arbiter(1000.0, true);
    let mut continued = replanned.workspace();
    continued.continue_motion(&ws);
    for _ in 0..400 {
        step(&replanned, &mut continued, &mut q, HumanCommand::Linear(&moving), &mut audit);
    }
    assert_eq!(audit.violations, 0, "{audit:?}");
    // A fresh workspace starts from rest: its first command is bounded
    // near zero, a jump down from `speed` the audit sees.
    let mut fresh = replanned.workspace();
    let mut jumped = audit.clone();
    step(&replanned, &mut fresh, &mut q, HumanCommand::Linear(&moving), &mut jumped);
    assert!(jumped.violations > 0, "{jumped:?}");
}

#[test]
fn a_joint_stops_before_its_position_limit() {
    let arbiter = free_arbiter(1000.0, true);
    let limits = arbiter.robot().limits().to_vec();
    let mut ws = arbiter.workspace();
    // Joint 1 at full speed toward its upper limit, 0.6 rad away.
    let mut q = READY;
    q[0] = limits[0].upper - 0.6;
    let mut audit = MotionAudit::new(7);
    let push = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let mut fastest = 0.0_f64;
    for _ in 0..2000 {
        let (_, qdot) = step(&arbiter, &mut ws, &mut q, HumanCommand::Joint(&push), &mut audit);
        fastest = fastest.max(qdot[0]);
        assert!(q[0] <= limits[0].upper, "joint 1 at {} past {}", q[0], limits[0].upper);
    }
    assert!(fastest > 1.5, "it got fast ({fastest} rad/s)");
    assert!(limits[0].upper - q[0] < 1e-3, "and it reached the limit: {} short", limits[0].upper - q[0]);
    assert_eq!(audit.violations, 0, "{audit:?}");
}

#[test]
fn the_embedded_panda_has_frankas_limits_and_a_problem_file_can_set_others() {
    let panda = RobotModel::panda();
    let joint2 = &panda.motion_limits()[1];
    assert_eq!((joint2.velocity, joint2.acceleration, joint2.deceleration, joint2.jerk), (2.175, 7.5, 7.5, 3750.0));
    assert_eq!(joint2.sources[1], LimitSource::Builtin("franka_panda"));
    assert_eq!(joint2.sources[0], LimitSource::Builtin("franka_panda"));

    let dir = tempfile::tempdir().unwrap();
    let robots = dir.path().join("robots/panda");
    std::fs::create_dir_all(&robots).unwrap();
    std::fs::copy(common::repo().join("problems/robots/panda/panda.urdf"), robots.join("panda.urdf")).unwrap();
    let text = std::fs::read_to_string(common::repo().join("problems/panda_reach.toml")).unwrap();
    let limits = "joint_limits:\n  panda_joint1:\n    has_acceleration_limits: true\n    max_acceleration: 3.0\n";
    std::fs::write(dir.path().join("limits.yaml"), limits).unwrap();
    let shipped = "joint_limits = \"robots/panda/joint_limits.yaml\"";
    let with = text.replacen(shipped, "joint_limits = \"limits.yaml\"", 1);
    assert_ne!(with, text, "the shipped problem names the shipped limits");
    std::fs::write(dir.path().join("p.toml"), &with).unwrap();
    let problem = tandem::problem::Problem::from_file(dir.path().join("p.toml")).unwrap();
    let joint1 = &problem.robot.motion_limits()[0];
    assert_eq!((joint1.acceleration, joint1.deceleration), (3.0, 3.0));
    assert!(matches!(&joint1.sources[1], LimitSource::File(f) if f.ends_with("limits.yaml")), "{:?}", joint1.sources);
    // The URDF's velocity and tandem's defaults elsewhere (a Panda read
    // from a file is any robot until its limits are given).
    assert_eq!(joint1.sources[0], LimitSource::Urdf);
    assert_eq!(joint1.sources[3], LimitSource::Default);
    let shipped_problem =
        tandem::problem::Problem::from_file(common::repo().join("problems/panda_reach.toml")).unwrap();
    let builtin = tandem::problem::Problem::builtin("panda_reach").unwrap();
    for (a, b) in shipped_problem.robot.motion_limits().iter().zip(builtin.robot.motion_limits()) {
        assert_eq!((a.acceleration, a.jerk), (b.acceleration, b.jerk), "the file and the embedded problem agree");
    }

    let fr3 = text.replacen(shipped, "joint_limits = \"builtin:franka_fr3\"", 1);
    std::fs::write(dir.path().join("fr3.toml"), &fr3).unwrap();
    let problem = tandem::problem::Problem::from_file(dir.path().join("fr3.toml")).unwrap();
    assert!(problem.robot.motion_limits().iter().all(|l| l.jerk == 5000.0 && l.velocity_profile.is_some()));

    std::fs::write(dir.path().join("limits.yaml"), "joint_limits:\n  panda_joint1:\n    has_jerk_limits: true\n")
        .unwrap();
    let e = tandem::problem::Problem::from_file(dir.path().join("p.toml")).unwrap_err().to_string();
    assert!(e.contains("joint_limits") && e.contains("max_jerk") && e.contains("missing"), "{e}");
}
