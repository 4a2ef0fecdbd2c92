//! Point-to-plane ICP (Chen & Medioni 1992): measured points pulled onto
//! the tangent planes of a model's surface points, Gauss-Newton on the
//! pose.
//!
//! The model is a set of surface points with outward normals in the
//! object's frame ([`SurfaceModel`], sampled once from a mesh, with a k-d
//! tree). The pose `T` maps the object into the world; each iteration
//! moves the measured points into the object's frame by `T⁻¹`, pairs each
//! with its nearest model point within
//! [`IcpSettings::max_correspondence_distance`], and takes the
//! Gauss-Newton step of `Σ (n·(T⁻¹x − y))²` over a left perturbation of
//! `T⁻¹`, damped as Levenberg-Marquardt's (a step that raises the cost is
//! refused and the next one shorter). It stops when a step moves less than
//! both tolerances.

use super::PerceptionError;
use crate::point_cloud::PointTree;
use nalgebra::{IsometryMatrix3, Matrix6, Rotation3, Translation3, Vector3, Vector6};

/// An object's surface for registration: points and outward unit normals
/// in the object's frame (m), and a k-d tree over the points.
#[derive(Debug, Clone)]
pub struct SurfaceModel {
    points: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    tree: PointTree,
}

impl SurfaceModel {
    /// The model from points and their normals (object frame; normals are
    /// normalised here).
    ///
    /// # Errors
    /// Lengths that differ, no points, a non-finite point, a zero normal.
    pub fn new(points: Vec<[f64; 3]>, normals: Vec<[f64; 3]>) -> Result<SurfaceModel, PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("surface model", None, m));
        if points.len() != normals.len() {
            return bad(format!("{} points and {} normals", points.len(), normals.len()));
        }
        if points.is_empty() {
            return bad("no points".into());
        }
        let mut unit = Vec::with_capacity(normals.len());
        for (i, (p, n)) in points.iter().zip(&normals).enumerate() {
            let nv = Vector3::from(*n);
            let norm = nv.norm();
            if !(p.iter().all(|c| c.is_finite()) && norm.is_finite() && norm > 1e-12) {
                return bad(format!("point {i} {p:?} or its normal {n:?} is not finite and non-zero"));
            }
            unit.push((nv / norm).into());
        }
        let tree = PointTree::new(&points);
        Ok(SurfaceModel { points, normals: unit, tree })
    }

    /// The surface points (object frame, m).
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// The unit normals, one per point.
    pub fn normals(&self) -> &[[f64; 3]] {
        &self.normals
    }

    /// The model point nearest `p` (object frame) closer than `cap` (m):
    /// its index and distance (m).
    pub fn nearest(&self, p: &[f64; 3], cap: f64) -> Option<(usize, f64)> {
        self.tree.nearest(p, cap).map(|(d2, k)| (self.tree.point(k).1, d2.sqrt()))
    }
}

/// Settings of point-to-plane ICP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcpSettings {
    /// The most Gauss-Newton iterations (default 50).
    pub max_iterations: usize,
    /// Measured points farther than this from every model point are left
    /// out of an iteration (m, default 0.02).
    pub max_correspondence_distance: f64,
    /// Stop when a step translates less than this (m, default 1e-8) …
    pub translation_tolerance: f64,
    /// … and rotates less than this (rad, default 1e-8).
    pub rotation_tolerance: f64,
}

impl Default for IcpSettings {
    fn default() -> IcpSettings {
        IcpSettings {
            max_iterations: 50,
            max_correspondence_distance: 0.02,
            translation_tolerance: 1e-8,
            rotation_tolerance: 1e-8,
        }
    }
}

impl IcpSettings {
    /// Checks every value.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("ICP settings", None, m));
        let d = self.max_correspondence_distance;
        if !(d.is_finite() && d > 0.0) {
            return bad(format!("max_correspondence_distance {d} must be finite and positive"));
        }
        for (name, v) in
            [("translation_tolerance", self.translation_tolerance), ("rotation_tolerance", self.rotation_tolerance)]
        {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} {v} must be finite and at least 0"));
            }
        }
        Ok(())
    }
}

/// What ICP found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcpResult {
    /// The object's pose in the world.
    pub pose: IsometryMatrix3<f64>,
    /// Root-mean-square point-to-plane distance of the paired points at
    /// the final pose (m).
    pub rmse: f64,
    /// Share of the measured points paired at the final pose.
    pub paired_fraction: f64,
    /// Iterations run.
    pub iterations: usize,
    /// Whether a proposed step went below both tolerances.
    pub converged: bool,
}

/// Registers the measured `points` (world frame, m) to `model` from the
/// `initial` pose of the object in the world.
///
/// # Errors
/// Settings out of range, no points, a non-finite point or pose.
pub fn point_to_plane_icp(
    model: &SurfaceModel,
    points: &[[f64; 3]],
    initial: &IsometryMatrix3<f64>,
    settings: &IcpSettings,
) -> Result<IcpResult, PerceptionError> {
    settings.validate()?;
    if points.is_empty() {
        return Err(PerceptionError::new("ICP", None, "no measured points"));
    }
    if let Some(i) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(PerceptionError::new("ICP", None, format!("measured point {i} is not finite: {:?}", points[i])));
    }
    if !initial.to_homogeneous().iter().all(|v| v.is_finite()) {
        return Err(PerceptionError::new("ICP", None, "the initial pose is not finite"));
    }
    // `inv` maps the world into the object's frame.
    let mut inv = initial.inverse();
    let cap = settings.max_correspondence_distance;
    let mut iterations = 0;
    let mut converged = false;
    let (mut h, mut g, mut cost, _) = normal_equations(model, points, &inv, cap);
    // Levenberg-Marquardt's damping, relative to JᵀJ's largest diagonal:
    // a step that raises the cost (pairs changing under it) is refused and
    // the next one shorter, so the pose settles instead of cycling between
    // two sets of pairs. A sphere leaves its rotation free, a cylinder its
    // spin: the damping also keeps those steps finite.
    let mut lambda = 1e-6;
    while iterations < settings.max_iterations {
        iterations += 1;
        let scale = (0..6).map(|i| h[(i, i)]).fold(0.0, f64::max).max(1e-30);
        let Some(chol) = (h + Matrix6::identity() * (lambda * scale)).cholesky() else {
            break;
        };
        let step = -chol.solve(&g);
        let omega = Vector3::new(step[0], step[1], step[2]);
        let v = Vector3::new(step[3], step[4], step[5]);
        if v.norm() < settings.translation_tolerance && omega.norm() < settings.rotation_tolerance {
            converged = true;
            break;
        }
        let candidate = IsometryMatrix3::from_parts(Translation3::from(v), Rotation3::new(omega)) * inv;
        let (h2, g2, cost2, _) = normal_equations(model, points, &candidate, cap);
        if cost2 <= cost {
            (inv, h, g, cost) = (candidate, h2, g2, cost2);
            lambda = (lambda / 3.0).max(1e-12);
        } else {
            lambda *= 4.0;
        }
    }
    let (_, _, sum_sq, paired) = normal_equations(model, points, &inv, cap);
    let rmse = if paired > 0 { (sum_sq / paired as f64).sqrt() } else { f64::INFINITY };
    Ok(IcpResult {
        pose: inv.inverse(),
        rmse,
        paired_fraction: paired as f64 / points.len() as f64,
        iterations,
        converged,
    })
}

/// Gauss-Newton's `JᵀJ`, `Jᵀr`, `Σr²` and the number of pairs at `inv`
/// (world → object), each residual `n·(x' − y)` with `x' = inv·x`, its
/// Jacobian `[x' × n, n]` for the perturbation `exp(ω, v)·inv`.
fn normal_equations(
    model: &SurfaceModel,
    points: &[[f64; 3]],
    inv: &IsometryMatrix3<f64>,
    cap: f64,
) -> (Matrix6<f64>, Vector6<f64>, f64, usize) {
    let mut h = Matrix6::zeros();
    let mut g = Vector6::zeros();
    let mut sum_sq = 0.0;
    let mut paired = 0;
    for p in points {
        let x = inv * nalgebra::Point3::from(*p);
        let Some((k, _)) = model.nearest(&[x.x, x.y, x.z], cap) else {
            continue;
        };
        let n = Vector3::from(model.normals[k]);
        let y = Vector3::from(model.points[k]);
        let r = n.dot(&(x.coords - y));
        let c = x.coords.cross(&n);
        let j = Vector6::new(c.x, c.y, c.z, n.x, n.y, n.z);
        h += j * j.transpose();
        g += j * r;
        sum_sq += r * r;
        paired += 1;
    }
    (h, g, sum_sq, paired)
}
