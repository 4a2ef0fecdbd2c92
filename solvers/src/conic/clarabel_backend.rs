//! The Clarabel backend: one interior-point solver per capacity, its data
//! overwritten in place before each solve.

use super::{ConicData, ConicError, ConicSettings, ConicSolution};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT::NonnegativeConeT,
    SupportedConeT::SecondOrderConeT,
};

/// A Clarabel solver for up to `m_max` inequality rows in `n` variables and
/// an optional second-order cone of `k` rows, reused across solves.
pub struct ConicSolver {
    solver: DefaultSolver<f64>,
    n: usize,
    m_max: usize,
    cone: Option<usize>,
    p_values: Vec<f64>,
    a_values: Vec<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
}

impl ConicSolver {
    /// Builds the solver (this allocates; solves do not).
    ///
    /// # Panics
    /// If `n` is zero.
    pub fn new(n: usize, m_max: usize, cone: Option<usize>, settings: &ConicSettings) -> Self {
        assert!(n > 0, "a conic problem needs at least one variable");
        let cone_rows = cone.map_or(0, |k| k + 1);
        let rows = m_max + cone_rows;
        // Dense patterns: P's upper triangle, every entry of A (explicit
        // zeros kept so that later values may be nonzero).
        let p_colptr: Vec<usize> = (0..=n).map(|j| j * (j + 1) / 2).collect();
        let p_rowval: Vec<usize> = (0..n).flat_map(|j| 0..=j).collect();
        let p_values: Vec<f64> = (0..n).flat_map(|j| (0..=j).map(move |i| f64::from(i == j))).collect();
        let a_colptr: Vec<usize> = (0..=n).map(|j| j * rows).collect();
        let a_rowval: Vec<usize> = (0..n).flat_map(|_| 0..rows).collect();
        let a_values = vec![0.0; n * rows];
        let mut b = vec![1.0; rows];
        if cone.is_some() {
            b[m_max..].fill(0.0);
            b[m_max] = 1.0;
        }
        let p = CscMatrix::new(n, n, p_colptr, p_rowval, p_values.clone());
        let a = CscMatrix::new(rows, n, a_colptr, a_rowval, a_values.clone());
        let mut cones = vec![NonnegativeConeT(m_max)];
        if let Some(k) = cone {
            cones.push(SecondOrderConeT(k + 1));
        }
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .presolve_enable(false)
            .equilibrate_enable(false)
            .input_sparse_dropzeros(false)
            .tol_gap_abs(settings.tolerance)
            .tol_gap_rel(settings.tolerance)
            .tol_feas(settings.tolerance)
            .max_iter(settings.max_iterations)
            .build()
            .expect("valid Clarabel settings");
        let solver = DefaultSolver::new(&p, &vec![0.0; n], &a, &b, &cones, settings)
            .expect("a dense pattern of matching dimensions");
        ConicSolver { solver, n, m_max, cone, p_values, a_values, q: vec![0.0; n], b }
    }

    /// The most inequality rows a solve can take.
    pub fn capacity_rows(&self) -> usize {
        self.m_max
    }

    /// Solves the problem `data` (see the module documentation).
    ///
    /// # Errors
    /// [`ConicError::Capacity`] when `data` does not fit this solver; the
    /// solver's verdict otherwise (infeasible, unbounded, iteration limit,
    /// numerical failure). Reduced-accuracy solutions are accepted.
    pub fn solve(&mut self, data: &ConicData<'_>) -> Result<ConicSolution<'_>, ConicError> {
        let (n, m) = (data.variables(), data.rows());
        let k = data.cone.map(|c| c.c.len());
        if n != self.n || m > self.m_max || k != self.cone || data.p.len() != n * n || data.g.len() != m * n {
            return Err(ConicError::Capacity {
                variables: n,
                rows: m,
                cone: k,
                capacity_variables: self.n,
                capacity_rows: self.m_max,
                capacity_cone: self.cone,
            });
        }
        self.fill(data);
        let updated = self
            .solver
            .update_P(&self.p_values)
            .and_then(|()| self.solver.update_q(&self.q))
            .and_then(|()| self.solver.update_A(&self.a_values))
            .and_then(|()| self.solver.update_b(&self.b));
        if updated.is_err() {
            return Err(ConicError::Numerical);
        }
        self.solver.solve();
        let solution = &self.solver.solution;
        match solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                Ok(ConicSolution { x: &solution.x, z: &solution.z[..m], iterations: solution.iterations })
            }
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => Err(ConicError::Infeasible),
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => Err(ConicError::Unbounded),
            SolverStatus::MaxIterations | SolverStatus::MaxTime => Err(ConicError::MaxIterations),
            _ => Err(ConicError::Numerical),
        }
    }

    /// Copies `data` into the fixed dense patterns (padding rows `0 ≤ 1`).
    fn fill(&mut self, data: &ConicData<'_>) {
        let (n, m) = (self.n, data.rows());
        let rows = self.b.len();
        let mut at = 0;
        for j in 0..n {
            for i in 0..=j {
                self.p_values[at] = data.p[i + j * n];
                at += 1;
            }
        }
        for j in 0..n {
            let column = &mut self.a_values[j * rows..(j + 1) * rows];
            for (i, a) in column.iter_mut().enumerate().take(m) {
                *a = data.g[i * n + j];
            }
            column[m..self.m_max].fill(0.0);
            if let Some(cone) = &data.cone {
                // Cone rows: s = (r, c − L u) ∈ SOC, so A = [0; L], b = [r; c].
                column[self.m_max] = 0.0;
                for (i, a) in column[self.m_max + 1..].iter_mut().enumerate() {
                    *a = cone.l[i * n + j];
                }
            }
        }
        self.q.copy_from_slice(data.q);
        self.b[..m].copy_from_slice(data.h);
        self.b[m..self.m_max].fill(1.0);
        if let Some(cone) = &data.cone {
            self.b[self.m_max] = cone.radius;
            self.b[self.m_max + 1..].copy_from_slice(cone.c);
        }
    }
}
