//! Input checks shared by the DARE and the finite-horizon recursion: each
//! names the offending matrix, so a caller's mistake gets a precise error.

use super::RiccatiError;
use super::dense::{asymmetry, symmetrize};
use nalgebra::{DMatrix, DMatrixView};

/// Fails unless `m` is `rows × cols`.
pub(super) fn shape(
    matrix: &'static str,
    m: &DMatrixView<'_, f64>,
    rows: usize,
    cols: usize,
) -> Result<(), RiccatiError> {
    if m.shape() == (rows, cols) {
        Ok(())
    } else {
        Err(RiccatiError::DimensionMismatch { matrix, expected: (rows, cols), found: m.shape() })
    }
}

/// Fails on the first NaN or infinite entry (column-major order).
pub(super) fn finite(matrix: &'static str, m: &DMatrixView<'_, f64>) -> Result<(), RiccatiError> {
    // v·0 is 0 for every finite v and NaN otherwise: one vectorisable pass
    // in the common case, the search below only for the error.
    if m.column_iter().all(|c| c.iter().fold(0.0, |acc, v| acc + v * 0.0) == 0.0) {
        return Ok(());
    }
    for (col, column) in m.column_iter().enumerate() {
        if let Some((row, &value)) = column.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(RiccatiError::NonFinite { matrix, row, col, value });
        }
    }
    Ok(())
}

/// Checks `m` is symmetric to `tolerance` (relative Frobenius), then removes
/// the remaining asymmetry so later steps see an exactly symmetric matrix.
pub(super) fn symmetric(matrix: &'static str, m: &mut DMatrix<f64>, tolerance: f64) -> Result<(), RiccatiError> {
    let asym = asymmetry(m);
    if asym > tolerance * m.norm() {
        return Err(RiccatiError::NotSymmetric { matrix, relative_asymmetry: asym / m.norm() });
    }
    symmetrize(m);
    Ok(())
}

/// Copies a view into an equally shaped buffer.
pub(super) fn copy_into(dst: &mut DMatrix<f64>, src: &DMatrixView<'_, f64>) {
    debug_assert_eq!(dst.shape(), src.shape());
    dst.copy_from(src);
}
