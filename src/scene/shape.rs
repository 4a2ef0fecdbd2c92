//! Collision shapes, in their own frame.
//!
//! Spheres, capsules, boxes and cylinders are kept as parameters: their
//! distances to each other are computed in closed form where one exists
//! (see [`signed_distance`](crate::collision::signed_distance)). Meshes
//! become their convex hull, held as a parry3d polyhedron.

use crate::point_cloud::PointTree;
use crate::robot::{Geometry, TriMesh};
use nalgebra::{Point3, Vector3};
use parry3d_f64::shape::ConvexPolyhedron;
use std::sync::Arc;
use thiserror::Error;

/// A shape that cannot be built.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ShapeError {
    /// A dimension that is not finite and positive.
    #[error("invalid {what}: {value} (must be finite and positive)")]
    InvalidShape {
        /// Which dimension (e.g. `box size`).
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A mesh whose vertices span no volume.
    #[error("cannot build a convex hull from {points} points (need at least 4 finite, non-coplanar points)")]
    DegenerateHull {
        /// How many points were given.
        points: usize,
    },
}

/// A collision shape in its own frame (metres): a convex one, or a point
/// cloud's balls. Axial shapes (capsule, cylinder) are centred on the
/// origin along z.
#[derive(Debug, Clone)]
pub enum Shape {
    /// A ball about the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A segment from −half_length to +half_length along z, swept by a ball.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half the length along z (m).
        half_length: f64,
    },
    /// A box centred on the origin, axis-aligned in its frame.
    Box {
        /// Half the side lengths along x, y, z (m).
        half_extents: Vector3<f64>,
    },
    /// A solid cylinder along z, centred on the origin.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half the length along z (m).
        half_length: f64,
    },
    /// The convex hull of a mesh.
    Convex(Arc<ConvexHull>),
    /// A ball of `radius` at every point of a cloud (a depth camera's view
    /// of what is around the robot): the union is not convex, so only
    /// obstacles may have this shape, and its distance to another shape
    /// is the smallest over the balls.
    Points {
        /// The points, in the shape's frame (the sensor's, placed by the
        /// obstacle's pose), in a tree for nearest-point queries.
        points: Arc<PointTree>,
        /// Radius of every ball (m): the sensor's noise and the filtering's
        /// spacing margin (see [`FilterReport`](crate::point_cloud::FilterReport)).
        radius: f64,
    },
}

/// The convex hull of a point set, with its bounding radius about the
/// shape origin.
#[derive(Debug, Clone)]
pub struct ConvexHull {
    pub(crate) polyhedron: ConvexPolyhedron,
    radius: f64,
    vertex_count: usize,
}

impl ConvexHull {
    /// The hull of `points` (m, shape frame).
    ///
    /// # Errors
    /// [`ShapeError::DegenerateHull`] when the points are fewer than 4,
    /// not finite, or coplanar.
    pub fn new(points: &[Point3<f64>]) -> Result<ConvexHull, ShapeError> {
        let finite = points.iter().all(|p| p.coords.iter().all(|c| c.is_finite()));
        let glam: Vec<_> = points.iter().map(|p| parry3d_f64::math::Vector::new(p.x, p.y, p.z)).collect();
        let polyhedron = (finite && points.len() >= 4)
            .then(|| ConvexPolyhedron::from_convex_hull(&glam))
            .flatten()
            .ok_or(ShapeError::DegenerateHull { points: points.len() })?;
        let radius = polyhedron.points().iter().map(|p| p.length()).fold(0.0, f64::max);
        let vertex_count = polyhedron.points().len();
        Ok(ConvexHull { polyhedron, radius, vertex_count })
    }

    /// The hull's vertices (m, shape frame).
    pub fn points(&self) -> Vec<[f64; 3]> {
        self.polyhedron.points().iter().map(|p| [p.x, p.y, p.z]).collect()
    }

    /// Number of hull vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }
}

impl Shape {
    /// A sphere of `radius` (m).
    pub fn sphere(radius: f64) -> Shape {
        Shape::Sphere { radius }
    }

    /// A box of full side lengths `size` (m).
    pub fn cuboid(size: [f64; 3]) -> Shape {
        Shape::Box { half_extents: Vector3::from(size) / 2.0 }
    }

    /// A cylinder along z of full `length` (m).
    pub fn cylinder(radius: f64, length: f64) -> Shape {
        Shape::Cylinder { radius, half_length: length / 2.0 }
    }

    /// A capsule along z whose cylindrical part is `length` long (m).
    pub fn capsule(radius: f64, length: f64) -> Shape {
        Shape::Capsule { radius, half_length: length / 2.0 }
    }

    /// The convex hull of a triangle mesh's vertices.
    ///
    /// # Errors
    /// See [`ConvexHull::new`].
    pub fn convex_hull_of(mesh: &TriMesh) -> Result<Shape, ShapeError> {
        Ok(Shape::Convex(Arc::new(ConvexHull::new(&mesh.vertices)?)))
    }

    /// The collision shape of a URDF geometry; meshes become their convex
    /// hull. `None` for a mesh whose format tandem cannot read.
    ///
    /// # Errors
    /// A degenerate mesh hull.
    pub fn from_geometry(geometry: &Geometry) -> Result<Option<Shape>, ShapeError> {
        Ok(Some(match geometry {
            Geometry::Sphere { radius } => Shape::sphere(*radius),
            Geometry::Box { half_extents } => Shape::Box { half_extents: *half_extents },
            Geometry::Cylinder { radius, length } => Shape::cylinder(*radius, *length),
            Geometry::Capsule { radius, length } => Shape::capsule(*radius, *length),
            Geometry::Mesh { mesh, .. } => Shape::convex_hull_of(mesh)?,
            Geometry::UnreadableMesh { .. } => return Ok(None),
        }))
    }

    /// Balls of `radius` (m) at `points` (m, the shape's frame; non-finite
    /// ones left out).
    ///
    /// # Errors
    /// A radius that is not finite and positive.
    pub fn points(points: &[[f64; 3]], radius: f64) -> Result<Shape, ShapeError> {
        let shape = Shape::Points { points: Arc::new(PointTree::new(points)), radius };
        shape.validate()?;
        Ok(shape)
    }

    /// True for a convex shape (every kind but [`Shape::Points`]).
    pub fn is_convex(&self) -> bool {
        !matches!(self, Shape::Points { .. })
    }

    /// Short kind name: `sphere`, `capsule`, `box`, `cylinder`, `convex`,
    /// `points`.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Shape::Sphere { .. } => "sphere",
            Shape::Capsule { .. } => "capsule",
            Shape::Box { .. } => "box",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Convex(_) => "convex",
            Shape::Points { .. } => "points",
        }
    }

    /// Radius of the smallest origin-centred ball holding the shape (m).
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Sphere { radius } => *radius,
            Shape::Capsule { radius, half_length } => radius + half_length,
            Shape::Box { half_extents } => half_extents.norm(),
            Shape::Cylinder { radius, half_length } => radius.hypot(*half_length),
            Shape::Convex(hull) => hull.radius,
            Shape::Points { points, radius } => points.reach() + radius,
        }
    }

    /// Support value in `direction` (shape frame; need not be unit): the
    /// largest `p · direction` over the points `p` of the shape (m when
    /// `direction` is a unit vector). E.g. a box's height above its centre
    /// is its support in `z`.
    pub fn support(&self, direction: &Vector3<f64>) -> f64 {
        let d = direction;
        match self {
            Shape::Sphere { radius } => radius * d.norm(),
            Shape::Capsule { radius, half_length } => half_length * d.z.abs() + radius * d.norm(),
            Shape::Box { half_extents } => half_extents.dot(&d.abs()),
            Shape::Cylinder { radius, half_length } => half_length * d.z.abs() + radius * d.x.hypot(d.y),
            Shape::Convex(hull) => hull
                .polyhedron
                .points()
                .iter()
                .map(|p| p.x * d.x + p.y * d.y + p.z * d.z)
                .fold(f64::NEG_INFINITY, f64::max),
            Shape::Points { points, radius } => {
                points.points().map(|(p, _)| p[0] * d.x + p[1] * d.y + p[2] * d.z).fold(f64::NEG_INFINITY, f64::max)
                    + radius * d.norm()
            }
        }
    }

    /// Edge lengths of the shape's bounding box in its own frame (m): the
    /// box itself, `2r × 2r × 2r` for a sphere, `2r × 2r × length` for a
    /// cylinder (length + 2r for a capsule); a convex hull reports the cube
    /// around its bounding ball, a point cloud the origin-centred box
    /// around its balls.
    pub fn extents(&self) -> Vector3<f64> {
        match self {
            Shape::Sphere { radius } => Vector3::repeat(2.0 * radius),
            Shape::Capsule { radius, half_length } => {
                Vector3::new(2.0 * radius, 2.0 * radius, 2.0 * (radius + half_length))
            }
            Shape::Box { half_extents } => 2.0 * half_extents,
            Shape::Cylinder { radius, half_length } => Vector3::new(2.0 * radius, 2.0 * radius, 2.0 * half_length),
            Shape::Convex(hull) => Vector3::repeat(2.0 * hull.radius),
            Shape::Points { points, radius } => match points.bounds() {
                Some((lo, hi)) => Vector3::from_fn(|i, _| 2.0 * (lo[i].abs().max(hi[i].abs()) + radius)),
                None => Vector3::zeros(),
            },
        }
    }

    /// Points of the shape (m, its frame) whose projection along any axis of
    /// its frame has the shape's silhouette as convex hull: a box's
    /// corners, a hull's vertices, and for round parts 48 points on each
    /// circle that bounds them seen along x, y or z (exact along those
    /// axes; along others, within 0.2 % of the radius); a point cloud's
    /// points (its balls' centres).
    pub fn silhouette_points(&self) -> Vec<Point3<f64>> {
        const N: usize = 48;
        // The three great circles of a ball of `radius` about `centre`.
        let ball = |centre: Point3<f64>, radius: f64, out: &mut Vec<Point3<f64>>| {
            for k in 0..N {
                let (s, c) = (std::f64::consts::TAU * k as f64 / N as f64).sin_cos();
                let (s, c) = (radius * s, radius * c);
                out.extend(
                    [Vector3::new(c, s, 0.0), Vector3::new(c, 0.0, s), Vector3::new(0.0, c, s)].map(|v| centre + v),
                );
            }
        };
        let mut out = vec![];
        match self {
            Shape::Sphere { radius } => ball(Point3::origin(), *radius, &mut out),
            Shape::Capsule { radius, half_length } => {
                ball(Point3::new(0.0, 0.0, -half_length), *radius, &mut out);
                ball(Point3::new(0.0, 0.0, *half_length), *radius, &mut out);
            }
            Shape::Box { half_extents: h } => {
                for k in 0..8 {
                    let sign = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                    out.push(Point3::new(sign(0) * h.x, sign(1) * h.y, sign(2) * h.z));
                }
            }
            Shape::Cylinder { radius, half_length } => {
                for k in 0..N {
                    let (s, c) = (std::f64::consts::TAU * k as f64 / N as f64).sin_cos();
                    out.extend([-half_length, *half_length].map(|z| Point3::new(radius * c, radius * s, z)));
                }
            }
            Shape::Convex(hull) => out.extend(hull.polyhedron.points().iter().map(|p| Point3::new(p.x, p.y, p.z))),
            Shape::Points { points, .. } => out.extend(points.points().map(|(p, _)| Point3::from(p))),
        }
        out
    }

    /// Points on the shape's surface (m, its frame) such that every point
    /// of the surface lies within `spacing` (m) of one of them: a grid of
    /// cell centres on each flat face, bands of rings on round parts, cells
    /// at most `spacing` on a side (so the covering radius is at most
    /// `spacing / √2` along the surface). The points a depth camera would
    /// give of the shape, all around and without noise; `None` for a hull
    /// or a point cloud, or a `spacing` that is not finite and positive.
    pub fn surface_points(&self, spacing: f64) -> Option<Vec<Point3<f64>>> {
        if !(spacing.is_finite() && spacing > 0.0) {
            return None;
        }
        let count = |length: f64| ((length / spacing).ceil() as usize).max(1);
        let mut out: Vec<Point3<f64>> = Vec::new();
        // Cell centres of an n × m grid over [−a, a] × [−b, b].
        let grid = |a: f64, b: f64, out: &mut Vec<(f64, f64)>| {
            let (n, m) = (count(2.0 * a), count(2.0 * b));
            for i in 0..n {
                for j in 0..m {
                    out.push((-a + (i as f64 + 0.5) * 2.0 * a / n as f64, -b + (j as f64 + 0.5) * 2.0 * b / m as f64));
                }
            }
        };
        // A ring of radius ρ at height z, points at most `spacing` apart.
        let ring = |rho: f64, z: f64, out: &mut Vec<Point3<f64>>| {
            let n = count(std::f64::consts::TAU * rho);
            for k in 0..n {
                let (s, c) = (std::f64::consts::TAU * (k as f64 + 0.5) / n as f64).sin_cos();
                out.push(Point3::new(rho * c, rho * s, z));
            }
        };
        // Latitude bands of a ball of radius r about (0, 0, z0), polar angle
        // θ from `from` to `to`: each band's ring at its middle, as many
        // points as its widest circle needs.
        let bands = |r: f64, z0: f64, (from, to): (f64, f64), out: &mut Vec<Point3<f64>>| {
            let n = count(r * (to - from));
            for k in 0..n {
                let (a, b) = (from + (to - from) * k as f64 / n as f64, from + (to - from) * (k + 1) as f64 / n as f64);
                let middle = 0.5 * (a + b);
                let widest = if a <= std::f64::consts::FRAC_PI_2 && b >= std::f64::consts::FRAC_PI_2 {
                    r
                } else {
                    r * a.sin().max(b.sin())
                };
                let ring_count = count(std::f64::consts::TAU * widest);
                for j in 0..ring_count {
                    let (s, c) = (std::f64::consts::TAU * (j as f64 + 0.5) / ring_count as f64).sin_cos();
                    let rho = r * middle.sin();
                    out.push(Point3::new(rho * c, rho * s, z0 + r * middle.cos()));
                }
            }
        };
        let mut flat = Vec::new();
        match self {
            Shape::Box { half_extents: h } => {
                for axis in 0..3 {
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    flat.clear();
                    grid(h[u], h[v], &mut flat);
                    for sign in [-1.0, 1.0] {
                        for &(a, b) in &flat {
                            let mut p = Point3::origin();
                            (p[axis], p[u], p[v]) = (sign * h[axis], a, b);
                            out.push(p);
                        }
                    }
                }
            }
            Shape::Sphere { radius } => bands(*radius, 0.0, (0.0, std::f64::consts::PI), &mut out),
            Shape::Cylinder { radius, half_length } | Shape::Capsule { radius, half_length } => {
                let n = count(2.0 * half_length);
                for k in 0..n {
                    ring(*radius, -half_length + (k as f64 + 0.5) * 2.0 * half_length / n as f64, &mut out);
                }
                if matches!(self, Shape::Capsule { .. }) {
                    bands(*radius, *half_length, (0.0, std::f64::consts::FRAC_PI_2), &mut out);
                    bands(*radius, -half_length, (std::f64::consts::FRAC_PI_2, std::f64::consts::PI), &mut out);
                } else {
                    // Caps: annuli of width at most `spacing`, each ring at its middle.
                    let m = count(*radius);
                    for k in 0..m {
                        let rho = (k as f64 + 0.5) * radius / m as f64;
                        let outer = (k + 1) as f64 * radius / m as f64;
                        let n = count(std::f64::consts::TAU * outer);
                        for z in [-*half_length, *half_length] {
                            for j in 0..n {
                                let (s, c) = (std::f64::consts::TAU * (j as f64 + 0.5) / n as f64).sin_cos();
                                out.push(Point3::new(rho * c, rho * s, z));
                            }
                        }
                    }
                }
            }
            Shape::Convex(_) | Shape::Points { .. } => return None,
        }
        Some(out)
    }

    /// Checks that every dimension is finite and positive.
    ///
    /// # Errors
    /// [`ShapeError::InvalidShape`] naming the bad dimension.
    pub fn validate(&self) -> Result<(), ShapeError> {
        let check = |what: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(ShapeError::InvalidShape { what, value: v }) }
        };
        match self {
            Shape::Sphere { radius } => check("sphere radius", *radius),
            Shape::Capsule { radius, half_length } => {
                check("capsule radius", *radius)?;
                // A zero-length capsule is a sphere: allowed.
                check("capsule length", half_length + f64::MIN_POSITIVE)
            }
            Shape::Box { half_extents } => half_extents.iter().try_for_each(|h| check("box size", *h)),
            Shape::Cylinder { radius, half_length } => {
                check("cylinder radius", *radius)?;
                check("cylinder length", *half_length)
            }
            Shape::Convex(_) => Ok(()),
            Shape::Points { radius, .. } => check("point radius", *radius),
        }
    }

    /// parry3d's cylinder runs along y, ours along z: its pose must be turned.
    pub(crate) fn needs_y_to_z(&self) -> bool {
        matches!(self, Shape::Cylinder { .. })
    }
}
