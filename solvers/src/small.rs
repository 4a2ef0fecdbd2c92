//! Small dense linear algebra on caller-owned slices, allocation-free: the
//! per-tick arithmetic of shared control (a 7 × 7 metric, a 3 × 3 task-space
//! system) where nalgebra's dynamic types would allocate.
//!
//! Matrices are square, column-major slices of length `n * n`; symmetric
//! routines read and write both triangles.
//!
//! ```
//! use tandem_solvers::small::{symmetric_eigen, cholesky_solve_in_place};
//! // A = [[2, 1], [1, 2]]: eigenvalues 1 and 3.
//! let mut a = [2.0, 1.0, 1.0, 2.0];
//! let (mut values, mut vectors) = ([0.0; 2], [0.0; 4]);
//! symmetric_eigen(&mut a, 2, &mut values, &mut vectors);
//! values.sort_by(f64::total_cmp);
//! assert!((values[0] - 1.0).abs() < 1e-14 && (values[1] - 3.0).abs() < 1e-14);
//! // Solve [[4, 2], [2, 3]] x = [2, 1].
//! let mut m = [4.0, 2.0, 2.0, 3.0];
//! let mut x = [2.0, 1.0];
//! assert!(cholesky_solve_in_place(&mut m, 2, &mut x));
//! assert!((x[0] - 0.5).abs() < 1e-14 && x[1].abs() < 1e-14);
//! ```

/// Eigen-decomposition of the symmetric `n × n` matrix `a` by cyclic Jacobi
/// rotations: `a = V diag(values) Vᵀ`, eigenvectors in the columns of
/// `vectors` (column-major). `a` is overwritten (its diagonal ends as the
/// eigenvalues). Unsorted. Accurate to a few ulps of the largest
/// eigenvalue; at most 30 sweeps (convergence is quadratic, 6–8 sweeps for
/// n = 7).
pub fn symmetric_eigen(a: &mut [f64], n: usize, values: &mut [f64], vectors: &mut [f64]) {
    debug_assert!(a.len() >= n * n && values.len() >= n && vectors.len() >= n * n);
    identity(vectors, n);
    for _sweep in 0..30 {
        let off: f64 = (0..n).flat_map(|c| (0..c).map(move |r| (r, c))).map(|(r, c)| a[r + c * n].powi(2)).sum();
        let scale: f64 = (0..n).map(|i| a[i + i * n].powi(2)).sum::<f64>() + off;
        if off <= 1e-32 * scale || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                rotate(a, n, vectors, p, q);
            }
        }
    }
    for i in 0..n {
        values[i] = a[i + i * n];
    }
}

/// One Jacobi rotation zeroing `a[p, q]` (Golub & Van Loan, Alg. 8.5.2).
fn rotate(a: &mut [f64], n: usize, v: &mut [f64], p: usize, q: usize) {
    let apq = a[p + q * n];
    if apq == 0.0 {
        return;
    }
    let theta = (a[q + q * n] - a[p + p * n]) / (2.0 * apq);
    let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
    let t = if theta == 0.0 { 1.0 } else { t };
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    for k in 0..n {
        // Columns p and q of A·J.
        let (akp, akq) = (a[k + p * n], a[k + q * n]);
        a[k + p * n] = c * akp - s * akq;
        a[k + q * n] = s * akp + c * akq;
    }
    for k in 0..n {
        // Rows p and q of Jᵀ·(A·J).
        let (apk, aqk) = (a[p + k * n], a[q + k * n]);
        a[p + k * n] = c * apk - s * aqk;
        a[q + k * n] = s * apk + c * aqk;
    }
    for k in 0..n {
        let (vkp, vkq) = (v[k + p * n], v[k + q * n]);
        v[k + p * n] = c * vkp - s * vkq;
        v[k + q * n] = s * vkp + c * vkq;
    }
}

/// Writes the `n × n` identity into `m`.
pub fn identity(m: &mut [f64], n: usize) {
    m[..n * n].fill(0.0);
    for i in 0..n {
        m[i + i * n] = 1.0;
    }
}

/// `out = V diag(f(values)) Vᵀ` for an eigen-decomposition from
/// [`symmetric_eigen`]: the matrix function `f(A)` (e.g. `1/λ` for the
/// inverse).
pub fn recompose(vectors: &[f64], values: &[f64], n: usize, f: impl Fn(f64) -> f64, out: &mut [f64]) {
    out[..n * n].fill(0.0);
    for k in 0..n {
        let fk = f(values[k]);
        let vk = &vectors[k * n..(k + 1) * n];
        for c in 0..n {
            let s = fk * vk[c];
            for r in 0..n {
                out[r + c * n] += vk[r] * s;
            }
        }
    }
}

/// Solves `m x = b` for symmetric positive definite `m` by an in-place
/// Cholesky factorisation (`m` is overwritten by `L` in its lower
/// triangle); `b` becomes `x`. Returns `false`, leaving `b` unspecified,
/// when a pivot is not positive and finite.
pub fn cholesky_solve_in_place(m: &mut [f64], n: usize, b: &mut [f64]) -> bool {
    if !cholesky_in_place(m, n) {
        return false;
    }
    cholesky_solve_factored(m, n, b);
    true
}

/// In-place Cholesky factorisation `m = L Lᵀ` (lower triangle of `m`).
/// Returns `false` when a pivot is not positive and finite.
pub fn cholesky_in_place(m: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = m[j + j * n];
        for k in 0..j {
            d -= m[j + k * n] * m[j + k * n];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        m[j + j * n] = d;
        for i in j + 1..n {
            let mut s = m[i + j * n];
            for k in 0..j {
                s -= m[i + k * n] * m[j + k * n];
            }
            m[i + j * n] = s / d;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` with `L` from [`cholesky_in_place`]; `b` becomes `x`.
pub fn cholesky_solve_factored(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i + k * n] * b[k];
        }
        b[i] = s / l[i + i * n];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k + i * n] * b[k];
        }
        b[i] = s / l[i + i * n];
    }
}

/// `y = M x` for the column-major `rows × cols` matrix `m`.
pub fn mat_vec(m: &[f64], rows: usize, cols: usize, x: &[f64], y: &mut [f64]) {
    y[..rows].fill(0.0);
    for c in 0..cols {
        let xc = x[c];
        for r in 0..rows {
            y[r] += m[r + c * rows] * xc;
        }
    }
}

/// `out = a + s·b`, element-wise.
pub fn add_scaled(out: &mut [f64], a: &[f64], s: f64, b: &[f64]) {
    for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
        *o = a + s * b;
    }
}

/// Dot product of two slices of the same length.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn random_symmetric(n: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Vec<f64> {
        let mut a = vec![0.0; n * n];
        for c in 0..n {
            for r in 0..=c {
                let v: f64 = rng.random_range(-1.0..1.0);
                a[r + c * n] = v;
                a[c + r * n] = v;
            }
        }
        a
    }

    #[test]
    fn jacobi_reconstructs_random_symmetric_matrices() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for n in 1..=12 {
            for _ in 0..20 {
                let a = random_symmetric(n, &mut rng);
                let (mut work, mut values, mut vectors, mut back) =
                    (a.clone(), vec![0.0; n], vec![0.0; n * n], vec![0.0; n * n]);
                symmetric_eigen(&mut work, n, &mut values, &mut vectors);
                recompose(&vectors, &values, n, |x| x, &mut back);
                let err = a.iter().zip(&back).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
                assert!(err < 1e-13, "n = {n}: reconstruction error {err}");
                // Orthonormal eigenvectors.
                for i in 0..n {
                    for j in 0..n {
                        let d = dot(&vectors[i * n..(i + 1) * n], &vectors[j * n..(j + 1) * n]);
                        let want = if i == j { 1.0 } else { 0.0 };
                        assert!((d - want).abs() < 1e-13, "n = {n}: vᵢ·vⱼ = {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn cholesky_solves_and_rejects_indefinite_matrices() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for n in 1..=10 {
            let g = random_symmetric(n, &mut rng);
            // M = GᵀG + I is positive definite.
            let mut m = vec![0.0; n * n];
            for c in 0..n {
                for r in 0..n {
                    m[r + c * n] = (0..n).map(|k| g[k + r * n] * g[k + c * n]).sum::<f64>() + f64::from(r == c);
                }
            }
            let x: Vec<f64> = (0..n).map(|i| i as f64 - 2.0).collect();
            let mut b = vec![0.0; n];
            mat_vec(&m, n, n, &x, &mut b);
            let mut f = m.clone();
            assert!(cholesky_solve_in_place(&mut f, n, &mut b));
            let err = x.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(err < 1e-11, "n = {n}: error {err}");
        }
        let mut indefinite = [1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky_solve_in_place(&mut indefinite, 2, &mut [1.0, 1.0]));
        let mut nan = [f64::NAN, 0.0, 0.0, 1.0];
        assert!(!cholesky_solve_in_place(&mut nan, 2, &mut [1.0, 1.0]));
    }
}
