//! Central finite differences of vector-valued functions.
//!
//! The reference every analytic Jacobian in tandem is checked against. The
//! truncation error of a central difference is O(h²) and its rounding error
//! O(ε/h), so `h ≈ 1e-6` gives about 1e-9 absolute accuracy for well-scaled
//! functions of order one.

/// Central-difference Jacobian of `f: Rⁿ → Rᵐ` at `x`.
///
/// `f(x, out)` writes `m` values into `out`. The result is written
/// column-major into `jac` (`m × n`, column `j` holds `∂f/∂x_j`), so it maps
/// directly onto an nalgebra or faer column-major matrix.
///
/// # Panics
/// If `jac.len() != m * x.len()` or `h` is not positive and finite: these are
/// programming errors of the caller, not data errors.
pub fn central_jacobian<F>(mut f: F, x: &[f64], m: usize, h: f64, jac: &mut [f64])
where
    F: FnMut(&[f64], &mut [f64]),
{
    let n = x.len();
    assert_eq!(jac.len(), m * n, "jacobian buffer must hold m * n values");
    assert!(h.is_finite() && h > 0.0, "step must be positive and finite");
    let mut xp = x.to_vec();
    let mut plus = vec![0.0; m];
    let mut minus = vec![0.0; m];
    for j in 0..n {
        xp[j] = x[j] + h;
        f(&xp, &mut plus);
        xp[j] = x[j] - h;
        f(&xp, &mut minus);
        xp[j] = x[j];
        for i in 0..m {
            jac[j * m + i] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_quadratics() {
        // Central differences are exact (up to rounding) on quadratics.
        let f = |x: &[f64], out: &mut [f64]| {
            out[0] = x[0] * x[0] + 3.0 * x[1];
            out[1] = x[0] * x[1];
            out[2] = -x[1] * x[1];
        };
        let x = [0.7, -1.3];
        let mut jac = vec![0.0; 6];
        central_jacobian(f, &x, 3, 1e-4, &mut jac);
        let expected = [2.0 * 0.7, -1.3, 0.0, 3.0, 0.7, 2.6];
        for (a, b) in jac.iter().zip(expected) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }
}
