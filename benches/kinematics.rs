//! Kinematics speed of the embedded Panda (7 active joints, fingers held).
//!
//! `fk_all_frames`: body poses and all 33 frame placements;
//! `fk_joints`: body poses only; `fk_frame_jacobian`: body poses, then the
//! pose and world-aligned 6×7 Jacobian of `panda_hand`. Each iteration uses
//! the next of 1000 seeded random configurations. Compare with
//! `benches/peers/run_pinocchio.sh` (same operations in Pinocchio's C++).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Matrix6xX;
use std::hint::black_box;
use tandem::robot::{KinematicsWorkspace, ReferenceFrame, RobotModel};

/// Deterministic configurations within limits (a 64-bit LCG: benches need
/// no statistical quality, only variety and repeatability).
fn configurations(model: &RobotModel, count: usize) -> Vec<Vec<f64>> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count).map(|_| model.limits().iter().map(|l| l.lower + (l.upper - l.lower) * next()).collect()).collect()
}

fn kinematics(c: &mut Criterion) {
    let panda = RobotModel::panda();
    let configs = configurations(&panda, 1000);
    let mut ws = KinematicsWorkspace::new(&panda);
    let hand = panda.frame_id("panda_hand").expect("panda_hand exists");
    let mut jac = Matrix6xX::zeros(panda.nq());
    let mut group = c.benchmark_group("panda");
    let mut i = 0;
    group.bench_function("fk_all_frames", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            panda.forward_kinematics(&mut ws, black_box(&configs[i])).expect("valid q");
            panda.update_frame_placements(&mut ws);
            black_box(&ws);
        })
    });
    group.bench_function("fk_joints", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            panda.forward_kinematics(&mut ws, black_box(&configs[i])).expect("valid q");
            black_box(&ws);
        })
    });
    group.bench_function("fk_frame_jacobian", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            panda.forward_kinematics(&mut ws, black_box(&configs[i])).expect("valid q");
            let pose = panda.frame_jacobian(&ws, hand, ReferenceFrame::WorldAligned, &mut jac).expect("7 columns");
            black_box((pose, &jac));
        })
    });
    group.finish();
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
