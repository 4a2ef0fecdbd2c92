//! Symmetric banded matrices and their in-place Cholesky factorisation.
//!
//! The normal equations `JᵀJ + λI` of a k-order trajectory problem couple
//! only configurations at most k slices apart, so with `n` variables per
//! slice every row of the matrix has nonzeros within `(k + 1)·n − 1`
//! columns of the diagonal. A dedicated band factorisation costs
//! `O(N·b²)` for `N` unknowns and half bandwidth `b` and allocates nothing;
//! each row's band is contiguous, so the row updates vectorise — on
//! AVX2 machines 4 lanes wide instead of SSE2's 2, with identical results
//! (the same operations in the same order, no fused multiply-adds).
//!
//! ```
//! use tandem_solvers::banded::SymmetricBand;
//! // The 1-D Laplacian plus identity: tridiagonal (half bandwidth 1).
//! let n = 5;
//! let mut a = SymmetricBand::zeros(n, 1);
//! for i in 0..n {
//!     a.add(i, i, 3.0);
//!     if i > 0 {
//!         a.add(i, i - 1, -1.0);
//!     }
//! }
//! let mut x = vec![1.0; n];
//! a.factorize().expect("positive definite");
//! a.solve_in_place(&mut x);
//! // Check A x = 1 on the middle row: -x1 + 3 x2 - x3 = 1.
//! assert!((-x[1] + 3.0 * x[2] - x[3] - 1.0).abs() < 1e-12);
//! ```

use thiserror::Error;

/// The matrix is not (numerically) positive definite.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[error("matrix is not positive definite: pivot {pivot} is {value:e}")]
pub struct NotPositiveDefinite {
    /// Row whose pivot was not positive.
    pub pivot: usize,
    /// The pivot's value before the square root.
    pub value: f64,
}

/// A symmetric `n × n` matrix with `A[i][j] = 0` for `|i − j| > b`, storing
/// its upper band row by row (row `i`: columns `i ..= i + b`). After
/// [`factorize`](Self::factorize) the same storage holds the Cholesky
/// factor `U = Lᵀ` (`A = Uᵀ U = L Lᵀ`), row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetricBand {
    n: usize,
    bandwidth: usize,
    /// Row `i` holds columns `i ..= i + b` at `data[i(b+1) .. (i+1)(b+1)]`;
    /// columns past `n − 1` are zero padding.
    data: Vec<f64>,
}

impl SymmetricBand {
    /// The zero matrix of size `n` and half bandwidth `bandwidth`.
    pub fn zeros(n: usize, bandwidth: usize) -> SymmetricBand {
        SymmetricBand { n, bandwidth, data: vec![0.0; n * (bandwidth + 1)] }
    }

    /// Number of rows (and columns).
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Half bandwidth `b`: entries with `|i − j| > b` are zero.
    pub fn bandwidth(&self) -> usize {
        self.bandwidth
    }

    /// Sets every entry to zero, keeping the storage.
    pub fn clear(&mut self) {
        self.data.fill(0.0);
    }

    /// Storage index of `A[i][j]`, `i ≤ j ≤ i + b`.
    #[inline]
    fn index(&self, i: usize, j: usize) -> usize {
        debug_assert!(i <= j && j - i <= self.bandwidth && j < self.n);
        i * (self.bandwidth + 1) + j - i
    }

    /// `A[i][j]` (zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if j < i { (j, i) } else { (i, j) };
        if j - i > self.bandwidth { 0.0 } else { self.data[self.index(i, j)] }
    }

    /// Adds `v` to `A[i][j]` (and so to `A[j][i]`).
    ///
    /// # Panics
    /// If `(i, j)` is outside the matrix or the band.
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if j < i { (j, i) } else { (i, j) };
        assert!(j < self.n && j - i <= self.bandwidth, "entry ({i}, {j}) outside the band");
        let k = self.index(i, j);
        self.data[k] += v;
    }

    /// Copies `other` (of the same size and band) into `self` without
    /// allocating.
    ///
    /// # Panics
    /// If the sizes or bands differ.
    pub fn copy_from(&mut self, other: &SymmetricBand) {
        self.copy_rows_from(other, 0);
    }

    /// Copies rows `from ..` of `other` (of the same size and band) into
    /// `self` without allocating; rows before `from` keep their values.
    ///
    /// # Panics
    /// If the sizes or bands differ, or `from > n`.
    pub fn copy_rows_from(&mut self, other: &SymmetricBand, from: usize) {
        assert!(self.n == other.n && self.bandwidth == other.bandwidth, "band shapes differ");
        let start = from * (self.bandwidth + 1);
        self.data[start..].copy_from_slice(&other.data[start..]);
    }

    /// Adds `v` to every diagonal entry.
    pub fn add_to_diagonal(&mut self, v: f64) {
        self.add_to_diagonal_from(v, 0);
    }

    /// Adds `v` to the diagonal entries of rows `from ..`.
    pub fn add_to_diagonal_from(&mut self, v: f64, from: usize) {
        let stride = self.bandwidth + 1;
        for d in self.data.iter_mut().skip(from * stride).step_by(stride) {
            *d += v;
        }
    }

    /// The largest diagonal entry (0 for an empty matrix).
    pub fn max_diagonal(&self) -> f64 {
        self.data.iter().step_by(self.bandwidth + 1).fold(0.0, |m, &d| m.max(d))
    }

    /// Adds `w · v vᵀ` on the block starting at row and column `first`.
    ///
    /// # Panics
    /// If the block leaves the matrix or `v` is wider than the band.
    pub fn add_outer(&mut self, first: usize, v: &[f64], w: f64) {
        assert!(v.len() <= self.bandwidth + 1, "row of width {} exceeds band {}", v.len(), self.bandwidth);
        assert!(first + v.len() <= self.n, "block leaves the matrix");
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { self.add_outer_avx2(first, v, w) };
        }
        self.add_outer_body(first, v, w);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_outer_avx2(&mut self, first: usize, v: &[f64], w: f64) {
        self.add_outer_body(first, v, w);
    }

    #[inline(always)]
    fn add_outer_body(&mut self, first: usize, v: &[f64], w: f64) {
        for (a, &va) in v.iter().enumerate() {
            // Rows of k-order differences are mostly zeros (one entry per
            // slice per joint): their rows of v vᵀ add nothing.
            if va == 0.0 {
                continue;
            }
            let row = self.index(first + a, first + a);
            let wa = w * va;
            for (dst, &vb) in self.data[row..row + v.len() - a].iter_mut().zip(&v[a..]) {
                *dst += wa * vb;
            }
        }
    }

    /// `y = A x`.
    ///
    /// # Panics
    /// If `x` or `y` do not have `n` entries.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        assert!(x.len() == self.n && y.len() == self.n);
        y.fill(0.0);
        let stride = self.bandwidth + 1;
        for i in 0..self.n {
            let width = stride.min(self.n - i);
            let row = &self.data[i * stride..i * stride + width];
            y[i] += row[0] * x[i];
            for m in 1..width {
                y[i] += row[m] * x[i + m];
                y[i + m] += row[m] * x[i];
            }
        }
    }

    /// Replaces the matrix by its Cholesky factor (`A = Uᵀ U`).
    ///
    /// Right-looking, row by row: row `k` of `U` is row `k` of what is left
    /// of `A` divided by the square root of its pivot, and it is then
    /// eliminated from the rows below, each update one contiguous segment
    /// of a row minus a multiple of a segment of row `k` (which
    /// vectorises). Updates by a zero entry of `U` (most of a trajectory's
    /// first joints, whose rows reach less far) are skipped.
    ///
    /// # Errors
    /// [`NotPositiveDefinite`] when a pivot is not positive and finite; the
    /// storage then holds a partial factor.
    pub fn factorize(&mut self) -> Result<(), NotPositiveDefinite> {
        self.factorize_from(0)
    }

    /// [`factorize`](Self::factorize) of a matrix whose rows before `from`
    /// already hold the factor of a matrix that differs from this one only
    /// in rows (and columns) `from ..` — as after a factorisation followed
    /// by [`copy_rows_from`](Self::copy_rows_from) of the changed matrix:
    /// those rows are kept, the eliminations of the last `b` of them are
    /// replayed on the fresh rows, and the rest is factorised, with the
    /// same result, bit for bit, as a full factorisation.
    ///
    /// # Errors
    /// As [`factorize`](Self::factorize).
    pub fn factorize_from(&mut self, from: usize) -> Result<(), NotPositiveDefinite> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { self.factorize_avx2(from) };
        }
        self.factorize_body(from)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn factorize_avx2(&mut self, from: usize) -> Result<(), NotPositiveDefinite> {
        self.factorize_body(from)
    }

    #[inline(always)]
    fn factorize_body(&mut self, from: usize) -> Result<(), NotPositiveDefinite> {
        // Rows before `from` were eliminated from rows `.. from` only.
        for k in from.saturating_sub(self.bandwidth)..from {
            self.eliminate(k, from);
        }
        let stride = self.bandwidth + 1;
        for k in from..self.n {
            let row = &mut self.data[k * stride..(k + 1) * stride];
            let pivot = row[0];
            if !(pivot > 0.0 && pivot.is_finite()) {
                return Err(NotPositiveDefinite { pivot: k, value: pivot });
            }
            let diagonal = pivot.sqrt();
            row[0] = diagonal;
            for u in &mut row[1..] {
                *u /= diagonal;
            }
            self.eliminate(k, k + 1);
        }
        Ok(())
    }

    /// Subtracts `U[k][j] · U[k][j ..]` from every row `j ≥ rows_from`
    /// within the band below row `k` (which holds `U`'s row).
    #[inline(always)]
    fn eliminate(&mut self, k: usize, rows_from: usize) {
        let (b, stride) = (self.bandwidth, self.bandwidth + 1);
        let (head, tail) = self.data.split_at_mut((k + 1) * stride);
        let u = &head[k * stride..];
        for m in rows_from.max(k + 1) - k..=b.min(self.n - 1 - k) {
            let factor = u[m];
            if factor == 0.0 {
                continue;
            }
            let row = &mut tail[(m - 1) * stride..(m - 1) * stride + stride - m];
            for (a, &x) in row.iter_mut().zip(&u[m..]) {
                *a -= factor * x;
            }
        }
    }

    /// Solves `A x = rhs` in place, after [`factorize`](Self::factorize).
    ///
    /// # Panics
    /// If `rhs` does not have `n` entries.
    pub fn solve_in_place(&self, rhs: &mut [f64]) {
        assert_eq!(rhs.len(), self.n);
        let stride = self.bandwidth + 1;
        // Uᵀ y = rhs, column by column: once y_k is known, remove its
        // contribution from the entries below.
        for k in 0..self.n {
            let width = stride.min(self.n - k);
            let row = &self.data[k * stride..k * stride + width];
            rhs[k] /= row[0];
            let yk = rhs[k];
            for (r, u) in rhs[k + 1..k + width].iter_mut().zip(&row[1..]) {
                *r -= u * yk;
            }
        }
        // U x = y, from the bottom: one dot product per row.
        for k in (0..self.n).rev() {
            let width = stride.min(self.n - k);
            let row = &self.data[k * stride..k * stride + width];
            rhs[k] = (rhs[k] - dot(&row[1..], &rhs[k + 1..k + width])) / row[0];
        }
    }
}

/// `a · b` with four independent accumulators, so the compiler can keep
/// several multiply-adds in flight (a single running sum is a serial chain).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    let mut acc = [0.0; 4];
    for (x, y) in a4.zip(b4) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_band(n: usize, b: usize, rng: &mut ChaCha8Rng) -> (SymmetricBand, DMatrix<f64>) {
        let mut band = SymmetricBand::zeros(n, b);
        // Sum of outer products of random rows (like JᵀJ), plus a ridge.
        for _ in 0..3 * n {
            let width = rng.random_range(1..=(b + 1).min(n));
            let first = rng.random_range(0..=n - width);
            let v: Vec<f64> = (0..width).map(|_| rng.random_range(-1.0..1.0)).collect();
            band.add_outer(first, &v, rng.random_range(0.1..2.0));
        }
        band.add_to_diagonal(1e-3);
        let dense = DMatrix::from_fn(n, n, |i, j| band.get(i, j));
        (band, dense)
    }

    #[test]
    fn solves_like_dense_cholesky() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for &(n, b) in &[(1, 0), (5, 0), (10, 1), (40, 6), (140, 20), (21, 25)] {
            let (mut band, dense) = random_band(n, b, &mut rng);
            let rhs = DVector::from_fn(n, |_, _| rng.random_range(-1.0..1.0));
            let mut y = vec![0.0; n];
            band.mul_vec(rhs.as_slice(), &mut y);
            let dense_y = &dense * &rhs;
            for i in 0..n {
                assert!((y[i] - dense_y[i]).abs() < 1e-12, "mul_vec row {i}");
            }
            let expected = dense.clone().cholesky().expect("pd").solve(&rhs);
            let mut x = rhs.as_slice().to_vec();
            band.factorize().expect("pd");
            band.solve_in_place(&mut x);
            let scale = expected.amax().max(1.0);
            for i in 0..n {
                assert!((x[i] - expected[i]).abs() < 1e-9 * scale, "n={n} b={b} x[{i}]: {} vs {}", x[i], expected[i]);
            }
        }
    }

    #[test]
    fn refactorising_changed_rows_matches_a_full_factorisation() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for &(n, b, from) in &[(40, 6, 0), (40, 6, 17), (140, 20, 90), (30, 5, 29)] {
            let (mut changed, _) = random_band(n, b, &mut rng);
            let mut factor = changed.clone();
            factor.factorize().expect("pd");
            let v: Vec<f64> = (0..(b + 1).min(n - from)).map(|_| rng.random_range(-1.0..1.0)).collect();
            changed.add_outer(from, &v, 0.7);
            factor.copy_rows_from(&changed, from);
            factor.factorize_from(from).expect("pd");
            changed.factorize().expect("pd");
            assert_eq!(factor, changed, "n={n} b={b} from={from}");
        }
    }

    #[test]
    fn rejects_indefinite_matrices() {
        let mut a = SymmetricBand::zeros(3, 1);
        a.add(0, 0, 1.0);
        a.add(1, 0, 2.0);
        a.add(1, 1, 1.0);
        a.add(2, 2, 1.0);
        let err = a.factorize().unwrap_err();
        assert_eq!(err.pivot, 1);
        assert!(err.value < 0.0);
        let mut nan = SymmetricBand::zeros(2, 1);
        nan.add(0, 0, f64::NAN);
        assert_eq!(nan.factorize().unwrap_err().pivot, 0);
    }

    #[test]
    #[should_panic(expected = "exceeds band")]
    fn refuses_rows_wider_than_the_band() {
        SymmetricBand::zeros(5, 1).add_outer(0, &[1.0, 1.0, 1.0], 1.0);
    }
}
