use super::*;
use crate::small::{cholesky_solve_in_place, dot};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random strictly convex QP: P = BᵀB + I, G random, h chosen so that a
/// random point is strictly feasible and some rows bind.
fn random_qp(n: usize, m: usize, rng: &mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let b: Vec<f64> = (0..n * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut p = vec![0.0; n * n];
    for c in 0..n {
        for r in 0..n {
            p[r + c * n] = (0..n).map(|k| b[k + r * n] * b[k + c * n]).sum::<f64>() + f64::from(r == c);
        }
    }
    let q: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
    let g: Vec<f64> = (0..m * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let h: Vec<f64> = (0..m).map(|_| rng.random_range(0.05..1.0)).collect();
    (p, q, g, h)
}

/// Stationarity, primal and dual feasibility, complementarity.
fn kkt_residual(data: &ConicData<'_>, x: &[f64], z: &[f64]) -> f64 {
    let n = data.variables();
    let mut worst = 0.0f64;
    for j in 0..n {
        let px: f64 = (0..n).map(|k| data.p[j + k * n] * x[k]).sum();
        let gz: f64 = (0..data.rows()).map(|i| data.g[i * n + j] * z[i]).sum();
        worst = worst.max((px + data.q[j] + gz).abs());
    }
    for (i, zi) in z.iter().enumerate().take(data.rows()) {
        let slack = data.h[i] - dot(&data.g[i * n..(i + 1) * n], x);
        worst = worst.max(-slack).max(-zi).max((slack * zi).abs());
    }
    worst
}

#[test]
fn random_qps_satisfy_kkt_conditions() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let settings = ConicSettings::default();
    let mut pool = ConicSolverPool::new(7, 32, None, &settings);
    for trial in 0..200 {
        let m = rng.random_range(0..=32);
        let (p, q, g, h) = random_qp(7, m, &mut rng);
        let data = ConicData { p: &p, q: &q, g: &g, h: &h, cone: None };
        let s = pool.solve(&data).unwrap_or_else(|e| panic!("trial {trial}: {e}"));
        let r = kkt_residual(&data, s.x, s.z);
        assert!(r < 1e-6, "trial {trial} (m = {m}): KKT residual {r}");
    }
}

#[test]
fn unconstrained_qp_matches_the_linear_solve() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut solver = ConicSolver::new(5, 4, None, &ConicSettings::default());
    for _ in 0..20 {
        let (p, q, _, _) = random_qp(5, 0, &mut rng);
        let data = ConicData { p: &p, q: &q, g: &[], h: &[], cone: None };
        let x = solver.solve(&data).unwrap().x.to_vec();
        let (mut f, mut want) = (p.clone(), q.iter().map(|v| -v).collect::<Vec<_>>());
        assert!(cholesky_solve_in_place(&mut f, 5, &mut want));
        let err = x.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-7, "error {err}");
    }
}

/// max gᵀu s.t. ‖L(u − a)‖ ≤ r has the closed form u = a + r W⁻¹g / √(gᵀW⁻¹g), W = LᵀL.
#[test]
fn trust_region_socp_matches_its_closed_form() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let n = 7;
    let mut solver = ConicSolver::new(n, 4, Some(n), &ConicSettings::default());
    for trial in 0..50 {
        // Upper-triangular L with a positive diagonal.
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            for j in i..n {
                l[i * n + j] = if i == j { rng.random_range(0.5..2.0) } else { rng.random_range(-0.5..0.5) };
            }
        }
        let a: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let g: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let r = rng.random_range(0.1..2.0);
        let mut la = vec![0.0; n];
        for i in 0..n {
            la[i] = dot(&l[i * n..(i + 1) * n], &a);
        }
        let neg_g: Vec<f64> = g.iter().map(|v| -v).collect();
        let data = ConicData {
            p: &vec![0.0; n * n],
            q: &neg_g,
            g: &[],
            h: &[],
            cone: Some(SecondOrderCone { l: &l, c: &la, radius: r }),
        };
        let x = solver.solve(&data).unwrap().x.to_vec();
        // W = LᵀL (row-major L: W[j,k] = Σ_i L[i,j] L[i,k]).
        let mut w = vec![0.0; n * n];
        for j in 0..n {
            for k in 0..n {
                w[j + k * n] = (0..n).map(|i| l[i * n + j] * l[i * n + k]).sum();
            }
        }
        let mut winv_g = g.clone();
        assert!(cholesky_solve_in_place(&mut w, n, &mut winv_g));
        let scale = r / dot(&g, &winv_g).sqrt();
        let err = (0..n).map(|i| (x[i] - (a[i] + scale * winv_g[i])).abs()).fold(0.0, f64::max);
        assert!(err < 1e-6, "trial {trial}: error {err}");
    }
}

#[test]
fn infeasible_and_mismatched_problems_are_reported() {
    let mut solver = ConicSolver::new(1, 2, None, &ConicSettings::default());
    // u ≤ −1 and −u ≤ −1 (u ≥ 1).
    let data = ConicData { p: &[1.0], q: &[0.0], g: &[1.0, -1.0], h: &[-1.0, -1.0], cone: None };
    assert_eq!(solver.solve(&data).unwrap_err(), ConicError::Infeasible);
    // The next solve works normally.
    let data = ConicData { p: &[1.0], q: &[-2.0], g: &[1.0], h: &[1.0], cone: None };
    assert!((solver.solve(&data).unwrap().x[0] - 1.0).abs() < 1e-7);
    let too_many = ConicData { p: &[1.0], q: &[0.0], g: &[1.0; 3], h: &[1.0; 3], cone: None };
    assert!(matches!(solver.solve(&too_many), Err(ConicError::Capacity { rows: 3, .. })));
    let nan = ConicData { p: &[f64::NAN], q: &[0.0], g: &[1.0], h: &[1.0], cone: None };
    assert!(solver.solve(&nan).is_err());
}

#[cfg(feature = "osqp")]
#[test]
fn osqp_and_clarabel_agree_on_random_qps() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let settings = ConicSettings { tolerance: 1e-9, ..ConicSettings::default() };
    let mut clarabel = ConicSolver::new(7, 24, None, &settings);
    let mut osqp = OsqpSolver::new(7, 24, &settings);
    for trial in 0..200 {
        let m = rng.random_range(0..=24);
        let (p, q, g, h) = random_qp(7, m, &mut rng);
        let data = ConicData { p: &p, q: &q, g: &g, h: &h, cone: None };
        let a = clarabel.solve(&data).unwrap().x.to_vec();
        let b = osqp.solve(&data).unwrap().x.to_vec();
        let err = a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-6, "trial {trial} (m = {m}): Clarabel and OSQP differ by {err}");
    }
}
