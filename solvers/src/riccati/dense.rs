//! Column-major dense kernels on preallocated nalgebra storage.
//!
//! Products go straight to `matrixmultiply` (nalgebra's own backend for
//! dynamic matrices, with runtime-dispatched AVX2/AVX-512 kernels), which
//! reads transposed operands through their strides without copying;
//! factorisations are written here because nalgebra's allocate on every call
//! and are several times slower at the sizes that matter (n ≤ 30). Every
//! routine works in place on caller-owned buffers, so the Riccati hot loop
//! never allocates.

use nalgebra::DMatrix;

/// A read-only operand of [`gemm`]: a matrix, its transpose, or a block of
/// its columns, described by strides into column-major storage.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Op<'a> {
    data: &'a [f64],
    rows: usize,
    cols: usize,
    row_stride: usize,
    col_stride: usize,
}

impl<'a> Op<'a> {
    /// `m` as it is.
    pub(crate) fn n(m: &'a DMatrix<f64>) -> Self {
        Op { data: m.as_slice(), rows: m.nrows(), cols: m.ncols(), row_stride: 1, col_stride: m.nrows() }
    }

    /// `mᵀ`, read in place.
    pub(crate) fn t(m: &'a DMatrix<f64>) -> Self {
        Op::n(m).transposed()
    }

    /// Rows `start .. start + count` of `m`.
    pub(crate) fn rows(m: &'a DMatrix<f64>, start: usize, count: usize) -> Self {
        Op { data: &m.as_slice()[start..], rows: count, cols: m.ncols(), row_stride: 1, col_stride: m.nrows() }
    }

    /// The transpose of this operand.
    pub(crate) fn transposed(self) -> Self {
        Op { rows: self.cols, cols: self.rows, row_stride: self.col_stride, col_stride: self.row_stride, ..self }
    }

    /// Whether every addressed element lies inside `data`.
    fn in_bounds(&self) -> bool {
        self.rows == 0
            || self.cols == 0
            || (self.rows - 1) * self.row_stride + (self.cols - 1) * self.col_stride < self.data.len()
    }
}

/// Products with at most this many multiply-adds run as plain loops: below
/// it, matrixmultiply's packing and per-call buffer allocation cost more
/// than the arithmetic.
const SMALL_GEMM: usize = 512;

/// `c ← alpha·a·b + beta·c`; `c` is not read when `beta` is zero.
///
/// # Panics
/// If the shapes do not agree (a programming error inside this crate).
pub(crate) fn gemm(c: &mut DMatrix<f64>, alpha: f64, a: Op<'_>, b: Op<'_>, beta: f64) {
    let (rows, cols) = c.shape();
    gemm_block(c.as_mut_slice(), rows, rows, cols, alpha, a, b, beta);
}

/// [`gemm`] into rows `first .. first + a.rows` of `c`, all columns.
pub(crate) fn gemm_rows(c: &mut DMatrix<f64>, first: usize, alpha: f64, a: Op<'_>, b: Op<'_>, beta: f64) {
    let (ld, cols) = c.shape();
    assert!(first + a.rows <= ld, "gemm_rows: block outside the matrix");
    gemm_block(&mut c.as_mut_slice()[first..], ld, a.rows, cols, alpha, a, b, beta);
}

/// `c ← alpha·a·b + beta·c` for the `m × n` block of `c` with column stride `ld`.
#[allow(clippy::too_many_arguments)] // a BLAS-style signature reads best here
fn gemm_block(c: &mut [f64], ld: usize, m: usize, n: usize, alpha: f64, a: Op<'_>, b: Op<'_>, beta: f64) {
    assert!(a.rows == m && b.cols == n && a.cols == b.rows, "gemm: shapes do not agree");
    assert!(a.in_bounds() && b.in_bounds(), "gemm: operand outside its storage");
    if m == 0 || n == 0 {
        return;
    }
    assert!(ld >= m && (n - 1) * ld + m <= c.len(), "gemm: output outside its storage");
    let k = a.cols;
    if m * n * k <= SMALL_GEMM {
        for j in 0..n {
            for i in 0..m {
                let dot: f64 = (0..k)
                    .map(|l| a.data[i * a.row_stride + l * a.col_stride] * b.data[l * b.row_stride + j * b.col_stride])
                    .sum();
                let dst = &mut c[j * ld + i];
                *dst = if beta == 0.0 { alpha * dot } else { alpha * dot + beta * *dst };
            }
        }
        return;
    }
    // SAFETY: the assertions above keep every element matrixmultiply reads
    // (a, b: rows × cols at the given strides) inside its slice and every
    // element it writes (m × n at column stride ld ≥ m, so no two alias)
    // inside `c`, a unique borrow that cannot overlap `a` or `b`.
    unsafe {
        matrixmultiply::dgemm(
            m,
            k,
            n,
            alpha,
            a.data.as_ptr(),
            a.row_stride as isize,
            a.col_stride as isize,
            b.data.as_ptr(),
            b.row_stride as isize,
            b.col_stride as isize,
            beta,
            c.as_mut_ptr(),
            1,
            ld as isize,
        );
    }
}

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

    #[test]
    fn gemm_handles_transposes_and_row_blocks() {
        for (r, k, c) in [(7, 6, 8), (9, 12, 10), (2, 1, 3), (1, 1, 1)] {
            let a = DMatrix::from_fn(k, r, |i, j| (i * 6 + j) as f64);
            let b = DMatrix::from_fn(k + 2, c, |i, j| (i + j) as f64 * 0.1);
            let mut out = DMatrix::from_element(r, c, 1.0);
            let b_top = b.rows(0, k).into_owned();
            gemm(&mut out, 2.0, Op::t(&a), Op::n(&b_top), 0.5);
            let want = a.transpose() * &b_top * 2.0 + DMatrix::from_element(r, c, 0.5);
            assert!((out - want).norm() < 1e-10);
            let tall = DMatrix::from_fn(3 * r, c, |i, j| (i * j) as f64 - 1.0);
            let block = tall.rows(r, r).into_owned();
            let mut out = DMatrix::zeros(c, c);
            gemm(&mut out, 1.0, Op::rows(&tall, r, r).transposed(), Op::n(&block), 0.0);
            assert!((out - block.transpose() * &block).norm() < 1e-10);
            let mut tall_out = DMatrix::from_element(r + c + 1, c, 3.0);
            gemm_rows(&mut tall_out, 1, 1.0, Op::n(&block).transposed(), Op::n(&block), 0.0);
            assert!((tall_out.rows(1, c) - block.transpose() * &block).norm() < 1e-10);
            assert!(tall_out.row(0).iter().chain(tall_out.rows(c + 1, r).iter()).all(|&v| v == 3.0));
        }
    }
}
