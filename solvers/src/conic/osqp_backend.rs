//! The OSQP backend (QPs only): a cross-check of Clarabel on the same data,
//! and an ADMM alternative that warm-starts from the previous solution.

use super::{ConicData, ConicError, ConicSettings, ConicSolution};
use osqp::{CscMatrix, Problem, Settings, Status};
use std::borrow::Cow;

/// An OSQP solver for QPs (no cone) with up to `m_max` inequality rows in
/// `n` variables, reused (and warm-started) across solves.
pub struct OsqpSolver {
    problem: Problem,
    n: usize,
    m_max: usize,
    p_indptr: Vec<usize>,
    p_indices: Vec<usize>,
    p_values: Vec<f64>,
    a_indptr: Vec<usize>,
    a_indices: Vec<usize>,
    a_values: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    x: Vec<f64>,
    y: Vec<f64>,
}

impl OsqpSolver {
    /// Builds the solver (this allocates; solves do not).
    ///
    /// # Panics
    /// If `n` is zero or OSQP rejects the dense pattern.
    pub fn new(n: usize, m_max: usize, settings: &ConicSettings) -> Self {
        assert!(n > 0, "a QP needs at least one variable");
        let rows = m_max.max(1);
        let p_indptr: Vec<usize> = (0..=n).map(|j| j * (j + 1) / 2).collect();
        let p_indices: Vec<usize> = (0..n).flat_map(|j| 0..=j).collect();
        let p_values: Vec<f64> = (0..n).flat_map(|j| (0..=j).map(move |i| f64::from(i == j))).collect();
        let a_indptr: Vec<usize> = (0..=n).map(|j| j * rows).collect();
        let a_indices: Vec<usize> = (0..n).flat_map(|_| 0..rows).collect();
        let a_values = vec![0.0; n * rows];
        let (lower, upper) = (vec![f64::NEG_INFINITY; rows], vec![1.0; rows]);
        let osqp_settings = Settings::default()
            .verbose(false)
            .eps_abs(settings.tolerance)
            .eps_rel(settings.tolerance)
            .max_iter(settings.max_iterations.max(4000))
            .polish(true)
            .warm_start(true)
            .adaptive_rho(true);
        let p = csc(n, n, &p_indptr, &p_indices, &p_values);
        let a = csc(rows, n, &a_indptr, &a_indices, &a_values);
        let problem =
            Problem::new(p, &vec![0.0; n], a, &lower, &upper, &osqp_settings).expect("a valid dense QP pattern");
        let (x, y) = (vec![0.0; n], vec![0.0; rows]);
        OsqpSolver {
            problem,
            n,
            m_max: rows,
            p_indptr,
            p_indices,
            p_values,
            a_indptr,
            a_indices,
            a_values,
            lower,
            upper,
            x,
            y,
        }
    }

    /// Solves the QP `data` (which must have no cone).
    ///
    /// # Errors
    /// As [`super::ConicSolver::solve`].
    pub fn solve(&mut self, data: &ConicData<'_>) -> Result<ConicSolution<'_>, ConicError> {
        super::check_qp_capacity(data, self.n, self.m_max)?;
        let (n, m) = (data.variables(), data.rows());
        let rows = self.m_max;
        let mut at = 0;
        for j in 0..n {
            for i in 0..=j {
                self.p_values[at] = data.p[i + j * n];
                at += 1;
            }
            let column = &mut self.a_values[j * rows..(j + 1) * rows];
            for (i, a) in column.iter_mut().enumerate() {
                *a = if i < m { data.g[i * n + j] } else { 0.0 };
            }
        }
        self.upper[..m].copy_from_slice(data.h);
        self.upper[m..].fill(1.0);
        self.problem.update_P_A(
            csc(n, n, &self.p_indptr, &self.p_indices, &self.p_values),
            csc(rows, n, &self.a_indptr, &self.a_indices, &self.a_values),
        );
        self.problem.update_lin_cost(data.q);
        self.problem.update_bounds(&self.lower, &self.upper);
        let status = self.problem.solve();
        let iterations = status.iter();
        match status {
            Status::Solved(s) | Status::SolvedInaccurate(s) => {
                self.x.copy_from_slice(s.x());
                self.y.copy_from_slice(s.y());
                Ok(ConicSolution { x: &self.x, z: &self.y[..m], iterations })
            }
            Status::PrimalInfeasible(_) | Status::PrimalInfeasibleInaccurate(_) => Err(ConicError::Infeasible),
            Status::DualInfeasible(_) | Status::DualInfeasibleInaccurate(_) => Err(ConicError::Unbounded),
            Status::MaxIterationsReached(_) => Err(ConicError::MaxIterations),
            _ => Err(ConicError::Numerical),
        }
    }
}

fn csc<'a>(nrows: usize, ncols: usize, indptr: &'a [usize], indices: &'a [usize], data: &'a [f64]) -> CscMatrix<'a> {
    CscMatrix {
        nrows,
        ncols,
        indptr: Cow::Borrowed(indptr),
        indices: Cow::Borrowed(indices),
        data: Cow::Borrowed(data),
    }
}
