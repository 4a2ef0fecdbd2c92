//! A dense dual active-set QP solver (Goldfarb & Idnani, 1983) for the
//! small strictly convex QPs solved every control tick: a handful of
//! variables, tens of rows, few of them active. It starts from the
//! unconstrained minimiser and adds the most violated row at a time, with
//! the full and partial steps of Goldfarb–Idnani, so it terminates; the
//! directions come from the Schur complement `G_A P⁻¹ G_Aᵀ` of the active
//! rows, refactored at each step (at most `n × n`: cheaper at these sizes
//! than updating a QR factorisation). The answer is exact up to rounding,
//! not to an interior-point tolerance.
//!
//! It needs `P` positive definite and the active rows linearly
//! independent; otherwise it reports [`ConicError::Numerical`] and the
//! caller falls back to Clarabel.

use super::{ConicData, ConicError, ConicSettings, ConicSolution};
use crate::small::{cholesky_in_place, cholesky_solve_factored, dot};

/// A Goldfarb–Idnani solver for QPs (no cone) of `n` variables and up to
/// `m_max` rows; solving allocates nothing.
pub struct ActiveSetSolver {
    n: usize,
    m_max: usize,
    max_steps: u32,
    /// Cholesky factor of `P` (column-major lower triangle).
    l: Vec<f64>,
    /// `P⁻¹ gᵢᵀ` for every row, row-major `m × n`.
    w: Vec<f64>,
    x: Vec<f64>,
    /// Multipliers of every row (0 when inactive).
    z: Vec<f64>,
    active: Vec<usize>,
    /// The active rows' Schur complement, factored (`k × k`).
    s: Vec<f64>,
    /// Dual direction (`k`) and primal direction (`n`).
    r: Vec<f64>,
    dx: Vec<f64>,
}

impl ActiveSetSolver {
    /// A solver for `n` variables and up to `m_max` rows (this allocates;
    /// solves do not).
    pub fn new(n: usize, m_max: usize, settings: &ConicSettings) -> Self {
        ActiveSetSolver {
            n,
            m_max,
            max_steps: settings.max_iterations.max(4 * m_max as u32 + 10),
            l: vec![0.0; n * n],
            w: vec![0.0; m_max * n],
            x: vec![0.0; n],
            z: vec![0.0; m_max],
            active: Vec::with_capacity(n),
            s: vec![0.0; n * n],
            r: vec![0.0; n],
            dx: vec![0.0; n],
        }
    }

    /// Solves the QP `data` exactly (see the module documentation);
    /// `iterations` counts Goldfarb–Idnani steps.
    ///
    /// # Errors
    /// [`ConicError::Capacity`] for a cone or too many rows,
    /// [`ConicError::Infeasible`] when a violated row cannot be met,
    /// [`ConicError::Numerical`] for a `P` that is not positive definite or
    /// dependent active rows, [`ConicError::MaxIterations`] past the step
    /// limit.
    pub fn solve(&mut self, data: &ConicData<'_>) -> Result<ConicSolution<'_>, ConicError> {
        super::check_qp_capacity(data, self.n, self.m_max)?;
        let m = data.rows();
        self.start(data)?;
        let mut steps = 0;
        while let Some(p) = self.most_violated(data) {
            self.add(data, p, &mut steps)?;
        }
        Ok(ConicSolution { x: &self.x, z: &self.z[..m], iterations: steps })
    }

    /// Factors `P`, sets `x = −P⁻¹ q`, `wᵢ = P⁻¹ gᵢᵀ`, no row active.
    fn start(&mut self, data: &ConicData<'_>) -> Result<(), ConicError> {
        let n = self.n;
        for c in 0..n {
            for r in 0..n {
                // Only the upper triangle of P is read.
                self.l[r + c * n] = if r <= c { data.p[r + c * n] } else { data.p[c + r * n] };
            }
        }
        if !cholesky_in_place(&mut self.l, n) {
            return Err(ConicError::Numerical);
        }
        for (x, q) in self.x.iter_mut().zip(data.q) {
            *x = -q;
        }
        cholesky_solve_factored(&self.l, n, &mut self.x);
        for i in 0..data.rows() {
            let w = &mut self.w[i * n..(i + 1) * n];
            w.copy_from_slice(&data.g[i * n..(i + 1) * n]);
            cholesky_solve_factored(&self.l, n, w);
        }
        self.z[..data.rows()].fill(0.0);
        self.active.clear();
        Ok(())
    }

    /// The inactive row violated the most beyond rounding, if any.
    fn most_violated(&self, data: &ConicData<'_>) -> Option<usize> {
        let n = self.n;
        let scale = 1.0 + self.x.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        (0..data.rows())
            .filter(|i| !self.active.contains(i))
            .map(|i| {
                let g = &data.g[i * n..(i + 1) * n];
                let tolerance = 1e-12 * (1.0 + data.h[i].abs() + scale * g.iter().map(|v| v.abs()).sum::<f64>());
                (i, dot(g, &self.x) - data.h[i] - tolerance)
            })
            .filter(|(_, v)| *v > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    /// Makes row `p` active: full steps add it, partial steps first drop the
    /// active rows whose multipliers reach zero.
    fn add(&mut self, data: &ConicData<'_>, p: usize, steps: &mut u32) -> Result<(), ConicError> {
        let n = self.n;
        let g_p = &data.g[p * n..(p + 1) * n];
        loop {
            *steps += 1;
            if *steps > self.max_steps {
                return Err(ConicError::MaxIterations);
            }
            self.directions(data, p)?;
            let slope = dot(g_p, &self.dx);
            let reach = dot(g_p, &self.w[p * n..(p + 1) * n]);
            // The full step meets row p; none when p depends on the active
            // rows (always so when n rows are active).
            let full = if self.active.len() < n && slope > 1e-12 * reach {
                (dot(g_p, &self.x) - data.h[p]) / slope
            } else {
                f64::INFINITY
            };
            let mut partial = (f64::INFINITY, usize::MAX);
            for (j, &row) in self.active.iter().enumerate() {
                if self.r[j] > 0.0 && self.z[row] / self.r[j] < partial.0 {
                    partial = (self.z[row] / self.r[j], j);
                }
            }
            let t = full.min(partial.0);
            if !t.is_finite() {
                return Err(ConicError::Infeasible);
            }
            for (x, d) in self.x.iter_mut().zip(&self.dx) {
                *x -= t * d;
            }
            for (j, &row) in self.active.iter().enumerate() {
                self.z[row] = (self.z[row] - t * self.r[j]).max(0.0);
            }
            self.z[p] += t;
            if full <= partial.0 {
                self.active.push(p);
                return Ok(());
            }
            let dropped = self.active.swap_remove(partial.1);
            self.z[dropped] = 0.0;
        }
    }

    /// With `S r = G_A w_p` (the active rows' Schur complement), the
    /// multipliers move by `−t r` and `x` by `−t (w_p − W_Aᵀ r)` as row
    /// `p`'s multiplier grows by `t` with the active rows held.
    fn directions(&mut self, data: &ConicData<'_>, p: usize) -> Result<(), ConicError> {
        let (n, k) = (self.n, self.active.len());
        let w_p = &self.w[p * n..(p + 1) * n];
        for (a, &i) in self.active.iter().enumerate() {
            let g_i = &data.g[i * n..(i + 1) * n];
            for (b, &j) in self.active.iter().enumerate() {
                self.s[a + b * k] = dot(g_i, &self.w[j * n..(j + 1) * n]);
            }
            self.r[a] = dot(g_i, w_p);
        }
        if !cholesky_in_place(&mut self.s[..k * k], k) {
            return Err(ConicError::Numerical);
        }
        cholesky_solve_factored(&self.s[..k * k], k, &mut self.r[..k]);
        self.dx.copy_from_slice(w_p);
        for (a, &j) in self.active.iter().enumerate() {
            let w_j = &self.w[j * n..(j + 1) * n];
            for (d, w) in self.dx.iter_mut().zip(w_j) {
                *d -= self.r[a] * w;
            }
        }
        Ok(())
    }
}
