//! Banded Cholesky of trajectory-shaped normal equations: T slices of n
//! joints with order-2 coupling (half bandwidth 3n − 1), as the optimizer
//! factorises them every Gauss-Newton step.

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use tandem_solvers::banded::SymmetricBand;

fn trajectory_normal_equations(horizon: usize, n: usize) -> SymmetricBand {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let bandwidth = 3 * n - 1;
    let mut band = SymmetricBand::zeros(horizon * n, bandwidth);
    for t in 0..horizon.saturating_sub(2) {
        for _ in 0..n {
            let row: Vec<f64> = (0..3 * n).map(|_| rng.random_range(-1.0..1.0)).collect();
            band.add_outer(t * n, &row, 1.0);
        }
    }
    band.add_to_diagonal(1e-3);
    band
}

fn banded(c: &mut Criterion) {
    let mut group = c.benchmark_group("banded_cholesky");
    for horizon in [20, 50] {
        let original = trajectory_normal_equations(horizon, 7);
        let mut work = original.clone();
        let mut rhs = vec![1.0; horizon * 7];
        group.bench_function(format!("factorize_solve_T{horizon}_n7"), |b| {
            b.iter(|| {
                work.copy_from(&original);
                work.factorize().expect("positive definite");
                rhs.fill(1.0);
                work.solve_in_place(black_box(&mut rhs));
                black_box(rhs[0])
            })
        });
    }
    group.finish();
}

criterion_group!(benches, banded);
criterion_main!(benches);
