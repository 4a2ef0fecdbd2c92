//! Signed distance between two placed convex shapes.
//!
//! Pairs with a sphere or capsule on one side reduce to the distance from a
//! point or a segment to the other shape and are computed in closed form;
//! every other pair goes through parry3d's GJK (separated) and EPA
//! (penetrating). All results are in world coordinates.

use crate::point_cloud::PointTree;
use crate::scene::Shape;
use nalgebra::{IsometryMatrix3, Point3, UnitQuaternion, Vector3};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Capsule, Cuboid, Cylinder};

/// How far apart two shapes are, with the points that realise it.
///
/// `point_b − point_a = distance · normal` (exactly for closed-form pairs,
/// to GJK/EPA's tolerance otherwise). When the shapes penetrate,
/// `distance` is minus the penetration depth and the witness points are the
/// deepest points of each shape inside the other.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignedDistance {
    /// Signed distance (m): positive apart, negative penetrating.
    pub distance: f64,
    /// Witness point on shape a (world, m).
    pub point_a: Point3<f64>,
    /// Witness point on shape b (world, m).
    pub point_b: Point3<f64>,
    /// Unit direction from a to b (world): moving b along it increases the distance.
    pub normal: Vector3<f64>,
}

impl SignedDistance {
    /// The same result seen from b.
    pub fn flipped(self) -> SignedDistance {
        SignedDistance { distance: self.distance, point_a: self.point_b, point_b: self.point_a, normal: -self.normal }
    }
}

/// A surface point of a shape closest to a query point: signed distance of
/// the query point to the surface (negative inside), the surface point and
/// the outward unit normal there, all world.
struct Surface {
    distance: f64,
    point: Point3<f64>,
    normal: Vector3<f64>,
}

/// Signed distance between shape `a` at world pose `pose_a` and shape `b`
/// at `pose_b` (shape frames to world). Allocation-free except for
/// penetrating pairs that need EPA (box, cylinder and hull pairs).
pub fn signed_distance(
    a: &Shape,
    pose_a: &IsometryMatrix3<f64>,
    b: &Shape,
    pose_b: &IsometryMatrix3<f64>,
) -> SignedDistance {
    signed_distance_within(a, pose_a, b, pose_b, f64::INFINITY)
}

/// [`signed_distance`], except that a point cloud's nearest point is only
/// searched for within `cap` (m) of the other shape: when none is that
/// close, the distance is +∞ (witnesses at the shapes' origins). Other
/// pairs are exact at any distance. For callers that keep only pairs
/// closer than a cutoff: an uncapped search on a large cloud costs many
/// times a capped one that finds nothing.
pub fn signed_distance_within(
    a: &Shape,
    pose_a: &IsometryMatrix3<f64>,
    b: &Shape,
    pose_b: &IsometryMatrix3<f64>,
    cap: f64,
) -> SignedDistance {
    match (a, b) {
        (_, Shape::Points { points, radius }) => to_points(a, pose_a, points, *radius, pose_b, cap),
        (Shape::Points { points, radius }, _) => to_points(b, pose_b, points, *radius, pose_a, cap).flipped(),
        (Shape::Sphere { radius }, _) => point_to_shape(&pose_a.translation.vector.into(), *radius, b, pose_b),
        (_, Shape::Sphere { radius }) => {
            point_to_shape(&pose_b.translation.vector.into(), *radius, a, pose_a).flipped()
        }
        (Shape::Capsule { radius: ra, half_length: la }, Shape::Capsule { radius: rb, half_length: lb }) => {
            let (pa, qa) = segment(pose_a, *la);
            let (pb, qb) = segment(pose_b, *lb);
            let (ca, cb) = closest_points_segments(&pa, &qa, &pb, &qb);
            balls(&ca, *ra, &cb, *rb)
        }
        _ => general(a, pose_a, b, pose_b),
    }
}

/// Whether two placed shapes are closer than `threshold` (m, ≥ 0): cheaper
/// than [`signed_distance`] for pairs that need GJK, and never allocates.
pub fn closer_than(
    a: &Shape,
    pose_a: &IsometryMatrix3<f64>,
    b: &Shape,
    pose_b: &IsometryMatrix3<f64>,
    threshold: f64,
) -> bool {
    match (a, b) {
        (_, Shape::Points { points, radius }) => return near_points(a, pose_a, points, *radius, pose_b, threshold),
        (Shape::Points { points, radius }, _) => return near_points(b, pose_b, points, *radius, pose_a, threshold),
        _ => {}
    }
    let analytic = matches!(a, Shape::Sphere { .. })
        || matches!(b, Shape::Sphere { .. })
        || matches!((a, b), (Shape::Capsule { .. }, Shape::Capsule { .. }));
    if analytic {
        return signed_distance(a, pose_a, b, pose_b).distance < threshold;
    }
    let (pa, pb) = (parry_pose(a, pose_a), parry_pose(b, pose_b));
    with_parry(a, |ga| {
        with_parry(b, |gb| {
            if threshold <= 0.0 {
                query::intersection_test(&pa, ga, &pb, gb).map(|r| r.intersecting).unwrap_or(true)
            } else {
                query::distance(&pa, ga, &pb, gb).map(|d| d.distance < threshold).unwrap_or(true)
            }
        })
    })
}

/// `a` (at `pose_a`) against the balls of `radius` at `points` (placed by
/// `pose_b`): the nearest ball's distance; +∞ (witnesses at the shapes'
/// origins) when there is no ball within `cap` (m) of `a`.
fn to_points(
    a: &Shape,
    pose_a: &IsometryMatrix3<f64>,
    points: &PointTree,
    radius: f64,
    pose_b: &IsometryMatrix3<f64>,
    cap: f64,
) -> SignedDistance {
    // Rounded up a little: a ball the caller counts as within the cap must
    // not be cut off.
    let cap = cap * (1.0 + 1e-9) + 1e-12;
    let ball = |p: [f64; 3]| IsometryMatrix3::from_parts((pose_b * Point3::from(p)).coords.into(), pose_b.rotation);
    let center = pose_b.inverse_transform_point(&pose_a.translation.vector.into());
    let local = [center.x, center.y, center.z];
    let nearest = match a {
        Shape::Sphere { radius: ra } => points.nearest(&local, cap + ra + radius).map(|(_, i)| i),
        // Two clouds: the nearest pair, point by point of the first.
        Shape::Points { points: first, radius: ra } => {
            let mut best = (f64::INFINITY, None);
            for (p, _) in first.points() {
                let pose = IsometryMatrix3::from_parts((pose_a * Point3::from(p)).coords.into(), pose_a.rotation);
                let d = to_points(&Shape::Sphere { radius: *ra }, &pose, points, radius, pose_b, cap);
                if d.distance < best.0 || d.distance.is_nan() {
                    best = (d.distance, Some(d));
                }
            }
            return best.1.unwrap_or_else(|| nothing(pose_a, pose_b));
        }
        _ => {
            let sphere = Shape::Sphere { radius };
            let exact = |p| signed_distance(a, pose_a, &sphere, &ball(p)).distance;
            points.nearest_to(&local, a.bounding_radius(), cap, exact).map(|(_, i)| i)
        }
    };
    match nearest {
        Some(k) => signed_distance(a, pose_a, &Shape::Sphere { radius }, &ball(points.point(k).0)),
        None => nothing(pose_a, pose_b),
    }
}

/// The distance to an empty cloud: +∞, witnesses at the shapes' origins.
fn nothing(pose_a: &IsometryMatrix3<f64>, pose_b: &IsometryMatrix3<f64>) -> SignedDistance {
    SignedDistance {
        distance: f64::INFINITY,
        point_a: pose_a.translation.vector.into(),
        point_b: pose_b.translation.vector.into(),
        normal: Vector3::z(),
    }
}

/// Whether `a` comes closer than `threshold` (m) to a ball of `radius` at
/// one of `points` (placed by `pose_b`).
fn near_points(
    a: &Shape,
    pose_a: &IsometryMatrix3<f64>,
    points: &PointTree,
    radius: f64,
    pose_b: &IsometryMatrix3<f64>,
    threshold: f64,
) -> bool {
    let center = pose_b.inverse_transform_point(&pose_a.translation.vector.into());
    let local = [center.x, center.y, center.z];
    match a {
        Shape::Sphere { radius: ra } => points.any_closer(&local, ra + radius + threshold),
        Shape::Points { points: first, radius: ra } => first.points().any(|(p, _)| {
            let c = pose_b.inverse_transform_point(&(pose_a * Point3::from(p)));
            points.any_closer(&[c.x, c.y, c.z], ra + radius + threshold)
        }),
        _ => {
            let sphere = Shape::Sphere { radius };
            points.any_near(&local, a.bounding_radius() + radius, threshold, |p| {
                let pose = IsometryMatrix3::from_parts((pose_b * Point3::from(p)).coords.into(), pose_b.rotation);
                closer_than(a, pose_a, &sphere, &pose, threshold)
            })
        }
    }
}

/// A ball of `radius` at `center` against a shape.
fn point_to_shape(center: &Point3<f64>, radius: f64, b: &Shape, pose_b: &IsometryMatrix3<f64>) -> SignedDistance {
    let surface = match b {
        Shape::Sphere { radius: rb } => return balls(center, radius, &pose_b.translation.vector.into(), *rb),
        Shape::Capsule { radius: rb, half_length } => {
            let (p, q) = segment(pose_b, *half_length);
            return balls(center, radius, &closest_point_segment(center, &p, &q), *rb);
        }
        Shape::Box { half_extents } => in_shape_frame(pose_b, center, |p| point_box(p, half_extents)),
        Shape::Cylinder { radius: rb, half_length } => {
            in_shape_frame(pose_b, center, |p| point_cylinder(p, *rb, *half_length))
        }
        Shape::Points { points, radius: rb } => {
            let pose = IsometryMatrix3::translation(center.x, center.y, center.z);
            return to_points(&Shape::Sphere { radius }, &pose, points, *rb, pose_b, f64::INFINITY);
        }
        Shape::Convex(_) => {
            return general(
                &Shape::Sphere { radius },
                &IsometryMatrix3::translation(center.x, center.y, center.z),
                b,
                pose_b,
            );
        }
    };
    // The surface normal points from b towards the ball centre: a → b is its opposite.
    SignedDistance {
        distance: surface.distance - radius,
        point_a: center - surface.normal * radius,
        point_b: surface.point,
        normal: -surface.normal,
    }
}

/// Two balls: the distance between centres minus both radii.
fn balls(ca: &Point3<f64>, ra: f64, cb: &Point3<f64>, rb: f64) -> SignedDistance {
    let d = cb - ca;
    let norm = d.norm();
    // Concentric balls: any direction is a valid normal.
    let normal = if norm > 0.0 { d / norm } else { Vector3::z() };
    SignedDistance { distance: norm - ra - rb, point_a: ca + normal * ra, point_b: cb - normal * rb, normal }
}

/// Evaluates `f` on the point expressed in the shape frame and maps the
/// result back to world.
fn in_shape_frame(pose: &IsometryMatrix3<f64>, p: &Point3<f64>, f: impl FnOnce(&Vector3<f64>) -> Surface) -> Surface {
    let r = pose.rotation.matrix();
    let local = r.tr_mul(&(p.coords - pose.translation.vector));
    let s = f(&local);
    Surface { distance: s.distance, point: pose * s.point, normal: r * s.normal }
}

/// Point against a box of half extents `h` centred on the origin.
fn point_box(p: &Vector3<f64>, h: &Vector3<f64>) -> Surface {
    let excess = p.abs() - h;
    if excess.iter().any(|&e| e > 0.0) {
        let clamped = Vector3::new(p.x.clamp(-h.x, h.x), p.y.clamp(-h.y, h.y), p.z.clamp(-h.z, h.z));
        let d = p - clamped;
        let distance = d.norm();
        return Surface { distance, point: clamped.into(), normal: d / distance };
    }
    // Inside: the nearest face is the one of largest (least negative) excess.
    let axis = excess.imax();
    let sign = if p[axis] >= 0.0 { 1.0 } else { -1.0 };
    let mut point = *p;
    point[axis] = sign * h[axis];
    let mut normal = Vector3::zeros();
    normal[axis] = sign;
    Surface { distance: excess[axis], point: point.into(), normal }
}

/// Point against a cylinder along z of `radius` and `half_length`.
fn point_cylinder(p: &Vector3<f64>, radius: f64, half_length: f64) -> Surface {
    let rho = p.x.hypot(p.y);
    let radial = if rho > 0.0 { Vector3::new(p.x / rho, p.y / rho, 0.0) } else { Vector3::x() };
    let sz = if p.z >= 0.0 { 1.0 } else { -1.0 };
    let (dr, dz) = (rho - radius, p.z.abs() - half_length);
    let side = || Surface { distance: dr, point: (radial * radius + Vector3::z() * p.z).into(), normal: radial };
    let cap = || Surface { distance: dz, point: Point3::new(p.x, p.y, sz * half_length), normal: Vector3::z() * sz };
    match (dr > 0.0, dz > 0.0) {
        (true, true) => {
            let rim = radial * radius + Vector3::z() * (sz * half_length);
            let d = p - rim;
            let distance = d.norm();
            Surface { distance, point: rim.into(), normal: d / distance }
        }
        (true, false) => side(),
        (false, true) => cap(),
        (false, false) if dr > dz => side(),
        (false, false) => cap(),
    }
}

/// World end points of an axial shape's z segment.
fn segment(pose: &IsometryMatrix3<f64>, half_length: f64) -> (Point3<f64>, Point3<f64>) {
    let axis = pose.rotation.matrix().column(2) * half_length;
    let c = Point3::from(pose.translation.vector);
    (c - axis, c + axis)
}

fn closest_point_segment(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> Point3<f64> {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    a + ab * t
}

/// Closest points between segments [p1, q1] and [p2, q2] (Ericson,
/// Real-Time Collision Detection, §5.1.9).
fn closest_points_segments(
    p1: &Point3<f64>,
    q1: &Point3<f64>,
    p2: &Point3<f64>,
    q2: &Point3<f64>,
) -> (Point3<f64>, Point3<f64>) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    let tiny = f64::EPSILON * f64::EPSILON;
    if a <= tiny && e <= tiny {
        return (*p1, *p2);
    }
    let (s, t) = if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            // Parallel segments: any s works; 0 is as good as another.
            let mut s = if denom > tiny * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (p1 + d1 * s, p2 + d2 * t)
}

/// parry3d's pose for a shape; its cylinder runs along y, ours along z.
fn parry_pose(shape: &Shape, pose: &IsometryMatrix3<f64>) -> parry3d_f64::math::Pose {
    let rotation = if shape.needs_y_to_z() {
        pose.rotation * nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2)
    } else {
        pose.rotation
    };
    nalgebra::Isometry3::from_parts(pose.translation, UnitQuaternion::from_rotation_matrix(&rotation)).into()
}

/// Calls `f` with the parry3d shape of `shape`, built on the stack.
fn with_parry<R>(shape: &Shape, f: impl FnOnce(&dyn parry3d_f64::shape::Shape) -> R) -> R {
    let v = |x: &Vector3<f64>| parry3d_f64::math::Vector::new(x.x, x.y, x.z);
    match shape {
        Shape::Sphere { radius } => f(&Ball::new(*radius)),
        Shape::Capsule { radius, half_length } => f(&Capsule::new_z(*half_length, *radius)),
        Shape::Box { half_extents } => f(&Cuboid::new(v(half_extents))),
        Shape::Cylinder { radius, half_length } => f(&Cylinder::new(*half_length, *radius)),
        Shape::Convex(hull) => f(&hull.polyhedron),
        // Point clouds never reach parry3d: `signed_distance` and
        // `closer_than` take them ball by ball first.
        Shape::Points { radius, .. } => f(&Ball::new(*radius)),
    }
}

/// Any pair, through parry3d's contact query (GJK, then EPA on penetration).
fn general(a: &Shape, pose_a: &IsometryMatrix3<f64>, b: &Shape, pose_b: &IsometryMatrix3<f64>) -> SignedDistance {
    // Far larger than any workspace, so a contact is always reported.
    const PREDICTION: f64 = 1.0e6;
    let (pa, pb) = (parry_pose(a, pose_a), parry_pose(b, pose_b));
    let contact = with_parry(a, |ga| with_parry(b, |gb| query::contact(&pa, ga, &pb, gb, PREDICTION)));
    let p = |x: parry3d_f64::math::Vector| Point3::new(x.x, x.y, x.z);
    match contact {
        Ok(Some(c)) if c.dist > 0.0 => refine_separated(a, pose_a, b, pose_b, p(c.point1), p(c.point2)),
        Ok(Some(c)) => SignedDistance {
            distance: c.dist,
            point_a: p(c.point1),
            point_b: p(c.point2),
            normal: Vector3::new(c.normal1.x, c.normal1.y, c.normal1.z),
        },
        // GJK/EPA gave up: report the bounding-ball lower bound, which errs
        // on the side of a collision.
        _ => {
            let (ca, cb) = (Point3::from(pose_a.translation.vector), Point3::from(pose_b.translation.vector));
            balls(&ca, a.bounding_radius(), &cb, b.bounding_radius())
        }
    }
}

/// The surface point of a primitive closest to `p` (world); `None` for hulls.
fn surface(shape: &Shape, pose: &IsometryMatrix3<f64>, p: &Point3<f64>) -> Option<Point3<f64>> {
    Some(match shape {
        Shape::Sphere { radius } => {
            let c = Point3::from(pose.translation.vector);
            c + (p - c).try_normalize(0.0).unwrap_or_else(Vector3::z) * *radius
        }
        Shape::Capsule { radius, half_length } => {
            let (a, b) = segment(pose, *half_length);
            let c = closest_point_segment(p, &a, &b);
            c + (p - c).try_normalize(0.0).unwrap_or_else(Vector3::z) * *radius
        }
        Shape::Box { half_extents } => in_shape_frame(pose, p, |l| point_box(l, half_extents)).point,
        Shape::Cylinder { radius, half_length } => {
            in_shape_frame(pose, p, |l| point_cylinder(l, *radius, *half_length)).point
        }
        Shape::Convex(_) | Shape::Points { .. } => return None,
    })
}

/// GJK stops early on curved shapes (cylinders), up to ~1e-6 m long:
/// alternating projections between the two surfaces, which never increase
/// the distance, polish its witness points to machine precision.
fn refine_separated(
    a: &Shape,
    pose_a: &IsometryMatrix3<f64>,
    b: &Shape,
    pose_b: &IsometryMatrix3<f64>,
    mut point_a: Point3<f64>,
    mut point_b: Point3<f64>,
) -> SignedDistance {
    for _ in 0..64 {
        let Some(next_b) = surface(b, pose_b, &point_a) else { break };
        let Some(next_a) = surface(a, pose_a, &next_b) else { break };
        if (next_b - next_a).norm() > (point_b - point_a).norm() {
            break;
        }
        let moved = (next_a - point_a).norm() + (next_b - point_b).norm();
        (point_a, point_b) = (next_a, next_b);
        if moved < 1e-14 {
            break;
        }
    }
    let d = point_b - point_a;
    let distance = d.norm();
    SignedDistance { distance, point_a, point_b, normal: d / distance }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64, y: f64, z: f64) -> IsometryMatrix3<f64> {
        IsometryMatrix3::translation(x, y, z)
    }

    #[test]
    fn sphere_box_outside_inside_and_edge() {
        let cube = Shape::cuboid([2.0, 2.0, 2.0]);
        let ball = Shape::sphere(0.5);
        let d = signed_distance(&ball, &at(3.0, 0.0, 0.0), &cube, &at(0.0, 0.0, 0.0));
        assert!((d.distance - 1.5).abs() < 1e-15);
        assert!((d.normal + Vector3::x()).norm() < 1e-15);
        let d = signed_distance(&ball, &at(0.8, 0.0, 0.0), &cube, &at(0.0, 0.0, 0.0));
        assert!((d.distance + 0.7).abs() < 1e-15, "{d:?}");
        assert!(((d.point_b - d.point_a) - d.normal * d.distance).norm() < 1e-15);
        let d = signed_distance(&cube, &at(0.0, 0.0, 0.0), &ball, &at(2.0, 2.0, 1.0));
        assert!((d.distance - (2f64.sqrt() - 0.5)).abs() < 1e-15);
    }

    #[test]
    fn analytic_pairs_agree_with_gjk_epa() {
        let shapes = [
            Shape::sphere(0.1),
            Shape::capsule(0.05, 0.3),
            Shape::cuboid([0.2, 0.1, 0.3]),
            Shape::cylinder(0.08, 0.25),
        ];
        let rot = |a: f64, b: f64, c: f64| nalgebra::Rotation3::from_euler_angles(a, b, c);
        let mut worst: f64 = 0.0;
        for (i, a) in shapes.iter().enumerate() {
            for (j, b) in shapes.iter().enumerate() {
                for k in 0..40 {
                    let t = k as f64;
                    let pa = IsometryMatrix3::from_parts(
                        Vector3::new(0.01 * t, 0.0, 0.02).into(),
                        rot(0.3 * t, 0.1, -0.2 * t),
                    );
                    let pb = IsometryMatrix3::from_parts(
                        Vector3::new(0.25 - 0.012 * t, 0.03, 0.05).into(),
                        rot(-0.2, 0.17 * t, 0.4),
                    );
                    let exact = signed_distance(a, &pa, b, &pb);
                    let reference = general(a, &pa, b, &pb);
                    assert!(
                        // Exact for closed forms; EPA's witnesses hold it to its tolerance.
                        ((exact.point_b - exact.point_a) - exact.normal * exact.distance).norm() < 1e-6,
                        "{i} {j} {k}: {exact:?}"
                    );
                    worst = worst.max((exact.distance - reference.distance).abs());
                    assert!(
                        (exact.distance - reference.distance).abs() < 1e-6,
                        "{i} {j} {k}: {exact:?} vs {reference:?}"
                    );
                    assert_eq!(closer_than(a, &pa, b, &pb, 0.0), exact.distance < 0.0, "{i} {j} {k}");
                }
            }
        }
        println!("max |analytic - GJK/EPA| = {worst:e}");
    }
}
