//! The infinite-horizon DARE by structure-preserving doubling (SDA).
//!
//! The cross term is removed first (`Â = A − B R⁻¹ Nᵀ`,
//! `Q̂ = Q − N R⁻¹ Nᵀ` leave `P` unchanged), then, with `G = B R⁻¹ Bᵀ`,
//! the doubling step
//! `W = I + G_k H_k`, `A_{k+1} = A_k W⁻¹ A_k`,
//! `G_{k+1} = G_k + A_k W⁻¹ G_k A_kᵀ`, `H_{k+1} = H_k + A_kᵀ H_k W⁻¹ A_k`
//! drives `H_k` to `P` with error `O(ρ^{2^{k+1}})`, `ρ` the closed-loop
//! spectral radius. Since `A_k = (I + G_k P) S^{2^k}` with `S = A − BK`, the
//! last `W⁻¹ A_k` is `S^{2^k}`, which bounds `ρ` from above for free.

use super::RiccatiError;
use super::blocks::Blocks;
use super::dense::{self, Op, gemm};
use super::validate;
use nalgebra::{DMatrix, DMatrixView};

mod newton;

/// The spectral-radius estimate uses `‖S^{2^j}‖_F^{1/2^j}` with `j` at least
/// this: the overestimate factor `(√n·κ)^{1/2^j}` is then within about 5% for
/// eigenvector condition numbers `κ` up to 1e5.
const SPECTRAL_POWER_LOG2: usize = 8;

/// One DARE: dynamics `x⁺ = A x + B u`, stage cost `xᵀQx + uᵀRu + 2xᵀNu`.
///
/// Holds views, so any nalgebra matrix converts (`&DMatrix`, `&Matrix4`, a
/// `DVector` for a single input). Shapes are checked when it is solved.
#[derive(Debug, Clone, Copy)]
pub struct DareProblem<'a> {
    a: DMatrixView<'a, f64>,
    b: DMatrixView<'a, f64>,
    q: DMatrixView<'a, f64>,
    r: DMatrixView<'a, f64>,
    n: Option<DMatrixView<'a, f64>>,
}

impl<'a> DareProblem<'a> {
    /// `A` (n×n), `B` (n×m), `Q` (n×n, symmetric PSD), `R` (m×m, symmetric PD).
    pub fn new(
        a: impl Into<DMatrixView<'a, f64>>,
        b: impl Into<DMatrixView<'a, f64>>,
        q: impl Into<DMatrixView<'a, f64>>,
        r: impl Into<DMatrixView<'a, f64>>,
    ) -> Self {
        DareProblem { a: a.into(), b: b.into(), q: q.into(), r: r.into(), n: None }
    }

    /// Adds the cross weight `N` (n×m); `[[Q, N], [Nᵀ, R]]` must be PSD.
    pub fn with_cross_term(mut self, n: impl Into<DMatrixView<'a, f64>>) -> Self {
        self.n = Some(n.into());
        self
    }

    /// State dimension `n` (rows of `A`).
    pub fn state_dim(&self) -> usize {
        self.a.nrows()
    }

    /// Input dimension `m` (columns of `B`).
    pub fn input_dim(&self) -> usize {
        self.b.ncols()
    }

    /// `(n, m)` once every shape agrees.
    fn dimensions(&self) -> Result<(usize, usize), RiccatiError> {
        let (n, m) = (self.state_dim(), self.input_dim());
        if n == 0 {
            return Err(RiccatiError::EmptyDimension { dimension: "state" });
        }
        if m == 0 {
            return Err(RiccatiError::EmptyDimension { dimension: "input" });
        }
        validate::shape("A", &self.a, n, n)?;
        validate::shape("B", &self.b, n, m)?;
        validate::shape("Q", &self.q, n, n)?;
        validate::shape("R", &self.r, m, m)?;
        if let Some(cross) = &self.n {
            validate::shape("N", cross, n, m)?;
        }
        Ok((n, m))
    }
}

/// Tolerances and limits of [`solve_dare`]; `Default` gives the documented values.
#[derive(Debug, Clone, PartialEq)]
pub struct DareSettings {
    /// Doubling stops once the squared relative change `(‖ΔH‖_F / ‖H‖_F)²`,
    /// which quadratic convergence makes the size of the next change, is at
    /// most this. Default `1e-16`.
    pub tolerance: f64,
    /// Doubling steps before reporting [`RiccatiError::NotStabilisable`]; step
    /// `k` accounts for `2^k` Riccati steps, so 60 covers any spectral radius
    /// that is below 1 in double precision. Default `60`.
    pub max_iterations: usize,
    /// Relative residual above which Newton (Hewer) refinement steps are
    /// taken. Default `1e-13`.
    pub refinement_threshold: f64,
    /// Newton refinement steps at most; each solves one Stein equation by
    /// Smith doubling. Default `3`.
    pub max_refinement_steps: usize,
    /// Relative residual above which the answer is rejected as
    /// [`RiccatiError::IllConditioned`]. Default `1e-10`.
    pub residual_tolerance: f64,
    /// Accepted `‖M − Mᵀ‖_F / ‖M‖_F` for `Q` and `R`. Default `1e-10`.
    pub symmetry_tolerance: f64,
    /// `Q` (or `Q − N R⁻¹ Nᵀ`) may have eigenvalues down to `−tol·‖Q‖_F`
    /// (rounding of a semidefinite weight) before it is rejected. Default `1e-10`.
    pub definiteness_tolerance: f64,
    /// Solve decoupled subsystems separately: when no entry of `A`, `B`,
    /// `Q`, `R`, `N` links two groups of states and inputs, each group is
    /// its own (smaller) DARE, and groups with identical matrices are solved
    /// once. The answer is the same (`P` and `K` are block diagonal then);
    /// only the time changes. Default `true`.
    pub decouple: bool,
}

impl Default for DareSettings {
    fn default() -> Self {
        DareSettings {
            tolerance: 1e-16,
            max_iterations: 60,
            refinement_threshold: 1e-13,
            max_refinement_steps: 3,
            residual_tolerance: 1e-10,
            symmetry_tolerance: 1e-10,
            definiteness_tolerance: 1e-10,
            decouple: true,
        }
    }
}

/// What a solve reports besides `P` and `K`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DareStats {
    /// Relative residual `‖Res‖_F / (‖P‖_F + ‖AᵀPA‖_F + ‖Q‖_F)` of the
    /// original (cross-term) equation, `Res = Q + AᵀPA − (AᵀPB + N)K − P`.
    pub residual: f64,
    /// Doubling iterations run (the most of any decoupled group; 0 when a
    /// warm start converged without doubling).
    pub iterations: usize,
    /// Newton refinement steps attempted (0 when the doubling result was
    /// accurate), or the Newton steps of a warm start.
    pub refinement_steps: usize,
    /// Estimate from above of the spectral radius of `A − BK`:
    /// `‖(A − BK)^{2^j}‖_F^{1/2^j}` with `2^j ≥ 256`, the power taken from
    /// the doubling itself (exact up to the last iterate's change), so it
    /// costs almost nothing. Below 1 it certifies a Schur-stable closed loop;
    /// it overestimates by a factor `(√n·κ)^{1/2^j}` (`κ` the eigenvector
    /// condition number), typically a few per cent.
    pub closed_loop_spectral_radius: f64,
}

/// The stabilising DARE solution and the optimal gain.
#[derive(Debug, Clone, PartialEq)]
pub struct DareSolution {
    /// `P` (n×n, symmetric PSD): the optimal cost-to-go is `xᵀPx`.
    pub p: DMatrix<f64>,
    /// `K` (m×n): the optimal policy is `u = −K x`.
    pub k: DMatrix<f64>,
    /// See [`DareStats::residual`].
    pub residual: f64,
    /// See [`DareStats::iterations`].
    pub iterations: usize,
    /// See [`DareStats::refinement_steps`].
    pub refinement_steps: usize,
    /// See [`DareStats::closed_loop_spectral_radius`].
    pub closed_loop_spectral_radius: f64,
}

/// Solves one DARE with a fresh workspace; see the [module docs](super).
///
/// For repeated solves use [`DareWorkspace::solve`], which reuses its buffers.
pub fn solve_dare(problem: &DareProblem<'_>, settings: &DareSettings) -> Result<DareSolution, RiccatiError> {
    let mut ws = DareWorkspace::new(problem.state_dim(), problem.input_dim());
    let stats = ws.solve(problem, settings)?;
    let DareWorkspace { p, k, .. } = ws;
    Ok(DareSolution {
        p,
        k,
        residual: stats.residual,
        iterations: stats.iterations,
        refinement_steps: stats.refinement_steps,
        closed_loop_spectral_radius: stats.closed_loop_spectral_radius,
    })
}

/// Every buffer a DARE solve needs, for a state dimension `n` and input
/// dimension `m`; `Send`, one per thread.
///
/// Solving a problem of another size resizes it, and the first solve of a
/// problem that decouples (see [`DareSettings::decouple`]) makes one
/// workspace per group. After that a solve of the same size and structure
/// allocates nothing on CPUs with AVX2 and FMA for `n` up to 64 (larger
/// products go to `matrixmultiply`, which takes a packing buffer per call).
#[derive(Debug, Clone)]
pub struct DareWorkspace {
    n: usize,
    m: usize,
    pub(super) has_cross: bool,
    // Inputs, copied (and symmetrised) once per solve.
    pub(super) a0: DMatrix<f64>,
    pub(super) b0: DMatrix<f64>,
    pub(super) q0: DMatrix<f64>,
    pub(super) r0: DMatrix<f64>,
    pub(super) n0: DMatrix<f64>,
    // Doubling iterates and scratch, n×n unless noted.
    at: DMatrix<f64>, // A_kᵀ
    g: DMatrix<f64>,
    h: DMatrix<f64>,
    w: DMatrix<f64>,
    aug: DMatrix<f64>,    // 3n×n: [W | A_k | G_k]ᵀ, then [· | W⁻¹A_k | W⁻¹G_k]ᵀ
    prod_t: DMatrix<f64>, // 2n×n: (A_k·W⁻¹[A_k | G_k])ᵀ
    t1: DMatrix<f64>,
    dh: DMatrix<f64>,
    mm: DMatrix<f64>,
    m2: DMatrix<f64>,
    // Gain, residual and refinement.
    lr: DMatrix<f64>, // m×m Cholesky factor of R
    z: DMatrix<f64>,  // m×n
    s: DMatrix<f64>,  // m×m: R + BᵀPB, then its factor
    pb: DMatrix<f64>, // n×m
    pa: DMatrix<f64>,
    f: DMatrix<f64>, // m×n: BᵀPA + Nᵀ
    res: DMatrix<f64>,
    pub(super) p: DMatrix<f64>,
    pub(super) k: DMatrix<f64>, // m×n
    p_prev: DMatrix<f64>,
    k_prev: DMatrix<f64>,
    /// `‖Res‖_F, ‖AᵀPA‖_F, ‖P‖_F, ‖Q‖_F` of the last residual evaluation.
    pub(super) residual_terms: [f64; 4],
    /// Decoupled groups (empty until a problem splits).
    blocks: Blocks,
}

impl DareWorkspace {
    /// Buffers for `n` states and `m` inputs.
    pub fn new(n: usize, m: usize) -> Self {
        let sq = || DMatrix::zeros(n, n);
        DareWorkspace {
            n,
            m,
            has_cross: false,
            a0: sq(),
            b0: DMatrix::zeros(n, m),
            q0: sq(),
            r0: DMatrix::zeros(m, m),
            n0: DMatrix::zeros(n, m),
            at: sq(),
            g: sq(),
            h: sq(),
            w: sq(),
            aug: DMatrix::zeros(3 * n, n),
            prod_t: DMatrix::zeros(2 * n, n),
            t1: sq(),
            dh: sq(),
            mm: sq(),
            m2: sq(),
            lr: DMatrix::zeros(m, m),
            z: DMatrix::zeros(m, n),
            s: DMatrix::zeros(m, m),
            pb: DMatrix::zeros(n, m),
            pa: sq(),
            f: DMatrix::zeros(m, n),
            res: sq(),
            p: sq(),
            k: DMatrix::zeros(m, n),
            p_prev: sq(),
            k_prev: DMatrix::zeros(m, n),
            residual_terms: [0.0; 4],
            blocks: Blocks::default(),
        }
    }

    /// Makes the buffers `n`×`m` (reallocating only when the size changes).
    pub(super) fn resize(&mut self, n: usize, m: usize) {
        if (self.n, self.m) != (n, m) {
            *self = DareWorkspace::new(n, m);
        }
    }

    /// Whether the loaded problems are identical, bit for bit.
    pub(super) fn same_problem(&self, other: &DareWorkspace) -> bool {
        (self.n, self.m, self.has_cross) == (other.n, other.m, other.has_cross)
            && self.a0 == other.a0
            && self.b0 == other.b0
            && self.q0 == other.q0
            && self.r0 == other.r0
            && (!self.has_cross || self.n0 == other.n0)
    }

    /// `P` of the last successful solve (n×n); unspecified after an error.
    pub fn p(&self) -> &DMatrix<f64> {
        &self.p
    }

    /// `K` of the last successful solve (m×n); unspecified after an error.
    pub fn k(&self) -> &DMatrix<f64> {
        &self.k
    }

    /// Solves `problem`, leaving `P` and `K` in [`p`](Self::p) and [`k`](Self::k).
    pub fn solve(&mut self, problem: &DareProblem<'_>, settings: &DareSettings) -> Result<DareStats, RiccatiError> {
        self.solve_from(problem, settings, None)
    }

    /// Solves `problem` by Newton (Hewer) steps from `p0`, e.g. the `P` of a
    /// nearby problem (a policy rebuilt along a reference with slightly
    /// different weights or time step): from a stabilising `p0` close to the
    /// answer one or two steps reach the residual threshold, with no
    /// doubling ([`DareStats::iterations`] is then 0).
    ///
    /// The answer is held to the cold solve's standard: its residual is
    /// checked and the closed loop `A − BK` certified Schur-stable, which
    /// makes it the stabilising solution. When `p0` does not lead there (its
    /// closed loop is unstable, Newton stalls or ends on another solution),
    /// the cold solve runs instead, so the result is the same `P` as
    /// [`solve`](Self::solve)'s to within the residual tolerance, or its error.
    ///
    /// # Errors
    /// As [`solve`](Self::solve), and for a `p0` that is not `n`×`n`, not
    /// finite, or not symmetric (named `"P0"`).
    pub fn solve_warm<'p>(
        &mut self,
        problem: &DareProblem<'_>,
        settings: &DareSettings,
        p0: impl Into<DMatrixView<'p, f64>>,
    ) -> Result<DareStats, RiccatiError> {
        self.solve_from(problem, settings, Some(p0.into()))
    }

    fn solve_from(
        &mut self,
        problem: &DareProblem<'_>,
        settings: &DareSettings,
        p0: Option<DMatrixView<'_, f64>>,
    ) -> Result<DareStats, RiccatiError> {
        let (n, m) = problem.dimensions()?;
        if let Some(p0) = &p0 {
            validate::shape("P0", p0, n, n)?;
            validate::finite("P0", p0)?;
        }
        self.resize(n, m);
        self.load(problem, settings)?;
        if let Some(p0) = &p0 {
            validate::copy_into(&mut self.p, p0);
            validate::symmetric("P0", &mut self.p, settings.symmetry_tolerance)?;
        }
        let warm = p0.is_some();
        if settings.decouple {
            let mut blocks = std::mem::take(&mut self.blocks);
            let cross = self.has_cross.then_some(&self.n0);
            let result = if blocks.split(&self.a0, &self.b0, &self.q0, &self.r0, cross) {
                Some(blocks.solve(self, settings, warm))
            } else {
                None
            };
            self.blocks = blocks;
            if let Some(result) = result {
                return result;
            }
        }
        self.solve_loaded(settings, warm)
    }

    /// Solves the problem already in `a0`, `b0`, `q0`, `r0`, `n0` (checked
    /// and symmetrised), starting from `p` when `warm`.
    pub(super) fn solve_loaded(&mut self, settings: &DareSettings, warm: bool) -> Result<DareStats, RiccatiError> {
        let n = self.n;
        self.prepare(settings)?;
        if warm && let Some(stats) = self.newton_from_p(settings) {
            return Ok(stats);
        }
        let last = self.doubling(settings)?;
        self.p.copy_from(&self.h);
        dense::symmetrize(&mut self.p);
        // (A − BK)^{2^k}, transposed: norms and powers do not care.
        for (dst, src) in self.mm.as_mut_slice().chunks_exact_mut(n).zip(self.aug.as_slice().chunks_exact(3 * n)) {
            dst.copy_from_slice(&src[n..2 * n]);
        }
        let rho = self.spectral_radius_bound(last);
        if rho.is_nan() || rho >= 1.0 {
            return Err(RiccatiError::NotDetectable { spectral_radius: rho });
        }
        let residual = self.gain_and_residual();
        let (residual, refinement_steps) = self.refine(settings, residual);
        if residual.is_nan() || residual > settings.residual_tolerance {
            return Err(RiccatiError::IllConditioned { residual, tolerance: settings.residual_tolerance });
        }
        Ok(DareStats { residual, iterations: last + 1, refinement_steps, closed_loop_spectral_radius: rho })
    }

    /// Checks and copies the inputs.
    fn load(&mut self, problem: &DareProblem<'_>, settings: &DareSettings) -> Result<(), RiccatiError> {
        let inputs = [("A", &problem.a), ("B", &problem.b), ("Q", &problem.q), ("R", &problem.r)];
        for (name, m) in inputs {
            validate::finite(name, m)?;
        }
        validate::copy_into(&mut self.a0, &problem.a);
        validate::copy_into(&mut self.b0, &problem.b);
        validate::copy_into(&mut self.q0, &problem.q);
        validate::copy_into(&mut self.r0, &problem.r);
        self.has_cross = problem.n.is_some();
        if let Some(cross) = &problem.n {
            validate::finite("N", cross)?;
            validate::copy_into(&mut self.n0, cross);
        }
        validate::symmetric("Q", &mut self.q0, settings.symmetry_tolerance)?;
        validate::symmetric("R", &mut self.r0, settings.symmetry_tolerance)
    }

    /// Factors `R`, forms `G = B R⁻¹ Bᵀ`, removes the cross term and checks `Q̂ ⪰ 0`.
    fn prepare(&mut self, settings: &DareSettings) -> Result<(), RiccatiError> {
        self.lr.copy_from(&self.r0);
        let max_diag = (0..self.m).map(|i| self.r0[(i, i)]).fold(0.0, f64::max);
        // Pivots below m·ε·max R_ii mean R is singular to working precision.
        dense::cholesky(&mut self.lr, self.m as f64 * f64::EPSILON * max_diag)
            .map_err(|_| RiccatiError::NotPositiveDefinite { matrix: "R" })?;
        // G = Zᵀ Z with Z = L⁻¹ Bᵀ: symmetric PSD by construction.
        dense::transpose_into(&self.b0, &mut self.z);
        dense::forward_solve(&self.lr, &mut self.z);
        gemm(&mut self.g, 1.0, Op::t(&self.z), Op::n(&self.z), 0.0);
        dense::symmetrize(&mut self.g);
        dense::transpose_into(&self.a0, &mut self.at);
        self.h.copy_from(&self.q0);
        let mut scale = dense::frobenius(self.q0.as_slice());
        if self.has_cross {
            dense::transpose_into(&self.n0, &mut self.z);
            dense::forward_solve(&self.lr, &mut self.z);
            gemm(&mut self.w, 1.0, Op::t(&self.z), Op::n(&self.z), 0.0); // N R⁻¹ Nᵀ
            scale += dense::frobenius(self.w.as_slice());
            self.h -= &self.w;
            dense::symmetrize(&mut self.h);
            dense::backward_solve(&self.lr, &mut self.z); // R⁻¹ Nᵀ
            gemm(&mut self.at, -1.0, Op::t(&self.z), Op::t(&self.b0), 1.0); // Âᵀ = Aᵀ − (R⁻¹Nᵀ)ᵀBᵀ
        }
        // Q̂ + δI positive definite ⟺ λ_min(Q̂) > −δ (Cholesky's own rounding is far below δ).
        self.w.copy_from(&self.h);
        dense::add_diagonal(&mut self.w, settings.definiteness_tolerance * scale + f64::MIN_POSITIVE);
        let matrix = if self.has_cross { "Q - N R⁻¹ Nᵀ" } else { "Q" };
        dense::cholesky(&mut self.w, 0.0).map_err(|_| RiccatiError::NotPositiveSemidefinite { matrix })
    }

    /// Runs the doubling until converged; returns the index `k` of the last
    /// step, whose `W⁻¹ A_k ≈ (A − BK)^{2^k}` is left, transposed, in
    /// `aug[n..2n, :]`.
    ///
    /// The iterate is kept as `A_kᵀ` and the system `W·[X1 | Y] = [A_k | G_k]`
    /// transposed (see [`dense::solve_augmented`]); the products read
    /// whichever orientation they need through strides.
    fn doubling(&mut self, settings: &DareSettings) -> Result<usize, RiccatiError> {
        let n = self.n;
        for k in 0..settings.max_iterations {
            let diverged = RiccatiError::NotStabilisable { iterations: k + 1 };
            // aug column i = row i of [W | A_k | G_k] with W = I + G_k H_k, so
            // its first block is Wᵀ = I + H_k G_k.
            dense::gemm_rows(&mut self.aug, 0, 1.0, Op::n(&self.h), Op::n(&self.g), 0.0);
            for (i, ((dst, at), g)) in self
                .aug
                .as_mut_slice()
                .chunks_exact_mut(3 * n)
                .zip(self.at.column_iter())
                .zip(self.g.column_iter())
                .enumerate()
            {
                dst[i] += 1.0;
                dst[n..2 * n].copy_from_slice(at.as_slice());
                dst[2 * n..].copy_from_slice(g.as_slice());
            }
            // I + GH has eigenvalues ≥ 1 in exact arithmetic: a zero pivot means overflow.
            dense::solve_augmented(&mut self.aug, n).map_err(|_| diverged.clone())?; // rows n.. = [X1ᵀ; Yᵀ]
            gemm(&mut self.t1, 1.0, Op::n(&self.h), Op::rows(&self.aug, n, n).transposed(), 0.0);
            gemm(&mut self.dh, 1.0, Op::n(&self.at), Op::n(&self.t1), 0.0); // A_kᵀ H X1
            let (change, size) = dense::add_assign_with_norms(&mut self.h, &self.dh);
            if !(change.is_finite() && size.is_finite()) {
                return Err(diverged);
            }
            let relative = if change == 0.0 { 0.0 } else { change / size };
            if relative * relative <= settings.tolerance {
                return Ok(k);
            }
            // [X1ᵀ; Yᵀ]·A_kᵀ = [A_{k+1}ᵀ; (A_k Y)ᵀ]
            gemm(&mut self.prod_t, 1.0, Op::rows(&self.aug, n, 2 * n), Op::n(&self.at), 0.0);
            gemm(&mut self.t1, 1.0, Op::t(&self.at), Op::rows(&self.prod_t, n, n), 0.0); // A_k Y A_kᵀ
            let (_, g_size) = dense::add_assign_with_norms(&mut self.g, &self.t1);
            for (dst, src) in self.at.as_mut_slice().chunks_exact_mut(n).zip(self.prod_t.as_slice().chunks_exact(2 * n))
            {
                dst.copy_from_slice(&src[..n]);
            }
            // An overflowing A_k shows up as a non-finite H one step later.
            if !g_size.is_finite() {
                return Err(diverged);
            }
        }
        Err(RiccatiError::NotStabilisable { iterations: settings.max_iterations })
    }

    /// `‖M^{2^j}‖_F^{1/2^{k+j}}` for `M = mm = S^{2^k}`, squaring (with
    /// rescaling, so tiny powers do not underflow) until `k + j ≥ 8`.
    fn spectral_radius_bound(&mut self, k: usize) -> f64 {
        let mut log2_power = k;
        let mut log_scale = 0.0;
        loop {
            let norm = dense::frobenius(self.mm.as_slice());
            if norm == 0.0 {
                return 0.0; // nilpotent closed loop (dead-beat control)
            }
            if !norm.is_finite() {
                return f64::INFINITY;
            }
            log_scale += norm.ln();
            if log2_power >= SPECTRAL_POWER_LOG2 {
                return (log_scale / 2f64.powi(log2_power as i32)).exp();
            }
            self.mm /= norm;
            gemm(&mut self.m2, 1.0, Op::n(&self.mm), Op::n(&self.mm), 0.0);
            std::mem::swap(&mut self.mm, &mut self.m2);
            log_scale *= 2.0;
            log2_power += 1;
        }
    }

    /// `K` from `P`, and the relative residual of the original equation
    /// (left in `res`); infinite if `R + BᵀPB` is not positive definite.
    fn gain_and_residual(&mut self) -> f64 {
        gemm(&mut self.pb, 1.0, Op::n(&self.p), Op::n(&self.b0), 0.0);
        self.s.copy_from(&self.r0);
        gemm(&mut self.s, 1.0, Op::t(&self.b0), Op::n(&self.pb), 1.0);
        dense::symmetrize(&mut self.s);
        gemm(&mut self.pa, 1.0, Op::n(&self.p), Op::n(&self.a0), 0.0);
        gemm(&mut self.f, 1.0, Op::t(&self.b0), Op::n(&self.pa), 0.0);
        if self.has_cross {
            for i in 0..self.m {
                for j in 0..self.n {
                    self.f[(i, j)] += self.n0[(j, i)];
                }
            }
        }
        self.k.copy_from(&self.f);
        if dense::cholesky(&mut self.s, 0.0).is_err() {
            self.residual_terms = [f64::INFINITY, 0.0, 0.0, 0.0];
            return f64::INFINITY;
        }
        dense::cholesky_solve(&self.s, &mut self.k);
        gemm(&mut self.res, 1.0, Op::t(&self.a0), Op::n(&self.pa), 0.0);
        let (apa, p, q) = (
            dense::frobenius(self.res.as_slice()),
            dense::frobenius(self.p.as_slice()),
            dense::frobenius(self.q0.as_slice()),
        );
        self.res += &self.q0;
        self.res -= &self.p;
        gemm(&mut self.res, -1.0, Op::t(&self.f), Op::n(&self.k), 1.0);
        dense::symmetrize(&mut self.res);
        let norm = dense::frobenius(self.res.as_slice());
        self.residual_terms = [norm, apa, p, q];
        if norm == 0.0 { 0.0 } else { norm / (apa + p + q) }
    }
}
