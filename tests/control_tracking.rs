//! LQR tracking policies: closed-loop convergence from perturbed starts,
//! the windowed closest-waypoint search, allocation-free queries, errors.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tandem::control::{
    ControlError, GainSchedule, JointTrajectory, MAX_TIME_STEP, MIN_TIME_STEP, TrackingPolicy, TrackingWeights,
    WEIGHT_RANGE,
};
use tandem::robot::RobotModel;

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
fn windowed_search_agrees_with_global_search() {
    let policy = TrackingPolicy::new(panda_reference(), TrackingWeights::default(), GainSchedule::Constant).unwrap();
    let reference = policy.reference();
    let mut ws = policy.workspace();
    let mut command = [0.0; 7];
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    for i in (0..reference.len()).step_by(3) {
        let q: Vec<f64> = reference.position(i).iter().map(|x| x + rng.random_range(-1e-3..1e-3)).collect();
        let windowed = policy.query(&mut ws, &q, None, &mut command).unwrap();
        let global = policy.query(&mut policy.workspace(), &q, None, &mut command).unwrap();
        assert_eq!(windowed.index, global.index, "at waypoint {i}");
    }
    // A jump far along the reference is found again (the hint is lost, then recovered).
    let far = reference.position(reference.len() - 1).to_vec();
    assert_eq!(policy.query(&mut ws, &far, None, &mut command).unwrap().index, reference.len() - 1);
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
        Err(ControlError::InvalidTimeStep { .. })
    ));
}

#[test]
fn references_load_from_csv() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ref.csv");
    std::fs::write(&path, "time, j1, j2\n0, 0, 0\n0.1, 0.1, -0.1\n0.2, 0.3, -0.2\n").unwrap();
    let r = JointTrajectory::from_csv(&path).unwrap();
    assert_eq!((r.len(), r.dof()), (3, 2));
    assert!((r.dt() - 0.1).abs() < 1e-15, "the time step is the spacing of the time column");
    assert!((r.velocity(1)[0] - 1.0).abs() < 1e-12 && r.velocity(0) == [0.0, 0.0]);
    assert!((r.acceleration(2)[0] - 10.0).abs() < 1e-9);
    std::fs::write(&path, "time,j1,j2\n0,0,0\n0.1,0.1,x\n").unwrap();
    let e = JointTrajectory::from_csv(&path).unwrap_err();
    assert!(e.to_string().contains("ref.csv:3") && e.to_string().contains("'x'"), "{e}");
    // A header-less file once turned its first row into joint names.
    std::fs::write(&path, "0,0,0\n0.1,0.1,0.1\n").unwrap();
    let e = JointTrajectory::from_csv(&path).unwrap_err().to_string();
    assert!(e.contains("ref.csv:1") && e.contains("is the header missing?"), "{e}");
    // Duplicate joint names were accepted.
    std::fs::write(&path, "time,j1,j1\n0,0,0\n0.1,0.1,0.1\n").unwrap();
    let e = JointTrajectory::from_csv(&path).unwrap_err().to_string();
    assert!(e.contains("joint 'j1' is named twice"), "{e}");
}

#[test]
fn references_refuse_sizes_and_values_they_cannot_hold() {
    let joints = || vec!["j1".to_string()];
    // --dt 1e-300 panicked (capacity overflow), 1e-9 aborted allocating 72 GB.
    for dt in [1e-300, 1e-9, 5e-5, 1.5, 1e6, f64::NAN] {
        let e = JointTrajectory::minimum_jerk(joints(), &[0.0], &[1.0], 3.0, dt).unwrap_err();
        assert!(matches!(e, ControlError::InvalidTimeStep { .. }), "{dt}: {e}");
    }
    let e = JointTrajectory::minimum_jerk(joints(), &[0.0], &[1.0], 1e6, 1e-4).unwrap_err();
    assert!(e.to_string().contains("more than 100001"), "{e}");
    // ±1e308 are finite, but their velocities are not: name the waypoint,
    // not "-inf is not finite".
    let e = JointTrajectory::new(joints(), 0.01, &[vec![1e308], vec![-1e308]]).unwrap_err().to_string();
    assert!(e.contains("waypoint 1: joint 'j1' moves from 100000000") && e.contains("too large"), "{e}");
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
    let e = JointTrajectory::new(joints, 0.01, &[vec![0.0; 65]]).unwrap_err();
    assert_eq!(e.to_string(), "the reference has 65 joints, more than 64");
}
