//! Decision points: modality of the finite von Mises mixture (FVMM) of goal-conditioned
//! sub-policies (dissertation §6.3, Algorithm 5).
//!
//! Every prospective goal `g` has a deterministic robot sub-policy that proposes an action
//! `a_g` (a velocity, m/s) and an intent-inference score (belief) `b_g`. The direction of
//! `a_g` becomes the mode `μ_g` of a von Mises component (eq. 6.2, planar commands) or a
//! von Mises–Fisher component (3-D commands, unit sphere S²); its concentration `κ_g` grows
//! with the belief. The marginal `π(a|s) = Σ_g w_g f(a | μ_g, κ_g)` (eq. 6.1, `w_g` = the
//! beliefs normalised to sum to 1) is unimodal when the sub-policies are co-directed or one
//! goal dominates — the robot may assist strongly — and multimodal at a *decision point*
//! (sub-policies pointing different ways), where the human should get more authority.
//!
//! Following §6.3.3 the mixture is evaluated only at the component means (no hill
//! climbing), so the test is cheap enough for every control tick; the functions here are
//! allocation-free. The evaluations are made scale-free by dividing by the *consensus
//! peak* — the value the mixture would have at a mean if every sub-policy pointed there,
//! `Σ_h w_h f_h(μ_h)` — and combined as a belief-weighted mean (see [`Modality`]). For
//! components of equal concentration this is `Σ_g Σ_h w_g w_h exp(κ (cos Δ_gh − 1))`: the
//! probability that two goals drawn from the belief agree, softened by the dispersion.
//! It is 1 for full agreement, `Σ_g w_g²` for well separated directions (½ for an even
//! two-way fork) and is compared with [`DecisionSettings::threshold`].
//!
//! ```
//! use tandem::arbitration::decision::{DecisionSettings, planar_modality, spatial_modality};
//!
//! let settings = DecisionSettings::default();
//! // Two goals, equally likely, whose sub-policies point left and right: a fork.
//! let fork = planar_modality(&[[-0.1, 0.0], [0.1, 0.0]], &[0.5, 0.5], &settings);
//! assert!(fork.multimodal);
//! // Both sub-policies go around an obstacle the same way: no decision to make.
//! let bypass = spatial_modality(&[[0.1, 0.02, 0.0], [0.1, 0.0, 0.0]], &[0.5, 0.5], &settings);
//! assert!(!bypass.multimodal);
//! ```

use std::f64::consts::PI;

/// Largest concentration used internally (dimensionless); larger or infinite values are
/// clamped to it so that densities stay finite.
const KAPPA_CAP: f64 = 1.0e6;

/// Argument (dimensionless) above which I0 is evaluated by its asymptotic expansion
/// instead of its power series; both are accurate to ~1e-15 relative around here.
const I0_SERIES_LIMIT: f64 = 20.0;

/// Tuning of the decision-point (modality) test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecisionSettings {
    /// Concentration κ (dimensionless, 1/rad² in the small-angle limit) of a component
    /// whose normalised belief is 0. `κ_g = kappa_min + w_g (kappa_max − kappa_min)`,
    /// where `w_g ∈ [0, 1]` is the belief normalised over the usable components.
    /// Negative or NaN results are treated as 0 (uniform), values are capped at 1e6.
    pub kappa_min: f64,
    /// Concentration κ (dimensionless) of a component whose normalised belief is 1.
    pub kappa_max: f64,
    /// Peak-ratio threshold (dimensionless, in (0, 1]): the mixture is called multimodal
    /// when [`Modality::peak_ratio`] `< threshold`. The default `(1 + e⁻²)/2 ≈ 0.568` is
    /// the peak ratio of two equally weighted, equally concentrated components whose
    /// separation equals 2σ (σ² = 1/κ), which is exactly where a mixture of two equal
    /// Gaussians turns bimodal; with von Mises components the verdict flips within ~1° of
    /// the true bimodality angle for the default concentrations. For unequal weights and
    /// well-separated directions it calls one goal dominant when it holds ≳ 68 % belief.
    /// A NaN threshold never reports multimodality.
    pub threshold: f64,
    /// Minimum speed (m/s) of a sub-policy action to carry a direction; slower (and
    /// zero-length) actions are skipped. NaN or negative means 0.
    pub min_speed: f64,
}

impl Default for DecisionSettings {
    /// `kappa_min = 1`, `kappa_max = 20`, `threshold = (1 + e⁻²)/2`, `min_speed = 1 mm/s`.
    fn default() -> Self {
        Self { kappa_min: 1.0, kappa_max: 20.0, threshold: 0.5 * (1.0 + (-2.0f64).exp()), min_speed: 1.0e-3 }
    }
}

/// Verdict of the modality test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Modality {
    /// `true` at a decision point: `peak_ratio < threshold`.
    pub multimodal: bool,
    /// Belief-weighted mean, over the usable components `g`, of the mixture value at the
    /// component mean `μ_g` divided by the consensus peak `Σ_h w_h f_h(μ_h)` (the mixture
    /// value at a mean if all sub-policies pointed there). Dimensionless, in [0, 1]:
    /// 1 = all sub-policies agree, ½ = an even fork between two well separated directions,
    /// `Σ w_g²` for fully separated directions. Each term is a mixture value at a
    /// component mean (§6.3.3); the belief weighting (rather than the minimum over the
    /// means) keeps a negligible-belief sub-policy pointing elsewhere from flagging a
    /// decision point, as §6.3.2 requires when one sub-policy predominates, and makes
    /// the ratio continuous in the beliefs. It is 1 when no component is usable.
    pub peak_ratio: f64,
}

/// Exponentially scaled modified Bessel function of the first kind, order 0:
/// `e^{−|x|} I0(x)` (dimensionless). Power series below 20, asymptotic expansion above;
/// relative error ~1e-15 everywhere, no overflow.
fn bessel_i0_scaled(x: f64) -> f64 {
    let x = x.abs();
    if x <= I0_SERIES_LIMIT { i0_series(x) * (-x).exp() } else { i0_asymptotic_scaled(x) }
}

/// Modified Bessel function of the first kind, order 0 (dimensionless); `+∞` once it
/// overflows (|x| ≳ 713).
#[cfg_attr(not(test), allow(dead_code))]
fn bessel_i0(x: f64) -> f64 {
    let x = x.abs();
    if x <= I0_SERIES_LIMIT {
        i0_series(x)
    } else {
        // Split the exponential so the product overflows only when I0 itself does.
        let h = 0.5 * x;
        h.exp() * i0_asymptotic_scaled(x) * h.exp()
    }
}

/// `I0(x) = Σ_k ((x/2)^k / k!)²` for `0 ≤ x ≤ 20`: positive terms, no cancellation.
fn i0_series(x: f64) -> f64 {
    let q = 0.25 * x * x;
    let mut term = 1.0;
    let mut sum = 1.0;
    let mut k = 1.0;
    while k < 200.0 {
        term *= q / (k * k);
        sum += term;
        if term <= sum * 1.0e-17 {
            break;
        }
        k += 1.0;
    }
    sum
}

/// `e^{−x} I0(x) ≈ (2πx)^{−1/2} Σ_k ((2k−1)!!)² / (k! (8x)^k)` for `x > 20`, truncated at
/// the smallest term (≲ e^{−2x}).
fn i0_asymptotic_scaled(x: f64) -> f64 {
    let mut term: f64 = 1.0;
    let mut sum = 1.0;
    let mut k = 1.0;
    while k < 200.0 {
        let odd = 2.0 * k - 1.0;
        let next = term * odd * odd / (8.0 * k * x);
        if next >= term || next <= sum * 1.0e-17 {
            sum += next;
            break;
        }
        term = next;
        sum += term;
        k += 1.0;
    }
    sum / (2.0 * PI * x).sqrt()
}

/// von Mises density (1/rad) from the cosine `c` of the angle to the mode.
fn von_mises_from_cos(c: f64, kappa: f64) -> f64 {
    let k = kappa.abs();
    (kappa * c - k).exp() / (2.0 * PI * bessel_i0_scaled(k))
}

/// von Mises–Fisher density on S² (1/sr) from the cosine `c` of the angle to the mode.
fn von_mises_fisher_from_cos(c: f64, kappa: f64) -> f64 {
    let k = kappa.abs();
    let norm = if k == 0.0 {
        1.0 / (4.0 * PI)
    } else {
        // κ / (4π sinh κ) · e^{κ} = κ / (2π (1 − e^{−2κ})).
        k / (2.0 * PI * -(-2.0 * k).exp_m1())
    };
    (kappa * c - k).exp() * norm
}

/// von Mises density (eq. 6.2) `exp(κ cos(θ − μ)) / (2π I0(κ))` in 1/rad, for the angle
/// `theta` (rad) given the mode `mu` (rad) and concentration `kappa` (dimensionless;
/// 0 = uniform `1/(2π)`, negative κ puts the mode at `mu + π`). Evaluated with a scaled
/// Bessel function, so it is finite for any finite κ. NaN inputs give NaN.
pub fn von_mises_density(theta: f64, mu: f64, kappa: f64) -> f64 {
    von_mises_from_cos((theta - mu).cos(), kappa)
}

/// von Mises–Fisher density on the unit sphere S², `κ / (4π sinh κ) · exp(κ μ·x)` in 1/sr,
/// for the direction `x` given the mean direction `mu` and concentration `kappa`
/// (dimensionless; 0 = uniform `1/(4π)`). `x` and `mu` need not be unit length (they
/// are normalised; a zero vector gives NaN). Computed as
/// `exp(κ (μ·x − 1)) · κ / (2π (1 − e^{−2κ}))`, finite for any finite κ.
pub fn von_mises_fisher_density(x: [f64; 3], mu: [f64; 3], kappa: f64) -> f64 {
    let c = dot(&x, &mu) / (norm(&x) * norm(&mu));
    von_mises_fisher_from_cos(c.clamp(-1.0, 1.0), kappa)
}

/// Modality of the planar FVMM built from the sub-policy actions `actions` (velocities in
/// the plane, m/s; only their directions matter) and goal beliefs `beliefs`
/// (any non-negative scale; normalised over the usable components). Components are
/// paired by index; extra entries of the longer slice are ignored.
///
/// Robustness: a component is skipped (treated as carrying no information) when its
/// action has a non-finite coordinate or a speed below `settings.min_speed`, or its
/// belief is NaN, infinite, zero or negative. With no usable component (empty input,
/// all skipped) the result is `Modality { multimodal: false, peak_ratio: 1.0 }`: there
/// is no disagreement to detect. Never panics; allocation-free, O(G²) evaluations.
pub fn planar_modality(actions: &[[f64; 2]], beliefs: &[f64], settings: &DecisionSettings) -> Modality {
    modality(actions, beliefs, settings, von_mises_from_cos)
}

/// Modality of the spatial mixture of von Mises–Fisher components on S², built from 3-D
/// sub-policy actions `actions` (m/s; only their directions matter) and goal beliefs
/// `beliefs`. Same semantics, robustness rules and cost as [`planar_modality`].
pub fn spatial_modality(actions: &[[f64; 3]], beliefs: &[f64], settings: &DecisionSettings) -> Modality {
    modality(actions, beliefs, settings, von_mises_fisher_from_cos)
}

fn dot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm<const D: usize>(a: &[f64; D]) -> f64 {
    dot(a, a).sqrt()
}

/// Unit direction of a usable action, or `None`.
fn direction<const D: usize>(a: &[f64; D], min_speed: f64) -> Option<[f64; D]> {
    if a.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // Scale first so that huge or tiny finite components neither overflow nor underflow.
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        return None;
    }
    let mut u = *a;
    u.iter_mut().for_each(|v| *v /= scale);
    let n = norm(&u);
    if n * scale < min_speed {
        return None;
    }
    u.iter_mut().for_each(|v| *v /= n);
    Some(u)
}

fn usable_belief(b: f64) -> Option<f64> {
    (b.is_finite() && b > 0.0).then_some(b)
}

fn modality<const D: usize>(
    actions: &[[f64; D]],
    beliefs: &[f64],
    settings: &DecisionSettings,
    density: fn(f64, f64) -> f64,
) -> Modality {
    let no_information = Modality { multimodal: false, peak_ratio: 1.0 };
    let min_speed = if settings.min_speed.is_nan() { 0.0 } else { settings.min_speed.max(0.0) };
    let components =
        || actions.iter().zip(beliefs).filter_map(move |(a, &b)| Some((direction(a, min_speed)?, usable_belief(b)?)));

    // Normalise the beliefs; divide by the largest first so the sum cannot overflow.
    let largest = components().fold(0.0f64, |m, (_, b)| m.max(b));
    if largest <= 0.0 {
        return no_information;
    }
    let total: f64 = components().map(|(_, b)| b / largest).sum();
    let weight = |b: f64| b / largest / total;
    let kappa = |w: f64| {
        let k = settings.kappa_min + w * (settings.kappa_max - settings.kappa_min);
        if k.is_nan() { 0.0 } else { k.clamp(0.0, KAPPA_CAP) }
    };

    // Consensus peak: the mixture value at a mean if every component pointed there.
    let consensus: f64 = components()
        .map(|(_, b)| {
            let w = weight(b);
            w * density(1.0, kappa(w))
        })
        .sum();
    if !(consensus > 0.0 && consensus.is_finite()) {
        return no_information;
    }

    let mut ratio = 0.0;
    for (mu_g, b_g) in components() {
        let at_mean: f64 = components()
            .map(|(mu_h, b_h)| {
                let w = weight(b_h);
                w * density(dot(&mu_g, &mu_h).clamp(-1.0, 1.0), kappa(w))
            })
            .sum();
        ratio += weight(b_g) * at_mean / consensus;
    }
    if ratio.is_nan() {
        return no_information;
    }
    let peak_ratio = ratio.clamp(0.0, 1.0);
    Modality { multimodal: peak_ratio < settings.threshold, peak_ratio }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    fn planar(deg: f64) -> [f64; 2] {
        let r = deg.to_radians();
        [0.2 * r.cos(), 0.2 * r.sin()]
    }

    fn spatial(deg: f64) -> [f64; 3] {
        // A tilted great circle, so that no coordinate axis is special.
        let r = deg.to_radians();
        let (e1, e2) = ([0.6, 0.0, 0.8], [0.0, 1.0, 0.0]);
        let v = |i: usize| 0.3 * (r.cos() * e1[i] + r.sin() * e2[i]);
        [v(0), v(1), v(2)]
    }

    #[test]
    fn i0_matches_reference_values() {
        // Reference values from mpmath (30 digits).
        let cases = [
            (0.0, 1.0),
            (0.5, 1.063_483_370_741_323_5),
            (1.0, 1.266_065_877_752_008_4),
            (3.75, 9.118_945_860_844_567),
            (10.0, 2_815.716_628_466_254_5),
            (15.0, 339_649.373_297_913_9),
            (20.0, 43_558_282.559_553_53),
            (50.0, 2.932_553_783_849_336_3e20),
            (100.0, 1.073_751_707_131_073_8e42),
        ];
        for (x, want) in cases {
            assert!(rel(bessel_i0(x), want) < 1e-13, "I0({x}) = {}", bessel_i0(x));
            assert!(rel(bessel_i0(-x), want) < 1e-13, "I0 is even");
        }
        let scaled = [
            (16.0, 0.100_544_127_361_252_02),
            (20.0, 0.089_780_311_884_826_02),
            (100.0, 0.039_944_379_299_096_68),
            (700.0, 0.015_081_295_651_531_358),
        ];
        for (x, want) in scaled {
            assert!(rel(bessel_i0_scaled(x), want) < 1e-13, "I0e({x})");
        }
        // Both branches agree at the switch-over point.
        let x = I0_SERIES_LIMIT;
        assert!(rel(i0_series(x) * (-x).exp(), i0_asymptotic_scaled(x)) < 1e-14);
        assert_eq!(bessel_i0(800.0), f64::INFINITY);
    }

    #[test]
    fn von_mises_values_and_normalisation() {
        let peak = von_mises_density(0.3, 0.3, 1.0);
        assert!(rel(peak, 1f64.exp() / (2.0 * PI * 1.266_065_877_752_008_4)) < 1e-14);
        assert!(rel(von_mises_density(1.0, -2.0, 0.0), 1.0 / (2.0 * PI)) < 1e-15);
        // Symmetric, periodic, mode at mu.
        assert!(rel(von_mises_density(0.7, 0.2, 3.0), von_mises_density(-0.3, 0.2, 3.0)) < 1e-14);
        assert!(rel(von_mises_density(0.7 + 2.0 * PI, 0.2, 3.0), von_mises_density(0.7, 0.2, 3.0)) < 1e-12);
        // Large kappa: finite, Gaussian-like peak sqrt(κ/2π).
        let big = von_mises_density(1.0, 1.0, 1.0e5);
        assert!(big.is_finite() && rel(big, (1.0e5 / (2.0 * PI)).sqrt()) < 1e-5);
        assert!(rel(von_mises_density(0.0, 0.0, -4.0), von_mises_density(PI, 0.0, 4.0)) < 1e-14);
        // Periodic trapezoid rule: spectrally accurate.
        let n = 8192;
        for kappa in [0.0, 0.5, 2.0, 10.5, 100.0, 1000.0, -3.0] {
            let h = 2.0 * PI / n as f64;
            let integral: f64 = (0..n).map(|i| von_mises_density(i as f64 * h, 1.1, kappa) * h).sum();
            assert!((integral - 1.0).abs() < 1e-10, "κ = {kappa}: ∫ = {integral}");
        }
    }

    #[test]
    fn von_mises_fisher_values_and_normalisation() {
        let mu = [1.0, 2.0, 2.0]; // not unit length on purpose
        let unit = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
        let x = [0.3, -0.5, 0.8];
        for kappa in [0.5, 3.0, 20.0] {
            let xn = norm(&x);
            let closed = kappa / (4.0 * PI * f64::sinh(kappa)) * (kappa * dot(&unit, &x) / xn).exp();
            assert!(rel(von_mises_fisher_density(x, mu, kappa), closed) < 1e-12);
        }
        assert!(rel(von_mises_fisher_density(x, mu, 0.0), 1.0 / (4.0 * PI)) < 1e-15);
        assert!(rel(von_mises_fisher_density(x, mu, 1e-12), 1.0 / (4.0 * PI)) < 1e-9);
        let big = von_mises_fisher_density(unit, mu, 1.0e4);
        assert!(rel(big, 1.0e4 / (2.0 * PI)) < 1e-12, "stable for large κ: {big}");
        assert!(von_mises_fisher_density([0.0; 3], mu, 1.0).is_nan());

        // Quadrature over S² in (z, φ): midpoint in z, periodic trapezoid in φ.
        let (nz, nphi) = (1500, 360);
        for kappa in [0.0, 1.0, 10.0, 100.0] {
            let mut integral = 0.0;
            for i in 0..nz {
                let z = -1.0 + (i as f64 + 0.5) * 2.0 / nz as f64;
                let r = (1.0 - z * z).sqrt();
                for j in 0..nphi {
                    let phi = j as f64 * 2.0 * PI / nphi as f64;
                    let p = [r * phi.cos(), r * phi.sin(), z];
                    integral += von_mises_fisher_density(p, mu, kappa);
                }
            }
            integral *= (2.0 / nz as f64) * (2.0 * PI / nphi as f64);
            assert!((integral - 1.0).abs() < 1e-4, "κ = {kappa}: ∫ = {integral}");
        }
    }

    #[test]
    fn identical_directions_are_unimodal() {
        let s = DecisionSettings::default();
        let m = planar_modality(&[planar(40.0), planar(40.0)], &[0.5, 0.5], &s);
        assert!(!m.multimodal);
        assert!((m.peak_ratio - 1.0).abs() < 1e-12);
        let m = spatial_modality(&[spatial(40.0), spatial(40.0)], &[0.3, 0.7], &s);
        assert!(!m.multimodal);
        assert!((m.peak_ratio - 1.0).abs() < 1e-12);
        // A single usable component is trivially unimodal.
        let m = planar_modality(&[planar(10.0)], &[0.2], &s);
        assert!(!m.multimodal && (m.peak_ratio - 1.0).abs() < 1e-12);
    }

    #[test]
    fn opposite_equal_directions_are_multimodal() {
        let s = DecisionSettings::default();
        let m = planar_modality(&[planar(0.0), planar(180.0)], &[0.5, 0.5], &s);
        assert!(m.multimodal);
        assert!((m.peak_ratio - 0.5).abs() < 1e-6, "{m:?}");
        let m = spatial_modality(&[spatial(0.0), spatial(180.0)], &[0.5, 0.5], &s);
        assert!(m.multimodal);
        assert!((m.peak_ratio - 0.5).abs() < 1e-6, "{m:?}");
    }

    #[test]
    fn dominant_goal_is_unimodal() {
        let s = DecisionSettings::default();
        let m = planar_modality(&[planar(0.0), planar(180.0)], &[0.99, 0.01], &s);
        assert!(!m.multimodal);
        assert!(m.peak_ratio > 0.97, "{m:?}");
        let m = spatial_modality(&[spatial(0.0), spatial(180.0)], &[0.01, 0.99], &s);
        assert!(!m.multimodal);
        assert!(m.peak_ratio > 0.97, "{m:?}");
    }

    #[test]
    fn close_directions_unimodal_wide_directions_multimodal() {
        // Equal beliefs -> κ = 10.5 for both components (σ ≈ 18°).
        let s = DecisionSettings::default();
        let close = planar_modality(&[planar(5.0), planar(15.0)], &[0.5, 0.5], &s);
        assert!(!close.multimodal && close.peak_ratio > 0.9, "{close:?}");
        let wide = planar_modality(&[planar(0.0), planar(120.0)], &[0.5, 0.5], &s);
        assert!(wide.multimodal && (wide.peak_ratio - 0.5).abs() < 1e-6, "{wide:?}");
        let close = spatial_modality(&[spatial(5.0), spatial(15.0)], &[0.5, 0.5], &s);
        assert!(!close.multimodal && close.peak_ratio > 0.9, "{close:?}");
        let wide = spatial_modality(&[spatial(0.0), spatial(120.0)], &[0.5, 0.5], &s);
        assert!(wide.multimodal && (wide.peak_ratio - 0.5).abs() < 1e-6, "{wide:?}");
        // Three equally likely goals in three directions: ratio Σ w² = 1/3.
        let three = planar_modality(&[planar(0.0), planar(120.0), planar(240.0)], &[1.0, 1.0, 1.0], &s);
        assert!(three.multimodal && (three.peak_ratio - 1.0 / 3.0).abs() < 1e-4, "{three:?}");
    }

    #[test]
    fn verdict_flips_once_near_true_bimodality() {
        let s = DecisionSettings::default();
        let kappa = s.kappa_min + 0.5 * (s.kappa_max - s.kappa_min);
        // Two equal von Mises components at ±δ are bimodal iff κ sin²δ > cos δ.
        let c = (-1.0 / kappa + (1.0 / (kappa * kappa) + 4.0).sqrt()) / 2.0;
        let exact_deg = 2.0 * c.acos().to_degrees();
        let sweep = |f: &dyn Fn(f64) -> Modality| {
            let mut flips = Vec::new();
            let mut last_ratio = f64::INFINITY;
            let mut last = f(0.0).multimodal;
            assert!(!last);
            for i in 1..=360 {
                let deg = i as f64 * 0.5;
                let m = f(deg);
                assert!(m.peak_ratio <= last_ratio + 1e-12, "monotone at {deg}°");
                last_ratio = m.peak_ratio;
                if m.multimodal != last {
                    flips.push(deg);
                }
                last = m.multimodal;
            }
            assert!(last, "multimodal at 180°");
            assert_eq!(flips.len(), 1, "flips at {flips:?}");
            flips[0]
        };
        let flat = sweep(&|d| planar_modality(&[planar(30.0), planar(30.0 + d)], &[2.0, 2.0], &s));
        let round = sweep(&|d| spatial_modality(&[spatial(-d / 2.0), spatial(d / 2.0)], &[1.0, 1.0], &s));
        assert!((flat - exact_deg).abs() < 2.0, "flip {flat}° vs exact {exact_deg}°");
        assert!((round - flat).abs() <= 0.5, "3-D flip {round}° vs 2-D {flat}°");
    }

    #[test]
    fn scale_free_in_beliefs_and_speed() {
        let s = DecisionSettings::default();
        let a = planar_modality(&[planar(0.0), planar(50.0)], &[0.3, 0.6], &s);
        let b = planar_modality(&[[2.0, 0.0], [0.01 * 0.643, 0.01 * 0.766]], &[3.0, 6.0], &s);
        assert!((a.peak_ratio - b.peak_ratio).abs() < 1e-3, "{a:?} {b:?}");
        let c = planar_modality(&[[1e300, 0.0], [-1e300, 1e-300]], &[1e300, 1e300], &s);
        assert!(c.multimodal && (c.peak_ratio - 0.5).abs() < 1e-6, "{c:?}");
    }

    #[test]
    fn bad_inputs_carry_no_information() {
        let s = DecisionSettings::default();
        let none = Modality { multimodal: false, peak_ratio: 1.0 };
        let single = |m: Modality| assert!(!m.multimodal && (m.peak_ratio - 1.0).abs() < 1e-12, "{m:?}");
        assert_eq!(planar_modality(&[], &[], &s), none);
        assert_eq!(spatial_modality(&[], &[0.5], &s), none);
        assert_eq!(planar_modality(&[[0.0, 0.0], [0.0, 0.0]], &[0.5, 0.5], &s), none);
        assert_eq!(planar_modality(&[[f64::NAN, 0.0]], &[1.0], &s), none);
        assert_eq!(planar_modality(&[planar(0.0), planar(180.0)], &[0.0, 0.0], &s), none);
        assert_eq!(spatial_modality(&[spatial(0.0)], &[f64::NAN], &s), none);

        // A broken component is dropped; the rest is still judged.
        let opposite = [planar(0.0), planar(180.0)];
        for bad in [f64::NAN, f64::INFINITY, -1.0, 0.0] {
            single(planar_modality(&opposite, &[0.5, bad], &s));
        }
        let m = planar_modality(&[planar(0.0), [f64::NAN, 1.0], planar(180.0)], &[0.5, 0.5, 0.5], &s);
        assert!(m.multimodal && (m.peak_ratio - 0.5).abs() < 1e-6);
        let m = spatial_modality(&[spatial(0.0), [0.0, f64::INFINITY, 0.0], spatial(180.0)], &[1.0; 3], &s);
        assert!(m.multimodal);
        // Actions slower than min_speed have no direction.
        let slow = [planar(0.0), [-1e-4, 0.0]];
        single(planar_modality(&slow, &[0.5, 0.5], &s));
        // Mismatched lengths: extra entries ignored.
        single(planar_modality(&opposite, &[0.5], &s));

        // Broken settings never panic.
        let broken = DecisionSettings {
            kappa_min: f64::NAN,
            kappa_max: f64::INFINITY,
            threshold: f64::NAN,
            min_speed: f64::NAN,
        };
        for m in [
            planar_modality(&opposite, &[0.5, 0.5], &broken),
            spatial_modality(&[spatial(0.0), spatial(90.0)], &[0.5, 0.5], &broken),
        ] {
            assert!(!m.multimodal && (0.0..=1.0).contains(&m.peak_ratio), "{m:?}");
        }
        let negative = DecisionSettings { kappa_min: -5.0, kappa_max: -1.0, ..s };
        let m = planar_modality(&opposite, &[0.5, 0.5], &negative);
        assert!((m.peak_ratio - 1.0).abs() < 1e-12, "κ = 0: uniform components agree");
    }
}
