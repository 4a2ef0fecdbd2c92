//! Rigid coherent point drift (Myronenko & Song, "Point Set Registration:
//! Coherent Point Drift", IEEE TPAMI 2010, Fig. 2): the registration the
//! dissertation's *mesh_pose* uses (§7.4.1).
//!
//! The moving set `Y` (points sampled from an object's mesh, in the
//! object's frame) are the centroids of a Gaussian mixture of one
//! variance σ², with a uniform component of weight `w` for outliers; the
//! fixed set `X` (the segmented depth points, world frame) is its data.
//! Each EM iteration computes the posteriors `P[m, n]` and the closed-form
//! rotation (an SVD of a 3 × 3 matrix, reflection excluded), translation,
//! optionally the scale, and σ². The transform maps the model into the
//! world: `T(y) = s R y + t`.
//!
//! Nothing of `P` (M × N) is stored: each iteration walks the data once,
//! one row of M posteriors at a time, and accumulates what the M-step
//! needs. The cost is M·N exponentials an iteration — a few hundred points
//! on either side keep it near a millisecond.

use super::PerceptionError;
use nalgebra::{Matrix3, Vector3};

/// Settings of rigid CPD.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CpdSettings {
    /// Weight of the uniform outlier component, in [0, 1) (default 0.1:
    /// the segmented points hold some of the table and of neighbours).
    pub outlier_weight: f64,
    /// The most EM iterations (default 100).
    pub max_iterations: usize,
    /// Stop when the negative log-likelihood changes by less than this
    /// (default 1e-8; 0 runs every iteration).
    pub tolerance: f64,
    /// Estimate a scale too (default false: a mesh has its true size).
    pub estimate_scale: bool,
    /// The initial σ² (m²); `None` takes CPD's own start, the mean squared
    /// distance between every pair of points.
    pub initial_variance: Option<f64>,
}

impl Default for CpdSettings {
    fn default() -> CpdSettings {
        CpdSettings {
            outlier_weight: 0.1,
            max_iterations: 100,
            tolerance: 1e-8,
            estimate_scale: false,
            initial_variance: None,
        }
    }
}

impl CpdSettings {
    /// Checks every value.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("CPD settings", None, m));
        if !(0.0..1.0).contains(&self.outlier_weight) {
            return bad(format!("outlier_weight {} must lie in [0, 1)", self.outlier_weight));
        }
        if self.tolerance.is_nan() || self.tolerance < 0.0 {
            return bad(format!("tolerance {} must be at least 0", self.tolerance));
        }
        if let Some(v) = self.initial_variance
            && !(v.is_finite() && v > 0.0)
        {
            return bad(format!("initial_variance {v} must be finite and positive"));
        }
        Ok(())
    }
}

/// A rigid (or similarity) transform found by CPD: `T(y) = s R y + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CpdResult {
    /// Rotation `R`.
    pub rotation: Matrix3<f64>,
    /// Translation `t` (m).
    pub translation: Vector3<f64>,
    /// Scale `s` (1 unless estimated).
    pub scale: f64,
    /// The final variance σ² (m²).
    pub variance: f64,
    /// EM iterations run.
    pub iterations: usize,
    /// Whether the tolerance was reached before `max_iterations`.
    pub converged: bool,
}

/// Scratch of one CPD run, kept to reuse its buffers.
#[derive(Debug, Clone, Default)]
pub struct CpdWorkspace {
    /// The moving points, transformed (m).
    moved: Vec<Vector3<f64>>,
    /// One row of unnormalised posteriors, `exp(−d²/2σ²)` over m.
    row: Vec<f64>,
    /// `P 1`: each moving point's total posterior.
    p1: Vec<f64>,
}

/// Registers `moving` (`Y`, e.g. model points) onto `fixed` (`X`, e.g.
/// measured points) by rigid CPD from the initial transform
/// (`rotation`, `translation`, `scale`).
///
/// # Errors
/// Settings out of range, an empty or non-finite point set, or an initial
/// transform that is not finite.
pub fn rigid_cpd(
    fixed: &[[f64; 3]],
    moving: &[[f64; 3]],
    initial: (Matrix3<f64>, Vector3<f64>, f64),
    settings: &CpdSettings,
    ws: &mut CpdWorkspace,
) -> Result<CpdResult, PerceptionError> {
    settings.validate()?;
    for (name, set) in [("fixed", fixed), ("moving", moving)] {
        if set.is_empty() {
            return Err(PerceptionError::new("CPD", None, format!("the {name} point set is empty")));
        }
        if let Some(i) = set.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(PerceptionError::new("CPD", None, format!("{name} point {i} is not finite: {:?}", set[i])));
        }
    }
    let (mut r, mut t, mut s) = initial;
    if !(r.iter().all(|v| v.is_finite()) && t.iter().all(|v| v.is_finite()) && s.is_finite() && s > 0.0) {
        return Err(PerceptionError::new(
            "CPD",
            None,
            "the initial transform is not finite (or its scale not positive)",
        ));
    }
    let (n, m) = (fixed.len(), moving.len());
    // Both sets shifted by their own means: the sums below then cancel
    // nothing large (points a metre away, objects a few centimetres).
    let mean = |set: &[[f64; 3]]| set.iter().fold(Vector3::zeros(), |a, p| a + Vector3::from(*p)) / set.len() as f64;
    let (cx, cy) = (mean(fixed), mean(moving));
    let x: Vec<Vector3<f64>> = fixed.iter().map(|p| Vector3::from(*p) - cx).collect();
    let y: Vec<Vector3<f64>> = moving.iter().map(|p| Vector3::from(*p) - cy).collect();
    // In shifted coordinates: T'(y') = s R y' + t' with t' = s R cy + t − cx.
    let mut tp = s * r * cy + t - cx;

    ws.moved.clear();
    ws.moved.extend(y.iter().map(|yi| s * r * yi + tp));
    ws.row.clear();
    ws.row.resize(m, 0.0);
    ws.p1.clear();
    ws.p1.resize(m, 0.0);

    let mut sigma2 = match settings.initial_variance {
        Some(v) => v,
        None => {
            // Σ‖x − T(y)‖² over all pairs, without the N × M loop:
            // N Σ‖T(y)‖² + M Σ‖x‖² − 2 (Σx)·(ΣT(y)).
            let (sx, sty) = (x.iter().sum::<Vector3<f64>>(), ws.moved.iter().sum::<Vector3<f64>>());
            let xx: f64 = x.iter().map(|v| v.norm_squared()).sum();
            let yy: f64 = ws.moved.iter().map(|v| v.norm_squared()).sum();
            (n as f64 * yy + m as f64 * xx - 2.0 * sx.dot(&sty)) / (3.0 * (n * m) as f64)
        }
    };
    let w = settings.outlier_weight;
    let mut q_prev = f64::INFINITY;
    let mut iterations = 0;
    let mut converged = false;
    while iterations < settings.max_iterations {
        // E-step, one data point at a time.
        let c = (2.0 * std::f64::consts::PI * sigma2).powf(1.5) * w / (1.0 - w) * m as f64 / n as f64;
        let inv = -0.5 / sigma2;
        ws.p1.iter_mut().for_each(|v| *v = 0.0);
        let (mut np, mut sum_x, mut xpx_raw) = (0.0, Vector3::zeros(), 0.0);
        let mut sum_xy = Matrix3::zeros();
        for xn in &x {
            let mut den = 0.0;
            for (e, ty) in ws.row.iter_mut().zip(&ws.moved) {
                *e = ((xn - ty).norm_squared() * inv).exp();
                den += *e;
            }
            if den == 0.0 {
                den = f64::EPSILON;
            }
            den += c;
            let mut pt1 = 0.0;
            let mut py = Vector3::zeros();
            for ((e, p1), ym) in ws.row.iter().zip(ws.p1.iter_mut()).zip(&y) {
                let p = e / den;
                *p1 += p;
                pt1 += p;
                py += p * ym;
            }
            np += pt1;
            sum_x += pt1 * xn;
            xpx_raw += pt1 * xn.norm_squared();
            sum_xy += xn * py.transpose();
        }
        if np.is_nan() || np <= 0.0 {
            return Err(PerceptionError::new(
                "CPD",
                None,
                format!("no point is explained by the model (σ² {sigma2:e} m²)"),
            ));
        }
        // M-step.
        let mu_x = sum_x / np;
        let mu_y = ws.p1.iter().zip(&y).fold(Vector3::zeros(), |a, (p, ym)| a + *p * ym) / np;
        let a = sum_xy - np * mu_x * mu_y.transpose();
        let ypy: f64 = ws.p1.iter().zip(&y).map(|(p, ym)| p * (ym - mu_y).norm_squared()).sum();
        let xpx = xpx_raw - np * mu_x.norm_squared();
        let svd = a.svd(true, true);
        let (u, v_t) = (svd.u.expect("requested"), svd.v_t.expect("requested"));
        let mut d = Matrix3::identity();
        d[(2, 2)] = (u * v_t).determinant().signum();
        r = u * d * v_t;
        let tr_ar = (a.transpose() * r).trace();
        if settings.estimate_scale {
            s = tr_ar / ypy;
        }
        tp = mu_x - s * r * mu_y;
        // The objective before σ² moves, as CPD's convergence test has it.
        let q = (xpx - 2.0 * s * tr_ar + s * s * ypy) / (2.0 * sigma2) + 1.5 * np * sigma2.ln();
        sigma2 = (xpx - 2.0 * s * tr_ar + s * s * ypy) / (3.0 * np);
        if sigma2.is_nan() || sigma2 <= 0.0 {
            // The model fits exactly (or rounding went below zero).
            sigma2 = (settings.tolerance / 10.0).max(1e-16);
        }
        for (mv, ym) in ws.moved.iter_mut().zip(&y) {
            *mv = s * r * ym + tp;
        }
        iterations += 1;
        let change = (q - q_prev).abs();
        q_prev = q;
        if change <= settings.tolerance {
            converged = true;
            break;
        }
    }
    t = tp + cx - s * r * cy;
    Ok(CpdResult { rotation: r, translation: t, scale: s, variance: sigma2, iterations, converged })
}
