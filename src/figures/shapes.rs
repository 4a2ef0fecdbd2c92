//! Plane geometry the figures draw with: arrows, convex hulls, ellipses.

/// An arrow from `p` by `v` as one path: shaft, then a head of two barbs
/// a quarter of its length at ±25°.
pub(super) fn arrow(p: (f64, f64), v: (f64, f64)) -> Vec<(f64, f64)> {
    let tip = (p.0 + v.0, p.1 + v.1);
    let barb = |angle: f64| {
        let (s, c) = (std::f64::consts::PI + angle).sin_cos();
        (tip.0 + 0.25 * (c * v.0 - s * v.1), tip.1 + 0.25 * (s * v.0 + c * v.1))
    };
    vec![p, tip, barb(0.44), tip, barb(-0.44)]
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
pub(super) fn convex_hull(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points.iter().copied().filter(|q| q.0.is_finite() && q.1.is_finite()).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * p.len());
    for pass in [p.clone(), p.iter().rev().copied().collect()] {
        let floor = hull.len();
        for q in pass {
            while hull.len() >= floor + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

pub(super) fn closed(mut points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if let Some(&first) = points.first() {
        points.push(first);
    }
    points
}

/// Points of the ellipse with half-axes `a` (along `angle`) and `b`.
pub(super) fn circle_points(x: f64, y: f64, a: f64, b: f64, angle: f64) -> Vec<(f64, f64)> {
    let (s, c) = angle.sin_cos();
    (0..72)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / 72.0;
            let (u, v) = (a * t.cos(), b * t.sin());
            (x + c * u - s * v, y + s * u + c * v)
        })
        .collect()
}

/// Half-axes and angle of the ellipse of a symmetric 2 × 2 matrix
/// (eigenvalues as lengths along the eigenvectors).
pub(super) fn ellipse_axes(m: &[f64; 4]) -> (f64, f64, f64) {
    let (p, q, r) = (m[0], 0.5 * (m[1] + m[2]), m[3]);
    let mean = 0.5 * (p + r);
    let spread = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    let angle = 0.5 * (2.0 * q).atan2(p - r);
    ((mean + spread).max(0.0), (mean - spread).max(0.0), angle)
}
