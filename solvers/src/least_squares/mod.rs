//! Constrained nonlinear least squares on banded Jacobians: an
//! augmented-Lagrangian outer loop around a Levenberg-Marquardt
//! (damped Gauss-Newton) inner loop.
//!
//! The problem is
//!
//! ```text
//! min_x  Σ r_i(x)²   subject to   h_j(x) = 0,   g_k(x) ≤ 0
//! ```
//!
//! given by a [`LeastSquaresProblem`] that writes the rows of `r`, `h` and
//! `g`, each with its gradient over a contiguous window of at most
//! `bandwidth + 1` variables, into [`Residuals`]. The inner loop minimises
//! the augmented Lagrangian
//!
//! ```text
//! L(x) = Σ r² + Σ_j μ (h_j + λ_j / 2μ)² + Σ_k μ max(0, g_k + λ_k / 2μ)²
//! ```
//!
//! (PHR form) by Gauss-Newton steps on the banded normal equations
//! `(JᵀJ + δI) s = −Jᵀφ` with Levenberg-Marquardt damping `δ` (Nielsen's
//! update), an optional ∞-norm step bound, and acceptance on actual versus
//! predicted decrease. The outer loop updates `λ_h += 2μh`,
//! `λ_g = max(0, λ_g + 2μg)` and grows `μ` when the violation does not
//! shrink fast enough.
//!
//! Constraint rows carry a *key*, so their multipliers follow the right
//! row when the set of rows changes between evaluations (e.g. collision
//! pairs that come within a cutoff); an inequality row that disappears
//! takes its multiplier with it.
//!
//! ```
//! use tandem_solvers::least_squares::{
//!     AugmentedLagrangian, LeastSquaresProblem, Residuals, SolverSettings, Termination,
//! };
//! // min (x0 − 2)² + (x1 − 2)²  s.t.  x0 + x1 = 1,  x0 ≤ 0.2
//! struct Toy;
//! impl LeastSquaresProblem for Toy {
//!     type Error = std::convert::Infallible;
//!     fn dimension(&self) -> usize { 2 }
//!     fn bandwidth(&self) -> usize { 1 }
//!     fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error> {
//!         out.cost.push(0, x[0] - 2.0, 0, 1)[0] = 1.0;
//!         out.cost.push(1, x[1] - 2.0, 1, 1)[0] = 1.0;
//!         out.equality.push(0, x[0] + x[1] - 1.0, 0, 2).fill(1.0);
//!         out.inequality.push(0, x[0] - 0.2, 0, 1)[0] = 1.0;
//!         Ok(())
//!     }
//! }
//! let mut solver = AugmentedLagrangian::new(2, 1, SolverSettings::default());
//! let mut x = [0.0, 0.0];
//! let report = solver.solve(&mut Toy, &mut x).unwrap();
//! assert_eq!(report.termination, Termination::Converged);
//! assert!((x[0] - 0.2).abs() < 1e-4 && (x[1] - 0.8).abs() < 1e-4);
//! ```

mod rows;
mod solver;

pub use rows::{Residuals, RowBlock};
pub use solver::{AugmentedLagrangian, SolveError, SolveReport, SolverSettings, Termination};

/// A constrained least-squares problem whose rows each depend on a
/// contiguous window of at most `bandwidth() + 1` variables.
pub trait LeastSquaresProblem {
    /// Why an evaluation can fail.
    type Error;

    /// Number of variables.
    fn dimension(&self) -> usize;

    /// Half bandwidth `b` of `JᵀJ`: no row touches variables more than `b`
    /// apart.
    fn bandwidth(&self) -> usize;

    /// Writes every cost, equality and inequality row at `x` into `out`
    /// (which arrives cleared). Constraint keys must be unique within
    /// their block and stable across evaluations.
    ///
    /// # Errors
    /// Whatever the problem cannot evaluate; the solve stops with it.
    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), Self::Error>;
}

#[cfg(test)]
mod tests;
