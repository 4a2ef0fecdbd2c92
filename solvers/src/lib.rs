//! Numerical building blocks for tandem, free of any robotics.
//!
//! This crate takes residual functions, matrices and vectors; it never sees a
//! robot, a frame or a joint. It holds finite-difference derivatives, used to
//! check every analytic Jacobian in tandem; the discrete-time Riccati solvers
//! behind LQR tracking ([`riccati`]: the DARE by structure-preserving
//! doubling, and the finite-horizon recursion); and the constrained
//! least-squares solver behind trajectory optimization ([`least_squares`]:
//! augmented Lagrangian around Levenberg-Marquardt on the block-banded
//! normal equations, factorised by [`banded`]); the small dense QPs and
//! SOCPs of per-tick shared control ([`conic`], over Clarabel, with OSQP as
//! a cross-check behind the `osqp` feature) and the allocation-free dense
//! arithmetic around them ([`small`]).
//!
//! ```
//! use tandem_solvers::finite_diff::central_jacobian;
//! // f(x) = [x0 * x1, sin(x0)]
//! let f = |x: &[f64], out: &mut [f64]| {
//!     out[0] = x[0] * x[1];
//!     out[1] = x[0].sin();
//! };
//! let mut jac = vec![0.0; 4];
//! central_jacobian(f, &[1.0, 2.0], 2, 1e-6, &mut jac);
//! // column-major: d out / d x0 = [2, cos 1], d out / d x1 = [1, 0]
//! assert!((jac[0] - 2.0).abs() < 1e-8 && (jac[1] - 1f64.cos()).abs() < 1e-8);
//! assert!((jac[2] - 1.0).abs() < 1e-8 && jac[3].abs() < 1e-8);
//! ```

pub mod banded;
pub mod conic;
pub mod finite_diff;
pub mod least_squares;
pub mod riccati;
pub mod small;
