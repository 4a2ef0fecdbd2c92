//! How far an estimated pose is from the truth: ADD and ADD-S
//! (Hinterstoisser et al., ACCV 2012; eq. 7.3–7.4 of the dissertation) and
//! the area under their accuracy–threshold curve (PoseCNN's AUC, to 10 cm).

use crate::point_cloud::PointTree;
use nalgebra::{IsometryMatrix3, Point3};

/// ADD (m): the mean distance between the model's points moved by the
/// true pose and by the estimate.
pub fn add(points: &[[f64; 3]], truth: &IsometryMatrix3<f64>, estimate: &IsometryMatrix3<f64>) -> f64 {
    let sum: f64 = points
        .iter()
        .map(|p| {
            let p = Point3::from(*p);
            (truth * p - estimate * p).norm()
        })
        .sum();
    sum / points.len().max(1) as f64
}

/// ADD-S (m): the mean, over the model's points moved by the true pose,
/// of the distance to the nearest model point moved by the estimate — ADD
/// for symmetric objects, where a turn that maps the object onto itself
/// is no error.
pub fn add_s(points: &[[f64; 3]], truth: &IsometryMatrix3<f64>, estimate: &IsometryMatrix3<f64>) -> f64 {
    let moved: Vec<[f64; 3]> = points.iter().map(|p| (estimate * Point3::from(*p)).coords.into()).collect();
    let tree = PointTree::new(&moved);
    let sum: f64 = points
        .iter()
        .map(|p| {
            let q = truth * Point3::from(*p);
            tree.nearest(&[q.x, q.y, q.z], f64::INFINITY).map_or(f64::INFINITY, |(d2, _)| d2.sqrt())
        })
        .sum();
    sum / points.len().max(1) as f64
}

/// The area under the accuracy–threshold curve of `errors` (m) for
/// thresholds from 0 to `max` (m), in percent: 100 when every error is 0.
/// A missing estimate counts as an infinite error.
pub fn auc(errors: &[f64], max: f64) -> f64 {
    if errors.is_empty() || max.is_nan() || max <= 0.0 {
        return 0.0;
    }
    // ∫₀^max share(e ≤ t) dt / max = mean over errors of (max − min(e, max)) / max.
    let sum: f64 = errors.iter().map(|e| if e.is_nan() { 0.0 } else { (max - e.min(max)) / max }).sum();
    100.0 * sum / errors.len() as f64
}

/// The share of `errors` (m) under `threshold`, in percent.
pub fn share_below(errors: &[f64], threshold: f64) -> f64 {
    if errors.is_empty() {
        return 0.0;
    }
    100.0 * errors.iter().filter(|e| **e < threshold).count() as f64 / errors.len() as f64
}
