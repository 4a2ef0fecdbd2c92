//! Discrete-time Riccati equations: the infinite-horizon DARE and the
//! finite-horizon backward recursion.
//!
//! For `x_{t+1} = A x_t + B u_t` and the stage cost
//! `xᵀQx + uᵀRu + 2xᵀNu`, [`solve_dare`] returns the stabilising solution
//! `P` of
//! `P = AᵀPA − (AᵀPB + N)(R + BᵀPB)⁻¹(BᵀPA + Nᵀ) + Q`
//! and the optimal gain `K = (R + BᵀPB)⁻¹(BᵀPA + Nᵀ)` of the policy
//! `u = −K x`. The method is the structure-preserving doubling algorithm
//! (SDA, quadratic convergence), followed by Newton (Hewer) refinement when
//! the residual calls for it; inputs that have no stabilising solution, or
//! whose answer cannot be trusted, return a [`RiccatiError`] instead of a
//! wrong `P`. A problem that splits into unconnected groups of states and
//! inputs (a per-joint model) is solved group by group
//! ([`DareSettings::decouple`]); [`DareWorkspace::solve_warm`] starts Newton
//! from a given `P` and falls back to the cold solve when that does not
//! lead to the stabilising solution. [`DareWorkspace`] keeps every buffer
//! between solves, so repeated solves of one size reuse them. [`finite_horizon_riccati`]
//! gives the time-varying gains of a finite horizon, with constant or
//! time-varying `A_t`, `B_t` (e.g. linearised along a reference).
//!
//! ```
//! use nalgebra::{dmatrix, DMatrix};
//! use tandem_solvers::riccati::{solve_dare, DareProblem, DareSettings};
//! // A double integrator sampled at dt = 0.1 s: state [position, velocity].
//! let dt = 0.1;
//! let a = dmatrix![1.0, dt; 0.0, 1.0];
//! let b = dmatrix![0.5 * dt * dt; dt];
//! let (q, r) = (DMatrix::<f64>::identity(2, 2), dmatrix![0.1]);
//! let sol = solve_dare(&DareProblem::new(&a, &b, &q, &r), &DareSettings::default())?;
//! assert!(sol.residual < 1e-12);
//! assert!(sol.closed_loop_spectral_radius < 1.0);
//! // u = −K x pushes a displaced, resting mass back towards the origin.
//! assert!(sol.k[(0, 0)] > 0.0);
//! # Ok::<(), tandem_solvers::riccati::RiccatiError>(())
//! ```

mod blocks;
mod dare;
mod dense;
mod finite_horizon;
mod gemm;
mod validate;

pub use dare::{DareProblem, DareSettings, DareSolution, DareStats, DareWorkspace, solve_dare};
pub use finite_horizon::{FiniteHorizonSolution, LinearDynamics, double_integrator, finite_horizon_riccati};

/// Why a Riccati solve returned no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RiccatiError {
    /// A matrix has the wrong shape for the state dimension `n` (rows of `A`)
    /// and input dimension `m` (columns of `B`).
    #[error("{matrix} is {}×{}, expected {}×{}", found.0, found.1, expected.0, expected.1)]
    DimensionMismatch {
        /// Which matrix (`"A"`, `"B"`, `"Q"`, `"R"`, `"N"`, `"Qf"`).
        matrix: &'static str,
        /// Expected (rows, columns).
        expected: (usize, usize),
        /// Actual (rows, columns).
        found: (usize, usize),
    },
    /// The state or input dimension is zero.
    #[error("the {dimension} dimension is zero")]
    EmptyDimension {
        /// `"state"` or `"input"`.
        dimension: &'static str,
    },
    /// An entry is NaN or infinite.
    #[error("{matrix}[{row}, {col}] = {value} is not finite")]
    NonFinite {
        /// Which matrix.
        matrix: &'static str,
        /// Row of the first offending entry.
        row: usize,
        /// Column of the first offending entry.
        col: usize,
        /// The entry.
        value: f64,
    },
    /// A weight matrix is not symmetric within the settings' tolerance.
    #[error("{matrix} is not symmetric: ‖M − Mᵀ‖_F / ‖M‖_F = {relative_asymmetry:e}")]
    NotSymmetric {
        /// Which matrix.
        matrix: &'static str,
        /// `‖M − Mᵀ‖_F / ‖M‖_F`.
        relative_asymmetry: f64,
    },
    /// A state weight has a negative eigenvalue (beyond the tolerance).
    /// With a cross term the checked matrix is the Schur complement
    /// `Q − N R⁻¹ Nᵀ`, i.e. the joint weight `[[Q, N], [Nᵀ, R]]` is indefinite.
    #[error("{matrix} is not positive semidefinite")]
    NotPositiveSemidefinite {
        /// Which matrix (`"Q"`, `"Q - N R⁻¹ Nᵀ"`, `"Qf"`).
        matrix: &'static str,
    },
    /// An input weight is not (numerically) positive definite.
    #[error("{matrix} is not positive definite")]
    NotPositiveDefinite {
        /// Which matrix (`"R"`, `"R + BᵀPB"`).
        matrix: &'static str,
    },
    /// The doubling iteration diverged or did not converge: an unstable (or
    /// marginal) mode that the cost penalises cannot be controlled, so no
    /// finite stabilising solution exists.
    #[error(
        "the doubling iteration diverged or stalled after {iterations} iterations: \
         (A, B) is not stabilisable (a penalised unstable mode is uncontrollable)"
    )]
    NotStabilisable {
        /// Doubling iterations run before giving up.
        iterations: usize,
    },
    /// The iteration settled, but the resulting closed loop `A − BK` is not
    /// Schur-stable: an unstable or marginal mode is invisible to the cost
    /// (`(A, Q)` not detectable) or cannot be controlled.
    #[error(
        "the closed loop A − BK is not Schur-stable (spectral radius ≥ {spectral_radius:.6}): \
         (A, Q) is not detectable or (A, B) not stabilisable"
    )]
    NotDetectable {
        /// Upper estimate of the closed-loop spectral radius (≥ 1).
        spectral_radius: f64,
    },
    /// The relative residual stays above the tolerance after refinement: the
    /// equation is too ill-conditioned for the answer to be trusted.
    #[error(
        "relative DARE residual {residual:e} exceeds the tolerance {tolerance:e} after refinement: \
         the problem is ill-conditioned"
    )]
    IllConditioned {
        /// Relative residual reached (infinite if a factorisation broke down).
        residual: f64,
        /// [`DareSettings::residual_tolerance`].
        tolerance: f64,
    },
    /// Time-varying dynamics do not cover the horizon.
    #[error("time-varying dynamics give {a_len} A and {b_len} B matrices, the horizon needs {horizon} of each")]
    HorizonMismatch {
        /// Number of `A_t`.
        a_len: usize,
        /// Number of `B_t`.
        b_len: usize,
        /// Requested horizon (steps).
        horizon: usize,
    },
    /// An error at one step of the finite-horizon recursion.
    #[error("at step {step}: {source}")]
    AtStep {
        /// Time step `t` (0-based).
        step: usize,
        /// What went wrong there.
        #[source]
        source: Box<RiccatiError>,
    },
}

#[cfg(test)]
mod tests;
