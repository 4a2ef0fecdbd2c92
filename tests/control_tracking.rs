//! LQR tracking policies: closed-loop convergence from perturbed starts,
//! the windowed closest-waypoint search, allocation-free queries, errors.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tandem::control::{
    ControlError, GainSchedule, MAX_TIME_STEP, MIN_TIME_STEP, PolicyQuery, TrackingPolicy, TrackingWeights,
    WEIGHT_RANGE,
};
use tandem::robot::RobotModel;
use tandem::trajectory::{JointTrajectory, TrajectoryError};

mod common;

#[global_allocator]
static GLOBAL: common::alloc::CountingAllocator = common::alloc::CountingAllocator;

const READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
const GOAL: [f64; 7] = [0.6, -0.2, -0.3, -1.9, 0.2, 1.8, 0.4];

fn panda_reference() -> JointTrajectory {
    let panda = RobotModel::panda();
    JointTrajectory::minimum_jerk(panda.joint_names().to_vec(), &READY, &GOAL, 3.0, 0.01).unwrap()
}

/// Simulates the kinematic arm `q ← q + v dt` under the policy; returns the
/// final configuration and the largest distance to the reference after the
/// first second.
fn rollout(policy: &TrackingPolicy, start: &[f64], steps: usize) -> (Vec<f64>, f64) {
    let dt = policy.reference().dt();
    let mut ws = policy.workspace();
    let (mut q, mut v) = (start.to_vec(), vec![0.0; start.len()]);
    let mut command = vec![0.0; start.len()];
    let mut late_error = 0.0f64;
    for step in 0..steps {
        let found = policy.query(&mut ws, &q, Some(&v), &mut command).unwrap();
        if step as f64 * dt > 1.0 {
            late_error = common::worst(late_error, found.distance);
        }
        v.copy_from_slice(&command);
        q.iter_mut().zip(&v).for_each(|(q, v)| *q += v * dt);
    }
    (q, late_error)
}

#[test]
fn perturbed_starts_converge_to_the_reference_and_reach_the_goal() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for schedule in [GainSchedule::Constant, GainSchedule::TimeVarying] {
        let policy = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), schedule).unwrap();
        let steps = policy.reference().len() + 200;
        for _ in 0..20 {
            let start: Vec<f64> = READY.iter().map(|q| q + rng.random_range(-0.15..0.15)).collect();
            let (end, late_error) = rollout(&policy, &start, steps);
            let miss = common::max_abs(end.iter().zip(GOAL).map(|(a, b)| a - b));
            assert!(miss < 1e-3, "{schedule:?}: ended {miss} rad from the goal");
            assert!(late_error < 0.05, "{schedule:?}: still {late_error} rad off the reference after 1 s");
        }
    }
}

#[test]
fn constant_gain_is_a_decoupled_pd_law() {
    let policy = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::Constant).unwrap();
    let k = policy.gain(0);
    assert_eq!((k.nrows(), k.ncols()), (7, 14));
    let (kp, kd) = (k[(0, 0)], k[(0, 7)]);
    assert!(kp > 0.0 && kd > 0.0);
    for j in 0..7 {
        for c in 0..14 {
            let expected = if c == j {
                kp
            } else if c == j + 7 {
                kd
            } else {
                0.0
            };
            assert!((k[(j, c)] - expected).abs() < 1e-9 * kp.max(1.0), "K[{j},{c}] = {}", k[(j, c)]);
        }
    }
    // Time-varying gains tend to the DARE gain far from the end of the horizon.
    let tv = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::TimeVarying).unwrap();
    assert!(common::max_abs((tv.gain(0) - k).iter().copied()) < 1e-6);
}

#[test]
fn progress_search_agrees_with_global_search() {
    let policy = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::Constant).unwrap();
    let reference = policy.reference();
    let mut ws = policy.workspace();
    let mut command = [0.0; 7];
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    for i in (0..reference.len()).step_by(3) {
        let q: Vec<f64> = reference.position(i).iter().map(|x| x + rng.random_range(-1e-3..1e-3)).collect();
        let windowed = policy.query(&mut ws, &q, None, &mut command).unwrap();
        let global = policy.query(&mut policy.workspace(), &q, None, &mut command).unwrap();
        // Near the ends of a minimum-jerk motion the waypoints lie closer
        // than the noise, so the points found may differ; their distances may not.
        assert!(
            windowed.distance <= global.distance * (1.0 + 1e-9) + 1e-15,
            "at waypoint {i}: {windowed:?} vs {global:?}"
        );
        assert!((windowed.progress - i as f64).abs() < 20.0, "at waypoint {i}: {windowed:?}");
    }
    // Moving on along the reference is followed to its end.
    let far = reference.position(reference.len() - 1).to_vec();
    assert_eq!(policy.query(&mut ws, &far, None, &mut command).unwrap().index, reference.len() - 1);
}

/// A reference through `points` (2-D), `dt` apart.
fn planar_reference(points: &[[f64; 2]], dt: f64) -> JointTrajectory {
    let waypoints: Vec<Vec<f64>> = points.iter().map(|p| p.to_vec()).collect();
    JointTrajectory::new(vec!["x".into(), "y".into()], dt, &waypoints).unwrap()
}

/// Rolls the policy out from `start`; asserts it ends within 1e-3 of the
/// goal and that progress never moved back by more than the backtrack bound
/// (0.2 rad of arc length) in one query nor jumped ahead by more than
/// `max_jump` waypoints.
fn assert_followed_in_order(policy: &TrackingPolicy, start: &[f64], max_jump: f64, what: &str) {
    let dt = policy.reference().dt();
    let mut ws = policy.workspace();
    let (mut q, mut v, mut command) = (start.to_vec(), vec![0.0; start.len()], vec![0.0; start.len()]);
    let mut last = None::<PolicyQuery>;
    for _ in 0..policy.reference().len() * 3 + 500 {
        let found = policy.query(&mut ws, &q, Some(&v), &mut command).unwrap();
        if let Some(prev) = last {
            assert!(
                found.arc_length >= prev.arc_length - 0.2 - 1e-9,
                "{what}: progress went back from {prev:?} to {found:?}"
            );
            assert!(found.progress <= prev.progress + max_jump, "{what}: progress jumped from {prev:?} to {found:?}");
        }
        last = Some(found);
        v.copy_from_slice(&command);
        q.iter_mut().zip(&v).for_each(|(q, v)| *q += v * dt);
    }
    let goal = policy.reference().goal();
    let miss = q.iter().zip(goal).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(miss < 1e-3, "{what}: ended {miss} from the goal");
}

#[test]
fn a_reference_that_turns_back_is_followed_to_its_goal() {
    // 0 → 1 → −1 rad on one joint (the other still), as in the issue.
    let mut points = vec![];
    for i in 0..=100 {
        points.push([i as f64 / 100.0, 0.0]);
    }
    for i in 1..=200 {
        points.push([1.0 - i as f64 / 100.0, 0.0]);
    }
    let policy =
        TrackingPolicy::new(planar_reference(&points, 0.01), TrackingWeights::default(), GainSchedule::Constant)
            .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for k in 0..20 {
        let start = [rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1)];
        assert_followed_in_order(&policy, &start, 5.0, &format!("reversing reference, start {k}"));
    }
}

#[test]
fn a_loop_and_a_figure_eight_are_followed_in_order() {
    // A circle run 1.5 times (it passes its start again) and a figure-eight
    // (Gerono lemniscate) of 701 waypoints that starts at its crossing point.
    let circle: Vec<[f64; 2]> =
        (0..=450).map(|i| (i as f64 / 300.0) * std::f64::consts::TAU).map(|a| [a.cos() - 1.0, a.sin()]).collect();
    let eight: Vec<[f64; 2]> =
        (0..=700).map(|i| (i as f64 / 700.0) * std::f64::consts::TAU).map(|a| [a.sin(), a.sin() * a.cos()]).collect();
    for (name, points) in [("circle", circle), ("figure-eight", eight)] {
        let policy =
            TrackingPolicy::new(planar_reference(&points, 0.01), TrackingWeights::default(), GainSchedule::Constant)
                .unwrap();
        // The first query at the start finds the start, not a later pass.
        let found = policy.query(&mut policy.workspace(), &points[0], None, &mut [0.0; 2]).unwrap();
        assert_eq!(found.index, 0, "{name}: the first query found waypoint {}", found.index);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for k in 0..10 {
            let start = [points[0][0] + rng.random_range(-0.05..0.05), points[0][1] + rng.random_range(-0.05..0.05)];
            assert_followed_in_order(&policy, &start, 8.0, &format!("{name}, start {k}"));
        }
    }
}

#[test]
fn the_command_varies_continuously_between_waypoints() {
    // Off a straight reference, moving along it changes the tracked point
    // smoothly: no jump where the nearest waypoint changes.
    let points: Vec<[f64; 2]> = (0..=20).map(|i| [0.1 * i as f64, 0.0]).collect();
    let policy =
        TrackingPolicy::new(planar_reference(&points, 0.1), TrackingWeights::default(), GainSchedule::TimeVarying)
            .unwrap();
    let mut ws = policy.workspace();
    let mut prev = None::<[f64; 2]>;
    for i in 0..=400 {
        let q = [0.5 + 0.0025 * i as f64, 0.05];
        let mut c = [0.0; 2];
        policy.query(&mut ws, &q, None, &mut c).unwrap();
        if let Some(p) = prev {
            let jump = (c[0] - p[0]).abs().max((c[1] - p[1]).abs());
            assert!(jump < 0.05, "the command jumped by {jump} at x = {}", q[0]);
        }
        prev = Some(c);
    }
}

#[test]
fn queries_do_not_allocate() {
    let policy = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::TimeVarying).unwrap();
    let mut ws = policy.workspace();
    let mut command = [0.0; 7];
    let v = [0.01; 7];
    let before = common::alloc::allocations();
    for i in 0..policy.reference().len() {
        policy.query(&mut ws, policy.reference().position(i), Some(&v), &mut command).unwrap();
    }
    assert_eq!(common::alloc::allocations() - before, 0);
}

#[test]
fn bad_queries_and_references_are_errors() {
    let policy = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::Constant).unwrap();
    let mut ws = policy.workspace();
    let mut command = [7.0; 7];
    let mut q = READY;
    q[2] = f64::NAN;
    let e = policy.query(&mut ws, &q, None, &mut command).unwrap_err();
    assert!(matches!(e, ControlError::NonFinite { what: "q", index: 2, .. }), "{e}");
    assert_eq!(command, [7.0; 7], "a failed query leaves the command untouched");
    assert!(matches!(policy.query(&mut ws, &READY[..6], None, &mut command), Err(ControlError::WrongLength { .. })));
    let weights = TrackingWeights { control: 0.0, ..TrackingWeights::default() };
    let e = TrackingPolicy::new(panda_reference(), weights, GainSchedule::Constant).unwrap_err();
    // Named, not a raw struct (`TrackingWeights { position: 100.0, … }` before).
    assert_eq!(e.to_string(), "the control weight is 0, outside [0.0001, 10000]");
    let e = JointTrajectory::new(vec!["a".into()], 0.01, &[vec![0.0], vec![f64::INFINITY]]).unwrap_err();
    assert!(e.to_string().contains("waypoint 1"), "{e}");
    assert!(matches!(
        JointTrajectory::new(vec!["a".into()], -1.0, &[vec![0.0]]),
        Err(TrajectoryError::InvalidTimeStep { .. })
    ));
    // A trajectory may be minutes apart; a tracking policy's reference may not.
    let coarse = JointTrajectory::new(vec!["a".into()], 2.0, &[vec![0.0], vec![1.0]]).unwrap();
    assert!(matches!(
        TrackingPolicy::new(coarse, TrackingWeights::default(), GainSchedule::Constant),
        Err(ControlError::InvalidTimeStep { .. })
    ));
}

#[test]
fn references_load_from_csv() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ref.csv");
    std::fs::write(&path, "time, j1, j2\n0, 0, 0\n0.1, 0.1, -0.1\n0.2, 0.3, -0.2\n").unwrap();
    let r = JointTrajectory::read_csv(&path).unwrap();
    assert_eq!((r.len(), r.dof()), (3, 2));
    assert!((r.dt() - 0.1).abs() < 1e-15, "the time step is the spacing of the time column");
    assert!((r.velocity(1)[0] - 1.0).abs() < 1e-12 && r.velocity(0) == [0.0, 0.0]);
    assert!((r.acceleration(2)[0] - 10.0).abs() < 1e-9);
    std::fs::write(&path, "time,j1,j2\n0,0,0\n0.1,0.1,x\n").unwrap();
    let e = JointTrajectory::read_csv(&path).unwrap_err();
    assert!(e.to_string().contains("ref.csv:3") && e.to_string().contains("'x'"), "{e}");
    // A header-less file once turned its first row into joint names.
    std::fs::write(&path, "0,0,0\n0.1,0.1,0.1\n").unwrap();
    let e = JointTrajectory::read_csv(&path).unwrap_err().to_string();
    assert!(e.contains("ref.csv:1") && e.contains("is the header missing?"), "{e}");
    // Duplicate joint names were accepted.
    std::fs::write(&path, "time,j1,j1\n0,0,0\n0.1,0.1,0.1\n").unwrap();
    let e = JointTrajectory::read_csv(&path).unwrap_err().to_string();
    assert!(e.contains("joint 'j1' is named twice"), "{e}");
}

#[test]
fn references_refuse_sizes_and_values_they_cannot_hold() {
    let joints = || vec!["j1".to_string()];
    // --dt 1e-300 panicked (capacity overflow), 1e-9 aborted allocating 72 GB.
    for dt in [1e-300, 1e-9, 1e-5] {
        let e = JointTrajectory::minimum_jerk(joints(), &[0.0], &[1.0], 3.0, dt).unwrap_err();
        assert!(matches!(e, TrajectoryError::TooManyWaypoints { .. }), "{dt}: {e}");
    }
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = JointTrajectory::minimum_jerk(joints(), &[0.0], &[1.0], 3.0, dt).unwrap_err();
        assert!(matches!(e, TrajectoryError::InvalidTimeStep { .. }), "{dt}: {e}");
    }
    // Time steps a trajectory may have but a tracking policy may not.
    for dt in [5e-5, 1.5, 1e6] {
        let reference = JointTrajectory::minimum_jerk(joints(), &[0.0], &[1.0], 2.0 * dt, dt).unwrap();
        let e = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant).unwrap_err();
        assert!(matches!(e, ControlError::InvalidTimeStep { .. }), "{dt}: {e}");
    }
    let e = JointTrajectory::minimum_jerk(joints(), &[0.0], &[1.0], 1e6, 1e-4).unwrap_err();
    assert!(e.to_string().contains("more than 100001"), "{e}");
    // ±1e308 are finite, but their velocities are not: name the waypoint,
    // not "-inf is not finite".
    let e = JointTrajectory::new(joints(), 0.01, &[vec![1e308], vec![-1e308]]).unwrap_err().to_string();
    assert!(
        e.contains("waypoint 1: joint 'j1' moves from 1e308 to -1e308 in 0.01 s") && e.contains("too large"),
        "{e}"
    );
}

#[test]
fn every_corner_of_the_weight_and_time_step_ranges_solves() {
    // Errors were misleading outside them ("not stabilisable" for dt = 1e6,
    // "Q is not positive semidefinite" for a position weight of 1e300).
    let (lo, hi) = (*WEIGHT_RANGE.start(), *WEIGHT_RANGE.end());
    for dt in [MIN_TIME_STEP, 0.01, MAX_TIME_STEP] {
        let joints = vec!["a".to_string(), "b".to_string()];
        let reference = JointTrajectory::minimum_jerk(joints, &[0.0, 0.0], &[0.5, -0.5], 4.0 * dt, dt).unwrap();
        for position in [lo, hi] {
            for velocity in [lo, hi] {
                for control in [lo, hi] {
                    let w = TrackingWeights { position, velocity, control };
                    for schedule in [GainSchedule::Constant, GainSchedule::TimeVarying] {
                        let policy = TrackingPolicy::new(reference.clone(), w, schedule);
                        let policy = policy.unwrap_or_else(|e| panic!("dt {dt}, {w:?}, {schedule:?}: {e}"));
                        assert!(policy.gain(0).iter().all(|k| k.is_finite()), "dt {dt}, {w:?}");
                    }
                }
            }
        }
    }
    let outside = TrackingWeights { position: 1e300, ..TrackingWeights::default() };
    let e = TrackingPolicy::new(panda_reference(), outside, GainSchedule::Constant).unwrap_err().to_string();
    assert!(e.contains("position weight is 1e300"), "{e}");
}

#[test]
fn a_workspace_from_another_policy_still_works() {
    let long = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::Constant).unwrap();
    let joints = vec!["a".to_string(), "b".to_string()];
    let short_ref = JointTrajectory::minimum_jerk(joints, &[0.0, 0.0], &[0.1, 0.1], 0.1, 0.01).unwrap();
    let short = TrackingPolicy::new(short_ref, TrackingWeights::default(), GainSchedule::Constant).unwrap();
    let mut ws = long.workspace();
    let mut command = [0.0; 7];
    long.query(&mut ws, long.reference().goal(), None, &mut command).unwrap();
    let mut small = [0.0; 2];
    let found = short.query(&mut ws, &[0.05, 0.05], None, &mut small).unwrap();
    assert!(found.index < short.reference().len());
}

#[test]
fn references_bound_their_joints() {
    let joints: Vec<String> = (0..65).map(|k| format!("j{k}")).collect();
    let reference = JointTrajectory::new(joints, 0.01, &[vec![0.0; 65]]).unwrap();
    let e = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant).unwrap_err();
    assert_eq!(e.to_string(), "the reference has 65 joints, more than 64");
    let joints: Vec<String> = (0..1025).map(|k| format!("j{k}")).collect();
    let e = JointTrajectory::new(joints, 0.01, &[vec![0.0; 1025]]).unwrap_err();
    assert_eq!(e.to_string(), "the reference has 1025 joints, more than 1024");
}
