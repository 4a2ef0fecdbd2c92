//! Unit tests of the DARE and the finite-horizon recursion: closed forms,
//! structural identities and every error path.

use super::*;
use nalgebra::{DMatrix, Matrix2, Vector2, dmatrix};

fn settings() -> DareSettings {
    DareSettings::default()
}

/// Positive root of `b²p² + (r(1 − a²) − qb²)p − qr = 0`, the scalar DARE.
fn scalar_p(a: f64, b: f64, q: f64, r: f64) -> f64 {
    let lin = r * (1.0 - a * a) - q * b * b;
    (-lin + (lin * lin + 4.0 * b * b * q * r).sqrt()) / (2.0 * b * b)
}

fn double_integrator(dt: f64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    (dmatrix![1.0, dt; 0.0, 1.0], dmatrix![0.5 * dt * dt; dt], dmatrix![10.0, 0.0; 0.0, 1.0], dmatrix![0.1])
}

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm().max(f64::MIN_POSITIVE)
}

#[test]
fn scalar_matches_closed_form() {
    for (a, b, q, r) in [(0.5, 1.0, 1.0, 1.0), (2.0, 1.0, 1.0, 1.0), (1.0, 0.3, 2.0, 0.5), (-3.0, 2.0, 0.1, 7.0)] {
        let (am, bm, qm, rm) = (dmatrix![a], dmatrix![b], dmatrix![q], dmatrix![r]);
        let sol = solve_dare(&DareProblem::new(&am, &bm, &qm, &rm), &settings()).expect("solvable");
        let p = scalar_p(a, b, q, r);
        assert!((sol.p[(0, 0)] - p).abs() < 1e-12 * p, "a={a}: {} vs {p}", sol.p[(0, 0)]);
        let k = b * p * a / (r + b * b * p);
        assert!((sol.k[(0, 0)] - k).abs() < 1e-12 * k.abs().max(1.0));
        // The scalar closed loop a − bk is its own spectral radius; the bound is tight here.
        let rho = (a - b * k).abs();
        assert!(sol.closed_loop_spectral_radius >= rho * (1.0 - 1e-9), "{rho}");
        assert!(sol.closed_loop_spectral_radius <= rho * (1.0 + 1e-9) + 1e-300);
        assert!(sol.residual < 1e-14);
    }
}

#[test]
fn double_integrator_is_stabilised_and_matches_value_iteration() {
    let (a, b, q, r) = double_integrator(0.05);
    let sol = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).expect("solvable");
    assert!(sol.residual < 1e-13, "{}", sol.residual);
    assert!(sol.closed_loop_spectral_radius < 1.0);
    assert!(sol.p.clone().cholesky().is_some(), "P positive definite");
    // The exact spectral radius of the 2×2 closed loop, for the bound.
    let cl = &a - &b * &sol.k;
    let (tr, det) = (cl.trace(), cl.determinant());
    let disc = tr * tr - 4.0 * det;
    let rho = if disc < 0.0 { det.sqrt() } else { (tr.abs() + disc.sqrt()) / 2.0 };
    assert!(sol.closed_loop_spectral_radius >= rho - 1e-12);
    assert!(sol.closed_loop_spectral_radius < rho * 1.05, "{} vs {rho}", sol.closed_loop_spectral_radius);
    let fh = finite_horizon_riccati(&LinearDynamics::constant(&a, &b), &q, &r, &q, 5000).expect("finite horizon");
    assert!(rel(&fh.cost_to_go[0], &sol.p) < 1e-10);
    assert!(rel(&fh.gains[0], &sol.k) < 1e-10);
}

#[test]
fn fixed_size_inputs_are_accepted() {
    let a = Matrix2::new(1.0, 0.1, 0.0, 1.0);
    let b = Vector2::new(0.005, 0.1);
    let (q, r) = (Matrix2::<f64>::identity(), nalgebra::Matrix1::new(1.0));
    let sol = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).expect("solvable");
    assert_eq!(sol.k.shape(), (1, 2));
}

#[test]
fn cross_term_equals_substitution() {
    let (a, b, q, r) = double_integrator(0.1);
    let n = dmatrix![0.3; -0.2];
    let with_n = solve_dare(&DareProblem::new(&a, &b, &q, &r).with_cross_term(&n), &settings()).expect("solvable");
    let r_inv_nt = r.clone().cholesky().expect("R PD").solve(&n.transpose());
    let (a_hat, q_hat) = (&a - &b * &r_inv_nt, &q - &n * &r_inv_nt);
    let sub = solve_dare(&DareProblem::new(&a_hat, &b, &q_hat, &r), &settings()).expect("solvable");
    assert!(rel(&with_n.p, &sub.p) < 1e-12);
    // u = −K̂x minimises the substituted cost in terms of û = u + R⁻¹Nᵀx.
    assert!(rel(&with_n.k, &(&sub.k + &r_inv_nt)) < 1e-12);
    assert!(with_n.residual < 1e-13);
}

#[test]
fn dead_beat_and_zero_weight() {
    // A = 0: P = Q, K = 0 and a nilpotent closed loop.
    let (z, b, q, r) = (DMatrix::zeros(2, 2), dmatrix![1.0; 0.0], DMatrix::identity(2, 2), dmatrix![1.0]);
    let sol = solve_dare(&DareProblem::new(&z, &b, &q, &r), &settings()).expect("solvable");
    assert_eq!(sol.p, q);
    assert_eq!(sol.closed_loop_spectral_radius, 0.0);
    // Q = 0 with a stable A: P = 0, K = 0.
    let a = dmatrix![0.5, 0.1; 0.0, 0.2];
    let sol = solve_dare(&DareProblem::new(&a, &b, &z, &r), &settings()).expect("solvable");
    assert_eq!(sol.p.norm(), 0.0);
    assert!((sol.closed_loop_spectral_radius - 0.5).abs() < 0.05);
}

#[test]
fn forced_refinement_keeps_the_answer() {
    let (a, b, q, r) = double_integrator(0.01);
    let plain = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).expect("solvable");
    let forced = DareSettings { refinement_threshold: 0.0, ..settings() };
    let refined = solve_dare(&DareProblem::new(&a, &b, &q, &r), &forced).expect("solvable");
    assert!(refined.refinement_steps >= 1);
    assert!(rel(&refined.p, &plain.p) < 1e-12);
    assert!(refined.residual <= plain.residual);
}

#[test]
fn workspace_reuse_is_exact_and_resizes() {
    let (a, b, q, r) = double_integrator(0.1);
    let mut ws = DareWorkspace::new(2, 1);
    let first = ws.solve(&DareProblem::new(&a, &b, &q, &r), &settings()).expect("solvable");
    let (p1, k1) = (ws.p().clone(), ws.k().clone());
    // A failing solve in between must not poison the workspace.
    let bad = dmatrix![f64::NAN, 0.0; 0.0, 1.0];
    assert!(ws.solve(&DareProblem::new(&bad, &b, &q, &r), &settings()).is_err());
    let second = ws.solve(&DareProblem::new(&a, &b, &q, &r), &settings()).expect("solvable");
    assert_eq!((first, &p1, &k1), (second, ws.p(), ws.k()));
    let (a3, b3, q3, r3) =
        (DMatrix::identity(3, 3) * 0.9, DMatrix::identity(3, 2), DMatrix::identity(3, 3), DMatrix::identity(2, 2));
    ws.solve(&DareProblem::new(&a3, &b3, &q3, &r3), &settings()).expect("resized solve");
    assert_eq!(ws.p().shape(), (3, 3));
}

#[test]
fn uncontrollable_penalised_unstable_mode_is_not_stabilisable() {
    let (a, b, q, r) = (dmatrix![2.0, 0.0; 0.0, 0.5], dmatrix![0.0; 1.0], DMatrix::identity(2, 2), dmatrix![1.0]);
    let err = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).unwrap_err();
    assert!(matches!(err, RiccatiError::NotStabilisable { .. }), "{err}");
    // A marginal uncontrollable mode: the iterate grows linearly, never converges.
    let a = dmatrix![1.0, 0.0; 0.0, 0.5];
    let err = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).unwrap_err();
    assert!(matches!(err, RiccatiError::NotStabilisable { .. }), "{err}");
}

#[test]
fn unpenalised_unstable_mode_is_not_detectable() {
    let (b, q, r) = (dmatrix![1.0], dmatrix![0.0], dmatrix![1.0]);
    for a in [2.0, 1.0, -1.0] {
        let a = dmatrix![a];
        let err = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).unwrap_err();
        let RiccatiError::NotDetectable { spectral_radius } = err else { panic!("a = {a}: {err}") };
        assert!(spectral_radius >= 1.0);
    }
}

#[test]
fn non_finite_input_is_named() {
    let (mut a, b, q, r) = double_integrator(0.1);
    a[(1, 0)] = f64::NAN;
    let err = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).unwrap_err();
    assert!(matches!(err, RiccatiError::NonFinite { matrix: "A", row: 1, col: 0, .. }), "{err}");
    let (a, b, q, mut r) = double_integrator(0.1);
    r[(0, 0)] = f64::INFINITY;
    let err = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).unwrap_err();
    assert!(matches!(err, RiccatiError::NonFinite { matrix: "R", .. }), "{err}");
}

#[test]
fn malformed_weights_and_shapes_are_rejected() {
    let (a, b, q, r) = double_integrator(0.1);
    let run = |a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>| {
        solve_dare(&DareProblem::new(a, b, q, r), &settings()).unwrap_err()
    };
    let err = run(&a, &DMatrix::zeros(3, 1), &q, &r);
    assert!(matches!(err, RiccatiError::DimensionMismatch { matrix: "B", expected: (2, 1), found: (3, 1) }));
    let err = run(&a, &b, &dmatrix![1.0, 0.5; 0.0, 1.0], &r);
    assert!(matches!(err, RiccatiError::NotSymmetric { matrix: "Q", .. }), "{err}");
    let err = run(&a, &b, &dmatrix![1.0, 0.0; 0.0, -1e-3], &r);
    assert_eq!(err, RiccatiError::NotPositiveSemidefinite { matrix: "Q" });
    assert_eq!(run(&a, &b, &q, &dmatrix![0.0]), RiccatiError::NotPositiveDefinite { matrix: "R" });
    assert_eq!(
        run(&a, &DMatrix::zeros(2, 0), &q, &DMatrix::zeros(0, 0)),
        RiccatiError::EmptyDimension { dimension: "input" }
    );
    // [[Q, N], [Nᵀ, R]] indefinite although Q and R are definite.
    let n = dmatrix![5.0; 0.0];
    let err = solve_dare(&DareProblem::new(&a, &b, &q, &r).with_cross_term(&n), &settings()).unwrap_err();
    assert_eq!(err, RiccatiError::NotPositiveSemidefinite { matrix: "Q - N R⁻¹ Nᵀ" });
}

#[test]
fn impossible_residual_tolerance_reports_ill_conditioning() {
    let (a, b, q, r) = double_integrator(0.01);
    let strict = DareSettings { residual_tolerance: 1e-300, ..settings() };
    let err = solve_dare(&DareProblem::new(&a, &b, &q, &r), &strict).unwrap_err();
    assert!(matches!(err, RiccatiError::IllConditioned { .. }), "{err}");
}

#[test]
fn finite_horizon_converges_to_the_dare_gain() {
    let a = dmatrix![1.1, 0.2, 0.0; 0.0, 0.9, 0.3; 0.1, 0.0, 1.05];
    let b = dmatrix![0.0, 1.0; 1.0, 0.0; 0.5, 0.5];
    let (q, r) = (DMatrix::identity(3, 3), dmatrix![1.0, 0.1; 0.1, 2.0]);
    let dare = solve_dare(&DareProblem::new(&a, &b, &q, &r), &settings()).expect("solvable");
    let fh = finite_horizon_riccati(&LinearDynamics::constant(&a, &b), &q, &r, &DMatrix::zeros(3, 3), 400)
        .expect("finite horizon");
    assert_eq!((fh.gains.len(), fh.cost_to_go.len()), (400, 401));
    assert!(rel(&fh.gains[0], &dare.k) < 1e-10);
    assert!(rel(&fh.cost_to_go[0], &dare.p) < 1e-10);
    // The last step only sees Qf = 0: no reason to act.
    assert_eq!(fh.gains[399].norm(), 0.0);
}

#[test]
fn finite_horizon_time_varying_matches_constant_and_checks_steps() {
    let (a, b, q, r) = double_integrator(0.1);
    let constant = finite_horizon_riccati(&LinearDynamics::constant(&a, &b), &q, &r, &q, 20).expect("ok");
    let (a_seq, b_seq) = (vec![a.clone(); 20], vec![b.clone(); 20]);
    let varying = finite_horizon_riccati(&LinearDynamics::time_varying(&a_seq, &b_seq), &q, &r, &q, 20).expect("ok");
    assert_eq!(constant, varying);
    let err = finite_horizon_riccati(&LinearDynamics::time_varying(&a_seq[..5], &b_seq), &q, &r, &q, 20).unwrap_err();
    assert_eq!(err, RiccatiError::HorizonMismatch { a_len: 5, b_len: 20, horizon: 20 });
    let mut bad = b_seq.clone();
    bad[7] = DMatrix::zeros(2, 2);
    let err = finite_horizon_riccati(&LinearDynamics::time_varying(&a_seq, &bad), &q, &r, &q, 20).unwrap_err();
    let RiccatiError::AtStep { step: 7, source } = err else { panic!("{err}") };
    assert!(matches!(*source, RiccatiError::DimensionMismatch { matrix: "B", .. }));
    let err = finite_horizon_riccati(&LinearDynamics::constant(&a, &b), &q, &dmatrix![-1.0], &q, 3).unwrap_err();
    assert_eq!(err, RiccatiError::NotPositiveDefinite { matrix: "R" });
}

/// Seven joints, x = [q, q̇], dt = 0.01 s, per-joint weights (the Panda's case when uniform).
fn joints(position: &[f64], control: f64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let j = position.len();
    let (a, b) = super::double_integrator(j, 0.01);
    let q = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(2 * j, |k, _| if k < j { position[k] } else { 1.0 }));
    (a, b, q, DMatrix::identity(j, j) * control)
}

fn dense_settings() -> DareSettings {
    DareSettings { decouple: false, ..settings() }
}

#[test]
fn decoupled_groups_match_the_dense_solve() {
    let uniform = joints(&[100.0; 7], 0.1);
    let distinct = joints(&[100.0, 50.0, 100.0, 20.0, 7.0, 100.0, 1.0], 0.1);
    for (a, b, q, r) in [uniform, distinct] {
        let problem = DareProblem::new(&a, &b, &q, &r);
        let dense = solve_dare(&problem, &dense_settings()).expect("solvable");
        let split = solve_dare(&problem, &settings()).expect("solvable");
        assert!(rel(&split.p, &dense.p) < 1e-12 && rel(&split.k, &dense.k) < 1e-12);
        assert!(split.residual < 1e-13, "{}", split.residual);
        assert!((split.closed_loop_spectral_radius - dense.closed_loop_spectral_radius).abs() < 0.01);
        // Off-block entries are exactly zero.
        assert_eq!(split.p[(0, 1)], 0.0);
        assert_eq!(split.k[(0, 1)], 0.0);
    }
    // Groups interleaved by a permutation, with a cross term and a coupled R
    // block: two groups {x0, x2; u1} and {x1, x3; u0, u2}.
    let a = dmatrix![1.0, 0.0, 0.1, 0.0; 0.0, 0.9, 0.0, 0.2; 0.3, 0.0, 1.1, 0.0; 0.0, 0.1, 0.0, 1.2];
    let b = dmatrix![0.0, 1.0, 0.0; 0.5, 0.0, 0.0; 0.0, 0.2, 0.0; 0.0, 0.0, 1.0];
    let q = dmatrix![2.0, 0.0, 0.5, 0.0; 0.0, 1.0, 0.0, 0.0; 0.5, 0.0, 1.0, 0.0; 0.0, 0.0, 0.0, 3.0];
    let r = dmatrix![1.0, 0.0, 0.3; 0.0, 2.0, 0.0; 0.3, 0.0, 1.0];
    let n = dmatrix![0.0, 0.1, 0.0; 0.05, 0.0, 0.0; 0.0, 0.0, 0.0; 0.0, 0.0, 0.1];
    let problem = DareProblem::new(&a, &b, &q, &r).with_cross_term(&n);
    let dense = solve_dare(&problem, &dense_settings()).expect("solvable");
    let split = solve_dare(&problem, &settings()).expect("solvable");
    assert!(rel(&split.p, &dense.p) < 1e-12 && rel(&split.k, &dense.k) < 1e-12);
    assert!(split.residual < 1e-13);
    // A group that cannot be stabilised fails the whole solve, as densely.
    // (x1 unstable, driven by nothing: x3 no longer acts on it, u0 no longer on x1.)
    let mut bad = a.clone();
    bad[(1, 1)] = 2.0;
    bad[(1, 3)] = 0.0;
    let b_bad = dmatrix![0.0, 1.0, 0.0; 0.0, 0.0, 0.0; 0.0, 0.2, 0.0; 0.0, 0.0, 1.0];
    let err = solve_dare(&DareProblem::new(&bad, &b_bad, &q, &r), &settings()).unwrap_err();
    assert!(matches!(err, RiccatiError::NotStabilisable { .. }), "{err}");
}

#[test]
fn warm_start_equals_the_cold_solve() {
    for decouple in [true, false] {
        let s = DareSettings { decouple, ..settings() };
        let (a, b, q, r) = joints(&[100.0; 7], 0.1);
        let (a2, b2, q2, r2) = joints(&[101.0, 100.0, 99.5, 100.0, 100.0, 100.5, 100.0], 0.101);
        let nearby = solve_dare(&DareProblem::new(&a2, &b2, &q2, &r2), &s).expect("solvable");
        let problem = DareProblem::new(&a, &b, &q, &r);
        let cold = solve_dare(&problem, &s).expect("solvable");
        let mut ws = DareWorkspace::new(14, 7);
        let stats = ws.solve_warm(&problem, &s, &nearby.p).expect("solvable");
        assert_eq!(stats.iterations, 0, "decouple = {decouple}: Newton alone converged");
        assert!((1..=4).contains(&stats.refinement_steps), "{}", stats.refinement_steps);
        assert!(rel(ws.p(), &cold.p) < 1e-10 && rel(ws.k(), &cold.k) < 1e-10);
        assert!(stats.residual <= s.refinement_threshold && stats.closed_loop_spectral_radius < 1.0);
        // From the answer itself: no step at all.
        let again = ws.solve_warm(&problem, &s, &cold.p).expect("solvable");
        assert_eq!((again.iterations, again.refinement_steps), (0, 0));
    }
}

#[test]
fn warm_start_from_a_bad_guess_is_still_right_or_an_error() {
    // Scalar a = 2: the DARE's other root is negative and anti-stabilising.
    let (a, b, q, r) = (dmatrix![2.0], dmatrix![1.0], dmatrix![1.0], dmatrix![1.0]);
    let problem = DareProblem::new(&a, &b, &q, &r);
    let p = scalar_p(2.0, 1.0, 1.0, 1.0);
    // The roots of p² − 4p − 1 (b²p² + (r(1 − a²) − qb²)p − qr) sum to 4.
    let other = dmatrix![4.0 - p];
    assert!((other[(0, 0)].powi(2) - 4.0 * other[(0, 0)] - 1.0).abs() < 1e-12);
    let mut ws = DareWorkspace::new(1, 1);
    for guess in [other, dmatrix![0.0], dmatrix![-50.0], dmatrix![1e12]] {
        ws.solve_warm(&problem, &settings(), &guess).expect("solvable");
        assert!((ws.p()[(0, 0)] - p).abs() < 1e-10 * p, "from {guess}: {}", ws.p());
    }
    // A non-stabilising P for the Panda (zero: K = 0, the double integrator is marginal).
    let (a, b, q, r) = joints(&[100.0; 7], 0.1);
    let problem = DareProblem::new(&a, &b, &q, &r);
    let cold = solve_dare(&problem, &settings()).expect("solvable");
    for decouple in [true, false] {
        let s = DareSettings { decouple, ..settings() };
        let mut ws = DareWorkspace::new(14, 7);
        ws.solve_warm(&problem, &s, &DMatrix::zeros(14, 14)).expect("solvable");
        assert!(rel(ws.p(), &cold.p) < 1e-10);
        ws.solve_warm(&problem, &s, &(&cold.p * -1.0)).expect("solvable");
        assert!(rel(ws.p(), &cold.p) < 1e-10);
    }
    // No stabilising solution: the cold solve's error, whatever the guess.
    let (a, b, q, r) = (dmatrix![2.0, 0.0; 0.0, 0.5], dmatrix![0.0; 1.0], DMatrix::identity(2, 2), dmatrix![1.0]);
    let err = ws.solve_warm(&DareProblem::new(&a, &b, &q, &r), &settings(), &DMatrix::identity(2, 2)).unwrap_err();
    assert!(matches!(err, RiccatiError::NotStabilisable { .. }), "{err}");
    // A malformed guess is named.
    let (a, b, q, r) = double_integrator(0.1);
    let problem = DareProblem::new(&a, &b, &q, &r);
    let err = ws.solve_warm(&problem, &settings(), &DMatrix::zeros(3, 3)).unwrap_err();
    assert!(matches!(err, RiccatiError::DimensionMismatch { matrix: "P0", .. }), "{err}");
    let err = ws.solve_warm(&problem, &settings(), &dmatrix![f64::NAN, 0.0; 0.0, 1.0]).unwrap_err();
    assert!(matches!(err, RiccatiError::NonFinite { matrix: "P0", .. }), "{err}");
    let err = ws.solve_warm(&problem, &settings(), &dmatrix![1.0, 1.0; 0.0, 1.0]).unwrap_err();
    assert!(matches!(err, RiccatiError::NotSymmetric { matrix: "P0", .. }), "{err}");
}
