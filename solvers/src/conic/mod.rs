//! Small dense QPs and SOCPs solved again and again with new data: the
//! per-tick problems of shared control, over Clarabel (and OSQP for the QPs,
//! behind the `osqp` cargo feature, as a cross-check).
//!
//! The problem, in `u ∈ ℝⁿ`:
//!
//! ```text
//! minimise    ½ uᵀ P u + qᵀ u
//! subject to  G u ≤ h                    (m linear inequalities)
//!             ‖L u − c‖₂ ≤ r             (optional, one second-order cone, L is k × n)
//! ```
//!
//! A [`ConicSolver`] is built once for a *capacity* (`n`, at most `m_max`
//! inequality rows, the cone's `k` or none) with a fixed dense sparsity
//! pattern, so each solve only overwrites values (`presolve` and
//! equilibration off, as Clarabel requires for data updates): rows beyond
//! the problem's `m` are padded with `0 ≤ 1`. A [`ConicSolverPool`] holds
//! solvers for doubling row capacities and picks the smallest that fits,
//! since Clarabel's cost grows with the rows.
//!
//! ```
//! use tandem_solvers::conic::{ConicData, ConicSolver, ConicSettings};
//! // min ½‖u‖² − [1, 1]·u  s.t.  u₀ + u₁ ≤ 1  →  u = [½, ½].
//! let mut solver = ConicSolver::new(2, 1, None, &ConicSettings::default());
//! let data = ConicData { p: &[1.0, 0.0, 0.0, 1.0], q: &[-1.0, -1.0], g: &[1.0, 1.0], h: &[1.0], cone: None };
//! let u = solver.solve(&data).unwrap().x;
//! assert!((u[0] - 0.5).abs() < 1e-7 && (u[1] - 0.5).abs() < 1e-7);
//! ```

mod active_set;
mod clarabel_backend;
#[cfg(feature = "osqp")]
mod osqp_backend;
#[cfg(test)]
mod tests;

pub use active_set::ActiveSetSolver;
pub use clarabel_backend::ConicSolver;
#[cfg(feature = "osqp")]
pub use osqp_backend::OsqpSolver;

/// One second-order cone constraint `‖L u − c‖₂ ≤ radius`.
#[derive(Debug, Clone, Copy)]
pub struct SecondOrderCone<'a> {
    /// `L`, `k × n`, row-major (row `i` is `l[i*n .. (i+1)*n]`).
    pub l: &'a [f64],
    /// `c`, length `k`.
    pub c: &'a [f64],
    /// The radius `r ≥ 0`.
    pub radius: f64,
}

/// The data of one problem (see the module documentation).
#[derive(Debug, Clone, Copy)]
pub struct ConicData<'a> {
    /// `P`, `n × n`, symmetric positive semidefinite, column-major (only the
    /// upper triangle is read).
    pub p: &'a [f64],
    /// `q`, length `n`.
    pub q: &'a [f64],
    /// `G`, `m × n`, row-major; `m = h.len()`.
    pub g: &'a [f64],
    /// `h`, length `m`.
    pub h: &'a [f64],
    /// The optional second-order cone.
    pub cone: Option<SecondOrderCone<'a>>,
}

impl ConicData<'_> {
    /// Number of variables.
    pub fn variables(&self) -> usize {
        self.q.len()
    }

    /// Number of linear inequality rows.
    pub fn rows(&self) -> usize {
        self.h.len()
    }

    /// Largest violation of the constraints at `u` (0 when feasible).
    pub fn violation(&self, u: &[f64]) -> f64 {
        let n = self.variables();
        let mut worst = 0.0f64;
        for (i, h) in self.h.iter().enumerate() {
            let gu: f64 = self.g[i * n..(i + 1) * n].iter().zip(u).map(|(g, u)| g * u).sum();
            worst = worst.max(gu - h);
        }
        if let Some(cone) = &self.cone {
            worst = worst.max(cone_norm(cone, u) - cone.radius);
        }
        worst
    }

    /// The objective `½ uᵀ P u + qᵀ u` at `u`.
    pub fn objective(&self, u: &[f64]) -> f64 {
        let n = self.variables();
        let mut v = 0.0;
        for c in 0..n {
            for r in 0..n {
                v += 0.5 * u[r] * self.p[r + c * n] * u[c];
            }
            v += self.q[c] * u[c];
        }
        v
    }
}

/// `Ok` when `data` is a QP (no cone) that fits `n` variables and
/// `m_max` rows, else the [`ConicError::Capacity`] naming both.
pub(crate) fn check_qp_capacity(data: &ConicData<'_>, n: usize, m_max: usize) -> Result<(), ConicError> {
    let (variables, rows) = (data.variables(), data.rows());
    if variables != n || rows > m_max || data.cone.is_some() || data.p.len() != n * n || data.g.len() != rows * n {
        return Err(ConicError::Capacity {
            variables,
            rows,
            cone: data.cone.map(|c| c.c.len()),
            capacity_variables: n,
            capacity_rows: m_max,
            capacity_cone: None,
        });
    }
    Ok(())
}

/// `‖L u − c‖₂`.
pub(crate) fn cone_norm(cone: &SecondOrderCone<'_>, u: &[f64]) -> f64 {
    let n = u.len();
    cone.c
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let lu: f64 = cone.l[i * n..(i + 1) * n].iter().zip(u).map(|(l, u)| l * u).sum();
            (lu - c) * (lu - c)
        })
        .sum::<f64>()
        .sqrt()
}

/// Solver settings shared by the backends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConicSettings {
    /// Absolute and relative feasibility and optimality tolerance (default
    /// 1e-8: a joint velocity right to ~1e-8 rad/s, far below what any
    /// actuator resolves, at 6–10 interior-point iterations).
    pub tolerance: f64,
    /// Iteration limit (default 100).
    pub max_iterations: u32,
}

impl Default for ConicSettings {
    fn default() -> Self {
        ConicSettings { tolerance: 1e-8, max_iterations: 100 }
    }
}

/// What a solve found.
#[derive(Debug, Clone, Copy)]
pub struct ConicSolution<'s> {
    /// The minimiser.
    pub x: &'s [f64],
    /// Multipliers of the inequality rows (`z ≥ 0`, one per row of `G`).
    pub z: &'s [f64],
    /// Interior-point (or ADMM) iterations.
    pub iterations: u32,
}

/// Why a solve returned no solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ConicError {
    /// The constraints admit no point.
    #[error("the problem is infeasible")]
    Infeasible,
    /// The objective is unbounded below.
    #[error("the problem is unbounded")]
    Unbounded,
    /// The iteration limit was hit.
    #[error("the iteration limit was reached")]
    MaxIterations,
    /// Numerical trouble (non-finite data, lack of progress).
    #[error("the solver failed numerically")]
    Numerical,
    /// The data does not fit the solver's capacity.
    #[error(
        "data of {variables} variables, {rows} rows and cone {cone:?} do not fit a solver built for {capacity_variables}, {capacity_rows} and {capacity_cone:?}"
    )]
    Capacity {
        variables: usize,
        rows: usize,
        cone: Option<usize>,
        capacity_variables: usize,
        capacity_rows: usize,
        capacity_cone: Option<usize>,
    },
}

/// Solvers of doubling row capacities (2, 4, …, `max_rows`) for one
/// variable count and cone size; [`ConicSolverPool::solve`] uses the
/// smallest that fits. All are built up front: solving allocates nothing.
pub struct ConicSolverPool {
    solvers: Vec<ConicSolver>,
}

impl ConicSolverPool {
    /// Builds the pool for `n` variables, up to `max_rows` inequality rows
    /// and an optional cone of `k` rows.
    pub fn new(n: usize, max_rows: usize, cone: Option<usize>, settings: &ConicSettings) -> Self {
        let mut caps = vec![];
        let mut cap = 2;
        while cap < max_rows {
            caps.push(cap);
            cap *= 2;
        }
        caps.push(max_rows.max(1));
        ConicSolverPool { solvers: caps.into_iter().map(|m| ConicSolver::new(n, m, cone, settings)).collect() }
    }

    /// The largest row count a solve can take.
    pub fn max_rows(&self) -> usize {
        self.solvers.last().map_or(0, ConicSolver::capacity_rows)
    }

    /// Solves with the smallest solver whose capacity fits `data`.
    pub fn solve(&mut self, data: &ConicData<'_>) -> Result<ConicSolution<'_>, ConicError> {
        let m = data.rows();
        let index = self.solvers.iter().position(|s| s.capacity_rows() >= m).unwrap_or(self.solvers.len() - 1);
        self.solvers[index].solve(data)
    }
}
