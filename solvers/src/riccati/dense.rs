//! Column-major dense kernels on preallocated nalgebra storage.
//!
//! Factorisations are written here because nalgebra's allocate on every
//! call and are several times slower at the sizes that matter (n ≤ 30);
//! products are in [`super::gemm`]. Every routine works in place on
//! caller-owned buffers, so the Riccati hot loop never allocates.

pub(crate) use super::gemm::{Op, gemm, gemm_rows};
use nalgebra::DMatrix;

/// The factor was not positive definite at this pivot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NotPositiveDefinite;

/// A pivot of Gaussian elimination was zero or not finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Singular;

/// Adds `shift` to the diagonal.
pub(crate) fn add_diagonal(m: &mut DMatrix<f64>, shift: f64) {
    for i in 0..m.nrows().min(m.ncols()) {
        m[(i, i)] += shift;
    }
}

/// Replaces `m` by `(m + mᵀ) / 2`, removing the rounding drift that would
/// otherwise accumulate in iterates that are symmetric in exact arithmetic.
pub(crate) fn symmetrize(m: &mut DMatrix<f64>) {
    let n = m.nrows();
    let d = m.as_mut_slice();
    for j in 0..n {
        for i in j + 1..n {
            let v = 0.5 * (d[j * n + i] + d[i * n + j]);
            d[j * n + i] = v;
            d[i * n + j] = v;
        }
    }
}

/// `h ← h + d`; returns `(‖d‖_F, ‖h‖_F)` after the update.
///
/// The doubling iterates are symmetric in exact arithmetic; their rounding
/// asymmetry stays at the ε level over the few iterations the method takes,
/// so they are not symmetrised here (a strided pass that cost 10% of a
/// solve) — only the final `P` is.
pub(crate) fn add_assign_with_norms(h: &mut DMatrix<f64>, d: &DMatrix<f64>) -> (f64, f64) {
    for (x, v) in h.as_mut_slice().iter_mut().zip(d.as_slice()) {
        *x += v;
    }
    (frobenius(d.as_slice()), frobenius(h.as_slice()))
}

/// `‖m‖_F` over a slice, with eight partial sums so the additions do not
/// wait on each other (a single running sum is latency-bound).
pub(crate) fn frobenius(m: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let chunks = m.chunks_exact(8);
    let rest: f64 = chunks.remainder().iter().map(|v| v * v).sum();
    for c in chunks {
        for (a, v) in acc.iter_mut().zip(c) {
            *a += v * v;
        }
    }
    (acc.iter().sum::<f64>() + rest).sqrt()
}

/// `‖m − mᵀ‖_F`.
pub(crate) fn asymmetry(m: &DMatrix<f64>) -> f64 {
    let n = m.nrows();
    let mut sum = 0.0;
    for j in 0..n {
        for i in j + 1..n {
            let d = m[(i, j)] - m[(j, i)];
            sum += 2.0 * d * d;
        }
    }
    sum.sqrt()
}

/// Copies `src` transposed into `dst` (`dst` must be `src.ncols() × src.nrows()`).
pub(crate) fn transpose_into(src: &DMatrix<f64>, dst: &mut DMatrix<f64>) {
    debug_assert_eq!(dst.shape(), (src.ncols(), src.nrows()));
    for j in 0..src.ncols() {
        for i in 0..src.nrows() {
            dst[(j, i)] = src[(i, j)];
        }
    }
}

/// Solves `W·X = R` by Gaussian elimination with partial pivoting, on the
/// augmented system stored transposed: column `i` of `aug` (length `n + r`)
/// is row `i` of `[W | R]` on entry, and holds row `i` of `X` in its last
/// `r` entries on exit (the first `n` are overwritten).
///
/// With rows contiguous, every elimination step is an axpy over a whole
/// row of the augmented matrix instead of over the ever shorter tail of a
/// column, which is what makes this fast for few unknowns and many
/// right-hand sides.
pub(crate) fn solve_augmented(aug: &mut DMatrix<f64>, n: usize) -> Result<(), Singular> {
    // The row operations are long independent axpys: compiled for AVX-512 or
    // AVX2 they run 4–8 lanes wide instead of SSE2's 2, with identical
    // results (no reductions, no fused multiply-adds).
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { solve_augmented_avx512(aug, n) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { solve_augmented_avx2(aug, n) };
        }
    }
    solve_augmented_body(aug, n)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn solve_augmented_avx512(aug: &mut DMatrix<f64>, n: usize) -> Result<(), Singular> {
    solve_augmented_body(aug, n)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve_augmented_avx2(aug: &mut DMatrix<f64>, n: usize) -> Result<(), Singular> {
    solve_augmented_body(aug, n)
}

#[inline(always)]
fn solve_augmented_body(aug: &mut DMatrix<f64>, n: usize) -> Result<(), Singular> {
    let len = aug.nrows();
    debug_assert_eq!(aug.ncols(), n);
    debug_assert!(len >= n);
    let d = aug.as_mut_slice();
    for k in 0..n {
        let mut p = k;
        let mut best = d[k * len + k].abs();
        for i in k + 1..n {
            let v = d[i * len + k].abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        if !(best > 0.0 && best.is_finite()) {
            return Err(Singular);
        }
        if p != k {
            let (head, tail) = d.split_at_mut(p * len);
            head[k * len..(k + 1) * len].swap_with_slice(&mut tail[..len]);
        }
        let (head, tail) = d.split_at_mut((k + 1) * len);
        let pivot_row = &head[k * len..];
        let inv = 1.0 / pivot_row[k];
        for row in tail.chunks_exact_mut(len) {
            let l = row[k] * inv;
            if l != 0.0 {
                for (x, v) in row[k + 1..].iter_mut().zip(&pivot_row[k + 1..]) {
                    *x -= l * v;
                }
            }
        }
    }
    for k in (0..n).rev() {
        let (head, tail) = d.split_at_mut(k * len);
        let row_k = &mut tail[..len];
        let ukk = row_k[k];
        for v in &mut row_k[n..] {
            *v /= ukk;
        }
        let x_k = &row_k[n..];
        for row in head.chunks_exact_mut(len) {
            let u = row[k];
            if u != 0.0 {
                for (x, v) in row[n..].iter_mut().zip(x_k) {
                    *x -= u * v;
                }
            }
        }
    }
    Ok(())
}

/// In-place Cholesky factorisation `m = L·Lᵀ` (lower triangle; the strict
/// upper triangle is left untouched). Fails unless every pivot exceeds
/// `min_pivot`, so a matrix that is only semidefinite in floating point is
/// rejected instead of producing a huge, meaningless factor.
pub(crate) fn cholesky(m: &mut DMatrix<f64>, min_pivot: f64) -> Result<(), NotPositiveDefinite> {
    let n = m.nrows();
    debug_assert_eq!(m.ncols(), n);
    let d = m.as_mut_slice();
    for k in 0..n {
        let (left, right) = d.split_at_mut((k + 1) * n);
        let colk = &mut left[k * n..];
        let pivot = colk[k];
        if !(pivot > min_pivot && pivot.is_finite()) {
            return Err(NotPositiveDefinite);
        }
        let l = pivot.sqrt();
        colk[k] = l;
        let inv = 1.0 / l;
        for v in &mut colk[k + 1..] {
            *v *= inv;
        }
        for (j, colj) in right.chunks_exact_mut(n).enumerate() {
            let row = k + 1 + j;
            let f = colk[row];
            if f != 0.0 {
                for (x, l) in colj[row..].iter_mut().zip(&colk[row..]) {
                    *x -= l * f;
                }
            }
        }
    }
    Ok(())
}

/// Solves `L·X = rhs` in place (forward substitution), `L` from `cholesky`.
pub(crate) fn forward_solve(l: &DMatrix<f64>, rhs: &mut DMatrix<f64>) {
    let n = l.nrows();
    let f = l.as_slice();
    for x in rhs.as_mut_slice().chunks_exact_mut(n) {
        for k in 0..n {
            x[k] /= f[k * n + k];
            let xk = x[k];
            if xk != 0.0 {
                for (xi, l) in x[k + 1..].iter_mut().zip(&f[k * n + k + 1..(k + 1) * n]) {
                    *xi -= l * xk;
                }
            }
        }
    }
}

/// Solves `Lᵀ·X = rhs` in place (back substitution), `L` from `cholesky`.
pub(crate) fn backward_solve(l: &DMatrix<f64>, rhs: &mut DMatrix<f64>) {
    let n = l.nrows();
    let f = l.as_slice();
    for x in rhs.as_mut_slice().chunks_exact_mut(n) {
        for k in (0..n).rev() {
            let colk = &f[k * n + k + 1..(k + 1) * n];
            let dot: f64 = colk.iter().zip(&x[k + 1..]).map(|(a, b)| a * b).sum();
            x[k] = (x[k] - dot) / f[k * n + k];
        }
    }
}

/// Solves `L·Lᵀ·X = rhs` in place.
pub(crate) fn cholesky_solve(l: &DMatrix<f64>, rhs: &mut DMatrix<f64>) {
    forward_solve(l, rhs);
    backward_solve(l, rhs);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_matrix(n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 5) as f64 - 2.0 + if i == j { 0.5 } else { 0.0 })
    }

    #[test]
    fn augmented_elimination_solves() {
        let a = test_matrix(6);
        let x = DMatrix::from_fn(6, 3, |i, j| (i + 2 * j) as f64 * 0.3 - 1.0);
        let mut aug = DMatrix::zeros(9, 6);
        aug.rows_mut(0, 6).copy_from(&a.transpose());
        aug.rows_mut(6, 3).copy_from(&(&a * &x).transpose());
        solve_augmented(&mut aug, 6).expect("nonsingular");
        assert!((aug.rows(6, 3).transpose() - x).norm() < 1e-12);
    }

    #[test]
    fn augmented_elimination_rejects_singular() {
        let mut aug = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 2.0, 4.0, 1.0, 1.0]);
        assert_eq!(solve_augmented(&mut aug, 2), Err(Singular));
    }

    #[test]
    fn cholesky_solves_and_rejects() {
        let c = test_matrix(5);
        let spd = c.transpose() * &c + DMatrix::identity(5, 5);
        let x = DMatrix::from_fn(5, 2, |i, j| i as f64 - j as f64);
        let mut rhs = &spd * &x;
        let mut l = spd.clone();
        cholesky(&mut l, 0.0).expect("positive definite");
        cholesky_solve(&l, &mut rhs);
        assert!((rhs - x).norm() < 1e-12);
        let mut indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert_eq!(cholesky(&mut indefinite, 0.0), Err(NotPositiveDefinite));
    }
}
