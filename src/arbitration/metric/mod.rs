//! Metrics recovered from the robot policy's local behaviour: the Hessian
//! metric `W` (§5.4.1 of the dissertation, eq. 5.5–5.6) and the Fisher metric
//! `F` (Algorithm 3), their repair into well-conditioned positive definite
//! matrices, and the belief-weighted combination over goals (Algorithm 2).
//!
//! **Hessian metric.** A robot action is read as the gradient of a value
//! (§3.2.2), so values near `q` are recovered from actions: with `f(q) = 0`,
//! `f(p) ≈ π(p)·(p − q)` at each probe `p` (eq. 5.5). The probes are
//! `q + h eᵢ` and `q + h eᵢ + h eⱼ` (`i ≤ j`): `n + n(n+1)/2` policy
//! queries, plus the action at `q` itself, `1 + n(n+3)/2` in all (36 for 7
//! joints), and the forward-difference Hessian of eq. 5.6 follows. On a
//! linear field `π(p) = a + A(p − q)` this gives `A + Aᵀ` exactly, whatever
//! `h`: the curvature of the value, symmetric by construction. A policy
//! pulls toward lower cost, so the metric is minus half of it: `W =
//! −(A + Aᵀ)/2`, in the policy's units (1/s for a velocity policy).
//!
//! **Fisher metric.** States are sampled around `q` (the `2n` points
//! `q ± r eᵢ` and `n` more on the sphere of radius `r`, from a fixed
//! Halton sequence), the policy is fitted there by locally weighted
//! regression (a linear model, Gaussian weights of width `r`, §3.3.2), and
//! `F = −(A + Aᵀ)/2` for the fitted model's Jacobian `A`: `3n + 1` queries.
//! In task space the same fit maps gripper positions to gripper velocities.
//!
//! **Repair.** Finite differences are not positive definite in general
//! (and a tracking policy is flat along its reference): eigenvalues below
//! `floor · λ_max` are raised to it, and the metric is scaled to mean
//! eigenvalue 1 (trace n), so an isotropic metric is the identity and
//! reproduces the unassisted command. A metric whose largest eigenvalue is
//! not positive (a policy that pushes away everywhere) becomes the identity.
//!
//! **Several goals.** `M⁻¹ = Σ_g b_g M_g⁻¹` over goals with belief at least
//! `min_belief` (re-normalised), Algorithm 2.

use crate::control::{ControlError, RobotPolicy, RobotPolicyWorkspace};
use crate::settings::{InvalidSetting, check, positive};
use tandem_solvers::small::{add_scaled, identity, recompose, symmetric_eigen};

mod stage;

/// Settings of the metrics.
///
/// ```
/// # use tandem::arbitration::MetricSettings;
/// let s = MetricSettings::default();
/// assert_eq!((s.step, s.sample_radius, s.task_sample_radius), (1e-3, 0.02, 0.02));
/// assert_eq!((s.floor, s.min_belief), (0.05, 0.01));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricSettings {
    /// Finite-difference step `h` of the Hessian metric (rad or m).
    pub step: f64,
    /// Radius `r` of the Fisher metric's samples and width of its LWR
    /// weights (rad or m in joint space).
    pub sample_radius: f64,
    /// Radius of the task-space Fisher metric's joint samples (rad).
    pub task_sample_radius: f64,
    /// Eigenvalue floor relative to the largest eigenvalue (the metric's
    /// condition number is at most its inverse).
    pub floor: f64,
    /// Goals below this belief are left out of the combined metric.
    pub min_belief: f64,
}

impl Default for MetricSettings {
    fn default() -> Self {
        // A step well inside a segment of a 50-slice reference; a condition
        // number of at most 20.
        MetricSettings { step: 1e-3, sample_radius: 0.02, task_sample_radius: 0.02, floor: 0.05, min_belief: 0.01 }
    }
}

impl MetricSettings {
    /// Checks every setting: step and radii above 0, the floor in (0, 1],
    /// the smallest belief in [0, 1].
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        positive("step", self.step, "rad or m")?;
        positive("sample_radius", self.sample_radius, "rad or m")?;
        positive("task_sample_radius", self.task_sample_radius, "rad")?;
        check("floor", self.floor, self.floor > 0.0 && self.floor <= 1.0, "in (0, 1]")?;
        check("min_belief", self.min_belief, (0.0..=1.0).contains(&self.min_belief), "in [0, 1]")
    }
}

/// A repaired metric and its inverse (n × n, column-major).
#[derive(Debug, Clone)]
pub struct Metric {
    n: usize,
    pub(crate) matrix: Vec<f64>,
    pub(crate) inverse: Vec<f64>,
    /// Largest over smallest eigenvalue (1 for the identity).
    pub(crate) condition: f64,
}

impl Metric {
    pub(crate) fn identity(n: usize) -> Metric {
        let mut m = Metric { n, matrix: vec![0.0; n * n], inverse: vec![0.0; n * n], condition: 1.0 };
        m.set_identity();
        m
    }

    fn set_identity(&mut self) {
        identity(&mut self.matrix, self.n);
        identity(&mut self.inverse, self.n);
        self.condition = 1.0;
    }

    /// Dimension n.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// The metric (column-major n × n).
    pub fn matrix(&self) -> &[f64] {
        &self.matrix
    }

    /// Its inverse (column-major n × n).
    pub fn inverse(&self) -> &[f64] {
        &self.inverse
    }

    /// Largest over smallest eigenvalue.
    pub fn condition(&self) -> f64 {
        self.condition
    }
}

/// Scratch of metric computations for `n` joints; allocated once.
#[derive(Debug, Clone)]
pub(crate) struct MetricWorkspace {
    n: usize,
    pub(crate) probe: Vec<f64>,
    pub(crate) action: Vec<f64>,
    pub(crate) values: Vec<f64>,
    pub(crate) vectors: Vec<f64>,
    pub(crate) work: Vec<f64>,
    pub(crate) single: Vec<f64>,
    pub(crate) inverse_sum: Vec<f64>,
    /// Unit directions of the Fisher samples beyond the star (row-major, n each).
    pub(crate) directions: Vec<f64>,
    /// Normal equations of the LWR fit (d + 1)² and right-hand sides (d + 1) × m.
    pub(crate) normal: Vec<f64>,
    pub(crate) rhs: Vec<f64>,
}

impl MetricWorkspace {
    pub(crate) fn new(n: usize) -> Self {
        MetricWorkspace {
            n,
            probe: vec![0.0; n],
            action: vec![0.0; n],
            values: vec![0.0; n],
            vectors: vec![0.0; n * n],
            work: vec![0.0; n * n],
            single: vec![0.0; n * n],
            inverse_sum: vec![0.0; n * n],
            directions: halton_directions(n, n),
            normal: vec![0.0; (n + 1) * (n + 1)],
            rhs: vec![0.0; (n + 1) * n],
        }
    }
}

/// The raw Hessian metric `−(A + Aᵀ)/2` of `policy` at `q` (velocity
/// `velocity`) into `out` (n × n, column-major), by eq. 5.5–5.6 with step `h`.
pub(crate) fn hessian_metric(
    policy: &dyn RobotPolicy,
    state: &mut RobotPolicyWorkspace,
    q: &[f64],
    velocity: &[f64],
    h: f64,
    scratch: &mut MetricWorkspace,
    out: &mut [f64],
) -> Result<(), ControlError> {
    let n = scratch.n;
    // f_i = f(q + h eᵢ) ≈ h πᵢ(q + h eᵢ), kept on the diagonal of `work`.
    for i in 0..n {
        scratch.probe.copy_from_slice(q);
        scratch.probe[i] += h;
        policy.probe(state, &scratch.probe, velocity, &mut scratch.action)?;
        scratch.values[i] = h * scratch.action[i];
    }
    for i in 0..n {
        for j in i..n {
            scratch.probe.copy_from_slice(q);
            scratch.probe[i] += h;
            scratch.probe[j] += h;
            policy.probe(state, &scratch.probe, velocity, &mut scratch.action)?;
            // f(q + h eᵢ + h eⱼ) ≈ π(p)·(p − q).
            let f_ij = h * (scratch.action[i] + scratch.action[j]);
            let hessian = (f_ij - scratch.values[i] - scratch.values[j]) / (h * h);
            out[i + j * n] = -0.5 * hessian;
            out[j + i * n] = -0.5 * hessian;
        }
    }
    Ok(())
}

/// The raw joint-space Fisher metric `−(A + Aᵀ)/2` of `policy` at `q`:
/// `A` the Jacobian of a locally weighted linear fit of the policy on
/// samples of radius `r` (Algorithm 3). `center` is the action at `q`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fisher_metric(
    policy: &dyn RobotPolicy,
    state: &mut RobotPolicyWorkspace,
    q: &[f64],
    velocity: &[f64],
    center: &[f64],
    r: f64,
    scratch: &mut MetricWorkspace,
    out: &mut [f64],
) -> Result<(), ControlError> {
    let n = scratch.n;
    let mut fit = LwrFit::new(n, n, &mut scratch.normal, &mut scratch.rhs);
    fit.add(&scratch.probe[..0], center, 1.0, r);
    let extra = scratch.directions.len() / n;
    for k in 0..2 * n + extra {
        sample_offset(k, n, r, &scratch.directions, &mut scratch.work[..n]);
        add_scaled(&mut scratch.probe, q, 1.0, &scratch.work[..n]);
        policy.probe(state, &scratch.probe, velocity, &mut scratch.action)?;
        let offset = &scratch.work[..n];
        let weight = gaussian_weight(offset, r);
        fit.add(offset, &scratch.action, weight, r);
    }
    fit.slope_symmetric_negated(out);
    // The fit's slopes are per unit of x / r.
    out[..n * n].iter_mut().for_each(|v| *v /= r);
    Ok(())
}

/// The offset of Fisher sample `k`: `±r eᵢ` for `k < 2n`, then `r` times
/// the fixed unit directions.
pub(crate) fn sample_offset(k: usize, n: usize, r: f64, directions: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    if k < 2 * n {
        out[k / 2] = if k.is_multiple_of(2) { r } else { -r };
    } else {
        let d = &directions[(k - 2 * n) * n..(k - 2 * n + 1) * n];
        for (o, d) in out.iter_mut().zip(d) {
            *o = r * d;
        }
    }
}

/// Number of Fisher samples besides the centre.
pub(crate) fn sample_count(n: usize) -> usize {
    3 * n
}

/// Gaussian LWR weight of a sample at `offset` for bandwidth `r`.
pub(crate) fn gaussian_weight(offset: &[f64], r: f64) -> f64 {
    let d2: f64 = offset.iter().map(|x| x * x).sum();
    (-0.5 * d2 / (r * r)).exp()
}

/// Weighted least squares `y ≈ b + A x` (x of dimension `d`, y of `m`),
/// accumulated in place: normal equations over `[1, x]`.
pub(crate) struct LwrFit<'a> {
    d: usize,
    m: usize,
    normal: &'a mut [f64],
    rhs: &'a mut [f64],
}

impl<'a> LwrFit<'a> {
    pub(crate) fn new(d: usize, m: usize, normal: &'a mut [f64], rhs: &'a mut [f64]) -> Self {
        normal[..(d + 1) * (d + 1)].fill(0.0);
        rhs[..(d + 1) * m].fill(0.0);
        LwrFit { d, m, normal, rhs }
    }

    /// Adds sample `(x, y)` with weight `w`; an empty `x` is the origin.
    /// `scale` (the sample radius) keeps the normal equations O(1).
    pub(crate) fn add(&mut self, x: &[f64], y: &[f64], w: f64, scale: f64) {
        let d1 = self.d + 1;
        let feature = |i: usize| if i == 0 { 1.0 } else { x.get(i - 1).map_or(0.0, |v| v / scale) };
        for c in 0..d1 {
            let fc = feature(c);
            for r in 0..d1 {
                self.normal[r + c * d1] += w * feature(r) * fc;
            }
            for (k, yk) in y.iter().enumerate().take(self.m) {
                self.rhs[c + k * d1] += w * fc * yk;
            }
        }
    }

    /// Solves the fit and writes `−(A + Aᵀ)/2` (requires `m == d`) into
    /// `out` (d × d, column-major); a ridge of 1e-9 of the mean diagonal
    /// keeps directions the samples do not span at zero slope.
    pub(crate) fn slope_symmetric_negated(self, out: &mut [f64]) {
        let (d, d1) = (self.d, self.d + 1);
        let ridge = 1e-9 * (0..d1).map(|i| self.normal[i + i * d1]).sum::<f64>() / d1 as f64 + 1e-300;
        for i in 1..d1 {
            self.normal[i + i * d1] += ridge;
        }
        if !tandem_solvers::small::cholesky_in_place(self.normal, d1) {
            out[..d * d].fill(0.0);
            return;
        }
        for k in 0..self.m {
            tandem_solvers::small::cholesky_solve_factored(self.normal, d1, &mut self.rhs[k * d1..(k + 1) * d1]);
        }
        // A[k, j]: coefficient of x_j / scale in output k.
        for j in 0..d {
            for k in 0..d {
                let a_kj = self.rhs[(j + 1) + k * d1];
                let a_jk = self.rhs[(k + 1) + j * d1];
                out[k + j * d] = -0.5 * (a_kj + a_jk);
            }
        }
    }
}

/// Repairs the raw symmetric metric in `raw` into `out`: eigenvalues
/// floored at `floor · λ_max`, scaled to mean 1; the identity when the
/// largest eigenvalue is not positive or not finite. `raw` is overwritten.
pub(crate) fn repair(raw: &mut [f64], floor: f64, scratch: &mut MetricWorkspace, out: &mut Metric) {
    let n = scratch.n;
    symmetric_eigen(raw, n, &mut scratch.values, &mut scratch.vectors);
    let max = scratch.values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(max.is_finite() && max > 0.0) || scratch.values.iter().any(|v| !v.is_finite()) {
        out.set_identity();
        return;
    }
    let low = floor.clamp(1e-12, 1.0) * max;
    let mean = scratch.values.iter().map(|v| v.max(low)).sum::<f64>() / n as f64;
    recompose(&scratch.vectors, &scratch.values, n, |v| v.max(low) / mean, &mut out.matrix);
    recompose(&scratch.vectors, &scratch.values, n, |v| mean / v.max(low), &mut out.inverse);
    let min = scratch.values.iter().map(|v| v.max(low)).fold(f64::INFINITY, f64::min);
    out.condition = max / min;
}

/// Accumulates goals into a belief-weighted inverse metric (Algorithm 2).
pub(crate) struct MetricMixture {
    weight: f64,
}

impl MetricMixture {
    pub(crate) fn begin(scratch: &mut MetricWorkspace) -> Self {
        scratch.inverse_sum.fill(0.0);
        MetricMixture { weight: 0.0 }
    }

    /// Adds `belief · M⁻¹` of a repaired goal metric.
    pub(crate) fn add(&mut self, scratch: &mut MetricWorkspace, belief: f64, metric: &Metric) {
        for (s, m) in scratch.inverse_sum.iter_mut().zip(&metric.inverse) {
            *s += belief * m;
        }
        self.weight += belief;
    }

    /// The combined metric `(Σ b̃_g M_g⁻¹)⁻¹` into `out` (the identity when
    /// no goal was added).
    pub(crate) fn finish(self, scratch: &mut MetricWorkspace, out: &mut Metric) {
        let n = scratch.n;
        if self.weight <= 0.0 {
            out.set_identity();
            return;
        }
        scratch.single.copy_from_slice(&scratch.inverse_sum);
        symmetric_eigen(&mut scratch.single, n, &mut scratch.values, &mut scratch.vectors);
        let w = self.weight;
        // Each M_g⁻¹ is positive definite, so the sum is; guard roundoff.
        let tiny = 1e-300;
        recompose(&scratch.vectors, &scratch.values, n, |v| w / v.max(tiny), &mut out.matrix);
        recompose(&scratch.vectors, &scratch.values, n, |v| v.max(tiny) / w, &mut out.inverse);
        let (lo, hi) = scratch.values.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        out.condition = hi / lo.max(tiny);
    }
}

/// `count` unit vectors in `n` dimensions from a Halton sequence (bases the
/// first primes), mapped to the sphere by normalising Box–Muller-free
/// centred coordinates; deterministic. Row-major.
fn halton_directions(n: usize, count: usize) -> Vec<f64> {
    const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];
    let mut out = Vec::with_capacity(n * count);
    for k in 0..count {
        let start = out.len();
        for i in 0..n {
            let base = PRIMES[i % PRIMES.len()] + 2 * (i / PRIMES.len()) as u32;
            out.push(2.0 * radical_inverse(k as u32 + 1, base) - 1.0);
        }
        let norm = out[start..].iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-12);
        out[start..].iter_mut().for_each(|x| *x /= norm);
    }
    out
}

fn radical_inverse(mut k: u32, base: u32) -> f64 {
    let (mut value, mut scale) = (0.0, 1.0 / f64::from(base));
    while k > 0 {
        value += f64::from(k % base) * scale;
        k /= base;
        scale /= f64::from(base);
    }
    value
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::ControlError;

    /// π(p) = a + A (p − q0): a linear field.
    #[derive(Debug)]
    struct LinearField {
        a: Vec<f64>,
        matrix: Vec<f64>, // column-major
        q0: Vec<f64>,
    }

    impl RobotPolicy for LinearField {
        fn dof(&self) -> usize {
            self.a.len()
        }
        fn new_workspace(&self) -> RobotPolicyWorkspace {
            RobotPolicyWorkspace::new(())
        }
        fn act(&self, s: &mut RobotPolicyWorkspace, q: &[f64], v: &[f64], out: &mut [f64]) -> Result<(), ControlError> {
            self.probe(s, q, v, out)
        }
        fn probe(
            &self,
            _: &mut RobotPolicyWorkspace,
            q: &[f64],
            _: &[f64],
            out: &mut [f64],
        ) -> Result<(), ControlError> {
            let n = self.a.len();
            for (i, o) in out.iter_mut().enumerate().take(n) {
                *o = self.a[i] + (0..n).map(|j| self.matrix[i + j * n] * (q[j] - self.q0[j])).sum::<f64>();
            }
            Ok(())
        }
        fn reset(&self, _: &mut RobotPolicyWorkspace) {}
    }

    fn field(n: usize, seed: u64) -> LinearField {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        LinearField {
            a: (0..n).map(|_| rng.random_range(-1.0..1.0)).collect(),
            matrix: (0..n * n).map(|_| rng.random_range(-2.0..2.0)).collect(),
            q0: (0..n).map(|_| rng.random_range(-1.0..1.0)).collect(),
        }
    }

    fn expected(f: &LinearField) -> Vec<f64> {
        let n = f.a.len();
        let mut want = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                want[i + j * n] = -0.5 * (f.matrix[i + j * n] + f.matrix[j + i * n]);
            }
        }
        want
    }

    #[test]
    fn hessian_metric_is_exact_on_linear_fields() {
        for (n, seed) in [(2, 1), (3, 2), (7, 3), (9, 4)] {
            let f = field(n, seed);
            let q: Vec<f64> = f.q0.iter().map(|x| x + 0.3).collect();
            let mut scratch = MetricWorkspace::new(n);
            let mut out = vec![0.0; n * n];
            for h in [1e-4, 1e-2, 0.5] {
                hessian_metric(&f, &mut f.new_workspace(), &q, &vec![0.0; n], h, &mut scratch, &mut out).unwrap();
                let err = out.iter().zip(expected(&f)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(err < 1e-9, "n = {n}, h = {h}: error {err}");
            }
        }
    }

    #[test]
    fn fisher_metric_is_exact_on_linear_fields() {
        for (n, seed) in [(2, 5), (3, 6), (7, 7)] {
            let f = field(n, seed);
            let q = f.q0.clone();
            let mut scratch = MetricWorkspace::new(n);
            let (mut out, mut center) = (vec![0.0; n * n], vec![0.0; n]);
            f.probe(&mut f.new_workspace(), &q, &[], &mut center).unwrap();
            for r in [1e-3, 0.02, 0.3] {
                fisher_metric(&f, &mut f.new_workspace(), &q, &vec![0.0; n], &center, r, &mut scratch, &mut out)
                    .unwrap();
                let err = out.iter().zip(expected(&f)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(err < 1e-7, "n = {n}, r = {r}: error {err}");
            }
        }
    }

    #[test]
    fn repair_floors_scales_and_inverts() {
        let n = 3;
        let mut scratch = MetricWorkspace::new(n);
        let mut metric = Metric::identity(n);
        // diag(4, 1, −2) → eigenvalues floored at 0.05·4 = 0.2, mean (4+1+0.2)/3.
        let mut raw = vec![4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -2.0];
        repair(&mut raw, 0.05, &mut scratch, &mut metric);
        let mean = 5.2 / 3.0;
        for (i, want) in [4.0 / mean, 1.0 / mean, 0.2 / mean].iter().enumerate() {
            assert!((metric.matrix()[i + i * n] - want).abs() < 1e-12);
            assert!((metric.inverse()[i + i * n] - 1.0 / want).abs() < 1e-12);
        }
        assert!((metric.condition() - 20.0).abs() < 1e-9);
        // A field pushing away everywhere gives the identity.
        let mut raw = vec![-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0];
        repair(&mut raw, 0.05, &mut scratch, &mut metric);
        assert_eq!(metric.matrix(), &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let mut raw = vec![f64::NAN; 9];
        repair(&mut raw, 0.05, &mut scratch, &mut metric);
        assert_eq!(metric.condition(), 1.0);
    }

    #[test]
    fn mixture_inverts_the_belief_weighted_sum_of_inverses() {
        let n = 2;
        let mut scratch = MetricWorkspace::new(n);
        let (mut a, mut b, mut out) = (Metric::identity(n), Metric::identity(n), Metric::identity(n));
        a.inverse = vec![2.0, 0.0, 0.0, 0.5];
        b.inverse = vec![0.5, 0.0, 0.0, 2.0];
        let mut mix = MetricMixture::begin(&mut scratch);
        mix.add(&mut scratch, 0.25, &a);
        mix.add(&mut scratch, 0.5, &b);
        mix.finish(&mut scratch, &mut out);
        // Σ b̃ M⁻¹ = (1/3)·diag(2, .5) + (2/3)·diag(.5, 2) = diag(1, 1.5).
        assert!((out.inverse()[0] - 1.0).abs() < 1e-12 && (out.inverse()[3] - 1.5).abs() < 1e-12);
        assert!((out.matrix()[3] - 1.0 / 1.5).abs() < 1e-12);
    }
}
