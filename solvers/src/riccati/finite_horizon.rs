//! Finite-horizon LQR by the backward Riccati recursion, with constant or
//! time-varying dynamics (e.g. linearised along a reference trajectory).

use super::RiccatiError;
use super::dense::symmetrize;
use super::validate;
use nalgebra::{DMatrix, DMatrixView};

/// Tolerance for the symmetry of the weights (relative Frobenius) and for
/// the negative eigenvalues `Q` and `Qf` may show from rounding.
const WEIGHT_TOLERANCE: f64 = 1e-10;

/// The dynamics `x_{t+1} = A_t x_t + B_t u_t` over the horizon.
#[derive(Debug, Clone, Copy)]
pub enum LinearDynamics<'a> {
    /// The same `A` (n×n) and `B` (n×m) at every step.
    Constant {
        /// State matrix.
        a: DMatrixView<'a, f64>,
        /// Input matrix.
        b: DMatrixView<'a, f64>,
    },
    /// `A_t`, `B_t` for `t = 0 … horizon − 1` (longer slices are allowed;
    /// the extra entries are ignored).
    TimeVarying {
        /// State matrices, one per step.
        a: &'a [DMatrix<f64>],
        /// Input matrices, one per step.
        b: &'a [DMatrix<f64>],
    },
}

impl<'a> LinearDynamics<'a> {
    /// Time-invariant dynamics.
    pub fn constant(a: impl Into<DMatrixView<'a, f64>>, b: impl Into<DMatrixView<'a, f64>>) -> Self {
        LinearDynamics::Constant { a: a.into(), b: b.into() }
    }

    /// Time-varying dynamics, one `(A_t, B_t)` per step.
    pub fn time_varying(a: &'a [DMatrix<f64>], b: &'a [DMatrix<f64>]) -> Self {
        LinearDynamics::TimeVarying { a, b }
    }

    /// `(A_t, B_t)`; `t` is below the checked horizon.
    fn at(&self, t: usize) -> (DMatrixView<'a, f64>, DMatrixView<'a, f64>) {
        match *self {
            LinearDynamics::Constant { a, b } => (a, b),
            LinearDynamics::TimeVarying { a, b } => (a[t].as_view(), b[t].as_view()),
        }
    }
}

/// Gains and cost-to-go of a finite horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct FiniteHorizonSolution {
    /// `K_t` (m×n) for `t = 0 … horizon − 1`: the optimal input is `u_t = −K_t x_t`.
    pub gains: Vec<DMatrix<f64>>,
    /// `P_t` (n×n) for `t = 0 … horizon`: the optimal cost from `x` at step
    /// `t` is `xᵀP_t x`; `P_horizon = Qf`.
    pub cost_to_go: Vec<DMatrix<f64>>,
}

/// Minimises `Σ_{t<T} (x_tᵀQx_t + u_tᵀRu_t) + x_Tᵀ Qf x_T` over `T = horizon` steps.
///
/// Backward recursion from `P_T = Qf`:
/// `K_t = (R + B_tᵀP_{t+1}B_t)⁻¹ B_tᵀP_{t+1}A_t`,
/// `P_t = Q + K_tᵀRK_t + (A_t − B_tK_t)ᵀP_{t+1}(A_t − B_tK_t)` (the Joseph
/// form, which keeps `P_t` PSD under rounding). For long horizons and
/// constant dynamics `K_0` tends to the DARE gain.
///
/// `Q`, `Qf` (n×n) symmetric PSD and `R` (m×m) symmetric PD; `n` is the
/// size of `Q`, `m` that of `R`. Errors name the step at which a per-step
/// matrix is malformed or the recursion breaks down (overflow of `P_t`).
pub fn finite_horizon_riccati<'a>(
    dynamics: &LinearDynamics<'_>,
    q: impl Into<DMatrixView<'a, f64>>,
    r: impl Into<DMatrixView<'a, f64>>,
    qf: impl Into<DMatrixView<'a, f64>>,
    horizon: usize,
) -> Result<FiniteHorizonSolution, RiccatiError> {
    let (q, r, qf) = (q.into(), r.into(), qf.into());
    let (n, m) = (q.nrows(), r.nrows());
    let q = weight("Q", &q, n, false)?;
    let r = weight("R", &r, m, true)?;
    let mut p = weight("Qf", &qf, n, false)?;
    check_dynamics(dynamics, n, m, horizon)?;
    let mut gains = Vec::with_capacity(horizon);
    let mut cost_to_go = Vec::with_capacity(horizon + 1);
    cost_to_go.push(p.clone());
    for t in (0..horizon).rev() {
        let (a, b) = dynamics.at(t);
        let at_step = |source| RiccatiError::AtStep { step: t, source: Box::new(source) };
        let pb = &p * b;
        let s = &r + b.transpose() * &pb;
        let chol = s.cholesky().ok_or_else(|| at_step(RiccatiError::NotPositiveDefinite { matrix: "R + BᵀPB" }))?;
        let k = chol.solve(&(pb.transpose() * a));
        let closed = a - b * &k;
        p = &q + k.transpose() * &r * &k + closed.transpose() * &p * &closed;
        symmetrize(&mut p);
        validate::finite("P", &p.as_view()).map_err(at_step)?;
        gains.push(k);
        cost_to_go.push(p.clone());
    }
    gains.reverse();
    cost_to_go.reverse();
    Ok(FiniteHorizonSolution { gains, cost_to_go })
}

/// Checks a weight (shape, finite, symmetric, PSD or PD) and returns it symmetrised.
fn weight(
    name: &'static str,
    w: &DMatrixView<'_, f64>,
    size: usize,
    definite: bool,
) -> Result<DMatrix<f64>, RiccatiError> {
    if size == 0 {
        let dimension = if definite { "input" } else { "state" };
        return Err(RiccatiError::EmptyDimension { dimension });
    }
    validate::shape(name, w, size, size)?;
    validate::finite(name, w)?;
    let mut w = w.into_owned();
    validate::symmetric(name, &mut w, WEIGHT_TOLERANCE)?;
    let shift = if definite { 0.0 } else { WEIGHT_TOLERANCE * w.norm() + f64::MIN_POSITIVE };
    let mut shifted = w.clone();
    for i in 0..size {
        shifted[(i, i)] += shift;
    }
    if shifted.cholesky().is_none() {
        return Err(if definite {
            RiccatiError::NotPositiveDefinite { matrix: name }
        } else {
            RiccatiError::NotPositiveSemidefinite { matrix: name }
        });
    }
    Ok(w)
}

/// Checks that the dynamics cover the horizon with finite `n×n` / `n×m` matrices.
fn check_dynamics(dynamics: &LinearDynamics<'_>, n: usize, m: usize, horizon: usize) -> Result<(), RiccatiError> {
    let check = |a: &DMatrixView<'_, f64>, b: &DMatrixView<'_, f64>| {
        validate::shape("A", a, n, n)?;
        validate::shape("B", b, n, m)?;
        validate::finite("A", a)?;
        validate::finite("B", b)
    };
    match dynamics {
        LinearDynamics::Constant { a, b } => check(a, b),
        LinearDynamics::TimeVarying { a, b } => {
            if a.len() < horizon || b.len() < horizon {
                return Err(RiccatiError::HorizonMismatch { a_len: a.len(), b_len: b.len(), horizon });
            }
            for t in 0..horizon {
                check(&a[t].as_view(), &b[t].as_view())
                    .map_err(|source| RiccatiError::AtStep { step: t, source: Box::new(source) })?;
            }
            Ok(())
        }
    }
}

/// `dof` decoupled double integrators sampled every `dt` seconds, with
/// state `x = [p, ṗ]` (2·dof) and input `u = p̈` (dof), held constant over
/// a step: `A = [[I, dt·I], [0, I]]`, `B = [[dt²/2·I], [dt·I]]`.
pub fn double_integrator(dof: usize, dt: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut a = DMatrix::identity(2 * dof, 2 * dof);
    let mut b = DMatrix::zeros(2 * dof, dof);
    for j in 0..dof {
        a[(j, dof + j)] = dt;
        b[(j, j)] = 0.5 * dt * dt;
        b[(dof + j, j)] = dt;
    }
    (a, b)
}
