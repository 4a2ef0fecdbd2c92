//! One LQR tracking-policy query for the Panda (7 joints, 301-waypoint
//! reference): closest-waypoint search, error state, gain, integration.
//! `tracking_query` walks along the reference as a control loop would;
//! `tracking_query_lost` jumps each time, forcing the global search.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use tandem::robot::RobotModel;
use tandem::trajectory::JointTrajectory;

fn policy() -> TrackingPolicy {
    let ready = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let goal = [0.6, -0.2, -0.3, -1.9, 0.2, 1.8, 0.4];
    let joints = RobotModel::panda().joint_names().to_vec();
    let reference = JointTrajectory::minimum_jerk(joints, &ready, &goal, 3.0, 0.01).expect("valid reference");
    TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::TimeVarying).expect("valid policy")
}

fn control(c: &mut Criterion) {
    let policy = policy();
    let r = policy.reference();
    // Queries slightly off the reference, in the order a control loop meets them.
    let queries: Vec<Vec<f64>> = (0..r.len()).map(|i| r.position(i).iter().map(|q| q + 0.01).collect()).collect();
    let velocity = vec![0.05; r.dof()];
    let mut command = vec![0.0; r.dof()];
    let mut group = c.benchmark_group("panda");
    let mut ws = policy.workspace();
    let mut i = 0;
    group.bench_function("tracking_query", |b| {
        b.iter(|| {
            i = (i + 1) % queries.len();
            let found =
                policy.query(&mut ws, black_box(&queries[i]), Some(&velocity), &mut command).expect("valid query");
            black_box((found, &command));
        })
    });
    group.bench_function("tracking_query_lost", |b| {
        b.iter(|| {
            i = (i + 97) % queries.len();
            let found =
                policy.query(&mut ws, black_box(&queries[i]), Some(&velocity), &mut command).expect("valid query");
            black_box((found, &command));
        })
    });
    group.finish();
}

criterion_group!(benches, control);
criterion_main!(benches);
