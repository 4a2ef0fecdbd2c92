//! Dense products `c ← α·a·b + β·c` on column-major storage, for the small
//! matrices of the Riccati solvers.
//!
//! matrixmultiply (nalgebra's backend) allocates a packing buffer on every
//! call and masks most of its 8×4 kernel on a 14×14 product, which made it
//! the larger half of a DARE solve; the register-blocked AVX2/FMA kernels
//! here read the operands in place and allocate nothing. matrixmultiply is
//! kept for products beyond [`LARGE_GEMM`] (where packing pays) and for
//! CPUs without AVX2 and FMA.

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

/// Products with at most this many multiply-adds run as plain loops when
/// the AVX2 kernels do not apply: below it, matrixmultiply's packing and
/// per-call buffer allocation cost more than the arithmetic.
const SMALL_GEMM: usize = 512;

/// Products with more multiply-adds than this go to matrixmultiply, whose
/// cache blocking wins once the operands outgrow L1 (about 64×64×64).
const LARGE_GEMM: usize = 64 * 64 * 64;

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
    if k == 0 {
        for j in 0..n {
            for v in &mut c[j * ld..j * ld + m] {
                *v = if beta == 0.0 { 0.0 } else { beta * *v };
            }
        }
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if m * n * k <= LARGE_GEMM && x86::available() {
        // SAFETY: AVX2 and FMA are present (checked above); the assertions
        // above keep every element the kernels address inside its slice
        // (they read `a` and `b` at their strides and write the m × n block
        // of `c` at column stride ld ≥ m).
        unsafe {
            if a.row_stride == 1 {
                return x86::gemm_columns(c, ld, m, n, alpha, a, b, beta);
            }
            if a.col_stride == 1 && b.row_stride == 1 {
                return x86::gemm_dots(c, ld, m, n, alpha, a, b, beta);
            }
        }
    }
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

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! Register-blocked kernels: 8 rows × 4 columns of `c` in twelve of the
    //! sixteen ymm registers when `a`'s columns are contiguous, 4 × 2 dot
    //! products when its rows are (a transposed operand). Edges use masked
    //! loads and stores; a missing column repeats the last one and its
    //! result is dropped, so every block runs the same straight-line code.

    use super::Op;
    use std::arch::x86_64::*;

    /// Whether the CPU has AVX2 and FMA (the detection is cached by std).
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }

    /// The mask of the first `lanes` (0..=4) of four.
    #[inline(always)]
    fn mask(lanes: usize) -> __m256i {
        let on = |i: usize| if i < lanes { -1 } else { 0 };
        // SAFETY: needs only AVX, which every caller's target features include.
        unsafe { _mm256_setr_epi64x(on(0), on(1), on(2), on(3)) }
    }

    /// Loads `lanes` (0..=4) values from `p`; masked lanes are not touched.
    #[inline(always)]
    unsafe fn load(p: *const f64, lanes: usize, mask: __m256i) -> __m256d {
        // SAFETY: the caller guarantees the first `lanes` elements are readable.
        unsafe { if lanes == 4 { _mm256_loadu_pd(p) } else { _mm256_maskload_pd(p, mask) } }
    }

    /// `p[..lanes] ← alpha·v + beta·p[..lanes]` (`p` not read when `beta` is zero).
    #[inline(always)]
    unsafe fn store(p: *mut f64, lanes: usize, mask: __m256i, v: __m256d, alpha: f64, beta: f64) {
        if lanes == 0 {
            return;
        }
        // SAFETY: the caller guarantees the first `lanes` elements are writable.
        unsafe {
            let mut v = _mm256_mul_pd(v, _mm256_set1_pd(alpha));
            if beta != 0.0 {
                v = _mm256_fmadd_pd(load(p, lanes, mask), _mm256_set1_pd(beta), v);
            }
            if lanes == 4 { _mm256_storeu_pd(p, v) } else { _mm256_maskstore_pd(p, mask, v) }
        }
    }

    /// `c ← alpha·a·b + beta·c` for `a` with unit row stride: each step of
    /// `l` is two column loads of `a`, four broadcasts of `b[l, ·]` and eight FMAs.
    ///
    /// # Safety
    /// AVX2 and FMA present; shapes and bounds as [`super::gemm_block`] asserts.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn gemm_columns(
        c: &mut [f64],
        ld: usize,
        m: usize,
        n: usize,
        alpha: f64,
        a: Op<'_>,
        b: Op<'_>,
        beta: f64,
    ) {
        let (k, lda, rsb, csb) = (a.cols, a.col_stride, b.row_stride, b.col_stride);
        let (ap, bp, cp) = (a.data.as_ptr(), b.data.as_ptr(), c.as_mut_ptr());
        for j0 in (0..n).step_by(4) {
            let last = (n - j0).min(4) - 1;
            let cols = [j0, j0 + last.min(1), j0 + last.min(2), j0 + last];
            for i0 in (0..m).step_by(8) {
                let (lo, hi) = ((m - i0).min(4), (m - i0).saturating_sub(4).min(4));
                let (mlo, mhi) = (mask(lo), mask(hi));
                let mut acc = [_mm256_setzero_pd(); 8];
                for l in 0..k {
                    // SAFETY: rows i0 .. i0 + lo + hi of column l of `a` and
                    // b[l, cols] are inside their slices (bounds asserted by
                    // the caller); masked lanes are not read.
                    unsafe {
                        let col = ap.add(i0 + l * lda);
                        let x0 = load(col, lo, mlo);
                        let x1 = load(col.wrapping_add(4), hi, mhi);
                        let row = bp.add(l * rsb);
                        for (jj, &j) in cols.iter().enumerate() {
                            let y = _mm256_set1_pd(*row.add(j * csb));
                            acc[jj] = _mm256_fmadd_pd(x0, y, acc[jj]);
                            acc[4 + jj] = _mm256_fmadd_pd(x1, y, acc[4 + jj]);
                        }
                    }
                }
                for jj in 0..=last {
                    // SAFETY: column j0 + jj, rows i0 .. i0 + lo + hi of the
                    // output block are inside `c`.
                    unsafe {
                        let dst = cp.add((j0 + jj) * ld + i0);
                        store(dst, lo, mlo, acc[jj], alpha, beta);
                        store(dst.wrapping_add(4), hi, mhi, acc[4 + jj], alpha, beta);
                    }
                }
            }
        }
    }

    /// The sum of the four lanes.
    #[inline(always)]
    fn horizontal_sum(v: __m256d) -> f64 {
        // SAFETY: needs only AVX, which every caller's target features include.
        unsafe {
            let pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
            _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)))
        }
    }

    /// `c ← alpha·a·b + beta·c` for `a` with unit column stride (rows of `a`
    /// contiguous) and `b` with unit row stride: 4 × 2 blocks of dot
    /// products, four lanes of `l` at a time.
    ///
    /// # Safety
    /// AVX2 and FMA present; shapes and bounds as [`super::gemm_block`] asserts.
    #[allow(clippy::too_many_arguments)]
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn gemm_dots(
        c: &mut [f64],
        ld: usize,
        m: usize,
        n: usize,
        alpha: f64,
        a: Op<'_>,
        b: Op<'_>,
        beta: f64,
    ) {
        let (k, rsa, csb) = (a.cols, a.row_stride, b.col_stride);
        let (ap, bp) = (a.data.as_ptr(), b.data.as_ptr());
        for j0 in (0..n).step_by(2) {
            let last_col = (n - j0).min(2) - 1;
            let cols = [j0, j0 + last_col];
            for i0 in (0..m).step_by(4) {
                let last_row = (m - i0).min(4) - 1;
                let rows = [i0, i0 + last_row.min(1), i0 + last_row.min(2), i0 + last_row];
                let mut acc = [_mm256_setzero_pd(); 8];
                for l in (0..k).step_by(4) {
                    let lanes = (k - l).min(4);
                    let lanes_mask = mask(lanes);
                    // SAFETY: entries l .. l + lanes of the addressed rows of
                    // `a` and columns of `b` are inside their slices.
                    unsafe {
                        let y0 = load(bp.add(cols[0] * csb + l), lanes, lanes_mask);
                        let y1 = load(bp.add(cols[1] * csb + l), lanes, lanes_mask);
                        for (r, &i) in rows.iter().enumerate() {
                            let x = load(ap.add(i * rsa + l), lanes, lanes_mask);
                            acc[2 * r] = _mm256_fmadd_pd(x, y0, acc[2 * r]);
                            acc[2 * r + 1] = _mm256_fmadd_pd(x, y1, acc[2 * r + 1]);
                        }
                    }
                }
                for jj in 0..=last_col {
                    for r in 0..=last_row {
                        let dot = horizontal_sum(acc[2 * r + jj]);
                        let dst = &mut c[(j0 + jj) * ld + i0 + r];
                        *dst = if beta == 0.0 { alpha * dot } else { alpha * dot + beta * *dst };
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn kernels_match_the_reference_at_every_edge() {
        // Every remainder of the 8 × 4 and 4 × 2 blocks and of the 4-lane dots.
        for (r, k, c) in [(14, 14, 14), (13, 7, 5), (9, 3, 6), (1, 1, 1), (30, 30, 30), (16, 17, 8)] {
            let a = DMatrix::from_fn(r, k, |i, j| ((i * 13 + j * 7) % 11) as f64 - 5.0);
            let at = a.transpose();
            let b = DMatrix::from_fn(k, c, |i, j| ((i * 5 + j * 3) % 7) as f64 * 0.25 - 0.5);
            let want = &a * &b * 1.5 - DMatrix::from_element(r, c, 2.0);
            for op in [Op::n(&a), Op::t(&at)] {
                let mut out = DMatrix::from_element(r, c, 4.0);
                gemm(&mut out, 1.5, op, Op::n(&b), -0.5);
                assert!((&out - &want).norm() <= 1e-12 * want.norm(), "{r}×{k}×{c}");
                let mut fresh = DMatrix::from_element(r, c, f64::NAN);
                gemm(&mut fresh, 1.5, op, Op::n(&b), 0.0);
                assert!((fresh - &a * &b * 1.5).norm() <= 1e-12 * want.norm(), "{r}×{k}×{c}, beta = 0");
            }
        }
    }
}
