use super::*;
use nalgebra::{DMatrix, DVector};

/// min (x0 − 2)² + (x1 − 2)²  s.t.  x0 + x1 = 1,  x0 ≤ 0.2
struct Toy;
impl LeastSquaresProblem for Toy {
    type Error = std::convert::Infallible;
    fn dimension(&self) -> usize {
        2
    }
    fn bandwidth(&self) -> usize {
        1
    }
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error> {
        out.cost.push(0, x[0] - 2.0, 0, 1)[0] = 1.0;
        out.cost.push(1, x[1] - 2.0, 1, 1)[0] = 1.0;
        out.equality.push(0, x[0] + x[1] - 1.0, 0, 2).fill(1.0);
        out.inequality.push(0, x[0] - 0.2, 0, 1)[0] = 1.0;
        Ok(())
    }
}

fn tight() -> SolverSettings {
    SolverSettings {
        equality_tolerance: 1e-10,
        inequality_tolerance: 1e-10,
        step_tolerance: 1e-12,
        cost_tolerance: 1e-14,
        ..SolverSettings::default()
    }
}

#[test]
fn equality_and_active_inequality() {
    let mut solver = AugmentedLagrangian::new(2, 1, tight());
    let mut x = [0.0, 0.0];
    let report = solver.solve(&mut Toy, &mut x).unwrap();
    assert_eq!(report.termination, Termination::Converged);
    assert!((x[0] - 0.2).abs() < 1e-9 && (x[1] - 0.8).abs() < 1e-9, "{x:?}");
    assert!((report.cost - (1.8f64.powi(2) + 1.2f64.powi(2))).abs() < 1e-8);
    assert!(report.equality_violation <= 1e-10 && report.inequality_violation <= 1e-10);
    assert!(report.evaluations >= report.inner_steps && report.outer_iterations >= 1);
}

/// Rosenbrock as least squares: r = [10 (x1 − x0²), 1 − x0].
struct Rosenbrock;
impl LeastSquaresProblem for Rosenbrock {
    type Error = std::convert::Infallible;
    fn dimension(&self) -> usize {
        2
    }
    fn bandwidth(&self) -> usize {
        1
    }
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error> {
        out.cost.push(0, 10.0 * (x[1] - x[0] * x[0]), 0, 2).copy_from_slice(&[-20.0 * x[0], 10.0]);
        out.cost.push(1, 1.0 - x[0], 0, 1)[0] = -1.0;
        Ok(())
    }
}

#[test]
fn unconstrained_rosenbrock() {
    let mut solver = AugmentedLagrangian::new(
        2,
        1,
        SolverSettings { step_tolerance: 1e-12, cost_tolerance: 1e-20, ..Default::default() },
    );
    let mut x = [-1.2, 1.0];
    let report = solver.solve(&mut Rosenbrock, &mut x).unwrap();
    assert_eq!(report.termination, Termination::Converged);
    assert!((x[0] - 1.0).abs() < 1e-7 && (x[1] - 1.0).abs() < 1e-7, "{x:?} {report:?}");
    assert!(report.cost < 1e-14);
}

/// A smoothing chain: min Σ (x_{i+1} − 2x_i + x_{i−1})² + 0.01 Σ (x_i − c_i)²
/// s.t. x_0 = 0, x_{n−1} = 1, x_{n/2} = 2: an equality-constrained QP
/// whose exact solution comes from the dense KKT system.
struct Chain {
    n: usize,
    target: Vec<f64>,
}

impl Chain {
    const PINS: [(usize, f64); 3] = [(0, 0.0), (59, 1.0), (30, 2.0)];
}

impl LeastSquaresProblem for Chain {
    type Error = std::convert::Infallible;
    fn dimension(&self) -> usize {
        self.n
    }
    fn bandwidth(&self) -> usize {
        2
    }
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error> {
        for i in 1..self.n - 1 {
            let r = x[i + 1] - 2.0 * x[i] + x[i - 1];
            out.cost.push(i as u64, r, i - 1, 3).copy_from_slice(&[1.0, -2.0, 1.0]);
        }
        for (i, (xi, ci)) in x.iter().zip(&self.target).enumerate() {
            out.cost.push(0, 0.1 * (xi - ci), i, 1)[0] = 0.1;
        }
        for (k, &(i, v)) in Chain::PINS.iter().enumerate() {
            out.equality.push(k as u64, x[i] - v, i, 1)[0] = 1.0;
        }
        Ok(())
    }
}

#[test]
fn banded_equality_qp_matches_dense_kkt() {
    let n = 60;
    let target: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut chain = Chain { n, target: target.clone() };
    // Dense KKT: [2AᵀA  Cᵀ; C 0] [x; ν] = [2Aᵀb; d].
    let rows = (n - 2) + n;
    let mut a = DMatrix::zeros(rows, n);
    let mut b = DVector::zeros(rows);
    for i in 1..n - 1 {
        a[(i - 1, i - 1)] = 1.0;
        a[(i - 1, i)] = -2.0;
        a[(i - 1, i + 1)] = 1.0;
    }
    for i in 0..n {
        a[(n - 2 + i, i)] = 0.1;
        b[n - 2 + i] = 0.1 * target[i];
    }
    let m = Chain::PINS.len();
    let mut kkt = DMatrix::zeros(n + m, n + m);
    kkt.view_mut((0, 0), (n, n)).copy_from(&(2.0 * a.transpose() * &a));
    let mut rhs = DVector::zeros(n + m);
    rhs.rows_mut(0, n).copy_from(&(2.0 * a.transpose() * &b));
    for (k, &(i, v)) in Chain::PINS.iter().enumerate() {
        kkt[(n + k, i)] = 1.0;
        kkt[(i, n + k)] = 1.0;
        rhs[n + k] = v;
    }
    let exact = kkt.lu().solve(&rhs).expect("KKT solvable");
    let mut solver = AugmentedLagrangian::new(n, 2, tight());
    let mut x = vec![0.0; n];
    let report = solver.solve(&mut chain, &mut x).unwrap();
    assert_eq!(report.termination, Termination::Converged);
    for i in 0..n {
        assert!((x[i] - exact[i]).abs() < 1e-8, "x[{i}] = {} vs {}", x[i], exact[i]);
    }
    // A second solve from the solution converges at once.
    let first = report.evaluations;
    let again = solver.solve(&mut chain, &mut x).unwrap();
    assert_eq!(again.termination, Termination::Converged);
    assert!(again.evaluations < first, "{} vs {first}", again.evaluations);
}

/// x0 = 1 and x0 = 2 at once.
struct Contradiction;
impl LeastSquaresProblem for Contradiction {
    type Error = std::convert::Infallible;
    fn dimension(&self) -> usize {
        1
    }
    fn bandwidth(&self) -> usize {
        0
    }
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error> {
        out.equality.push(0, x[0] - 1.0, 0, 1)[0] = 1.0;
        out.equality.push(1, x[0] - 2.0, 0, 1)[0] = 1.0;
        Ok(())
    }
}

#[test]
fn contradictory_constraints_are_reported_infeasible() {
    let mut solver = AugmentedLagrangian::new(1, 0, SolverSettings::default());
    let mut x = [0.0];
    let report = solver.solve(&mut Contradiction, &mut x).unwrap();
    assert_eq!(report.termination, Termination::Infeasible);
    assert!((x[0] - 1.5).abs() < 1e-5, "the least-violating point: {x:?}");
    assert!((report.equality_violation - 0.5).abs() < 1e-5);
}

/// min Σ (x_i − 1)² s.t. x_i ≤ 0.5 for even i, where a constraint row is
/// only written while x_i > 0.3 (like collision pairs within a cutoff).
struct Cutoff;
impl LeastSquaresProblem for Cutoff {
    type Error = std::convert::Infallible;
    fn dimension(&self) -> usize {
        8
    }
    fn bandwidth(&self) -> usize {
        0
    }
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error> {
        for (i, xi) in x.iter().enumerate() {
            out.cost.push(0, xi - 1.0, i, 1)[0] = 1.0;
            if i % 2 == 0 && *xi > 0.3 {
                out.inequality.push(100 + i as u64, xi - 0.5, i, 1)[0] = 1.0;
            }
        }
        Ok(())
    }
}

#[test]
fn keyed_inequalities_follow_their_rows() {
    let mut solver = AugmentedLagrangian::new(8, 0, tight());
    let mut x = [0.0; 8];
    let report = solver.solve(&mut Cutoff, &mut x).unwrap();
    assert_eq!(report.termination, Termination::Converged);
    for (i, xi) in x.iter().enumerate() {
        let expected = if i % 2 == 0 { 0.5 } else { 1.0 };
        assert!((xi - expected).abs() < 1e-9, "x[{i}] = {xi}");
    }
}

struct Broken {
    value: f64,
    width: usize,
}
impl LeastSquaresProblem for Broken {
    type Error = String;
    fn dimension(&self) -> usize {
        3
    }
    fn bandwidth(&self) -> usize {
        1
    }
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), String> {
        if x[0] > 10.0 {
            return Err("x0 out of the model's range".into());
        }
        out.cost.push(0, self.value + x[0], 0, self.width).fill(1.0);
        Ok(())
    }
}

#[test]
fn errors_name_the_problem() {
    let mut solver = AugmentedLagrangian::new(3, 1, SolverSettings::default());
    let nan = solver.solve(&mut Broken { value: f64::NAN, width: 1 }, &mut [0.0; 3]);
    assert!(matches!(nan, Err(SolveError::NotFiniteAtStart)));
    let wide = solver.solve(&mut Broken { value: 0.0, width: 3 }, &mut [0.0; 3]);
    assert!(matches!(wide, Err(SolveError::RowOutsideBand { width: 3, .. })), "{wide:?}");
    let short = solver.solve(&mut Broken { value: 0.0, width: 1 }, &mut [0.0; 2]);
    assert!(matches!(short, Err(SolveError::Dimension { what: "x", expected: 3, got: 2 })));
    let failed = solver.solve(&mut Broken { value: 0.0, width: 1 }, &mut [11.0, 0.0, 0.0]);
    assert_eq!(failed.unwrap_err().to_string(), "evaluation failed: x0 out of the model's range");
}

#[test]
fn budgets_stop_the_solve() {
    let settings = SolverSettings { max_evaluations: 3, step_tolerance: 0.0, ..SolverSettings::default() };
    let mut solver = AugmentedLagrangian::new(2, 1, settings);
    let report = solver.solve(&mut Rosenbrock, &mut [-1.2, 1.0]).unwrap();
    assert_eq!(report.termination, Termination::EvaluationLimit);
    assert_eq!(report.evaluations, 3);
    let settings = SolverSettings { time_limit: Some(std::time::Duration::ZERO), ..SolverSettings::default() };
    let report = AugmentedLagrangian::new(2, 1, settings).solve(&mut Rosenbrock, &mut [-1.2, 1.0]).unwrap();
    assert_eq!(report.termination, Termination::TimeLimit);
}

#[test]
fn non_finite_entries_are_found_anywhere() {
    let mut block = RowBlock::default();
    assert!(!block.has_non_finite());
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for at in 0..10 {
            block.clear();
            block.push(0, -0.5, 0, 9).fill(1e300);
            assert!(!block.has_non_finite());
            block.clear();
            let value = if at == 9 { bad } else { 0.0 };
            let gradient = block.push(0, value, 0, 9);
            gradient.fill(-3.0);
            if at < 9 {
                gradient[at] = bad;
            }
            assert!(block.has_non_finite(), "{bad} at {at}");
        }
    }
}
