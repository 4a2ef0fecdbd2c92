//! Collision queries over a [`CollisionModel`] and a [`CollisionWorkspace`]:
//! boolean checks, signed distances with witness points and their
//! gradients, minimum distance, and motion (edge) validation. None of them
//! allocates once the workspace exists (penetrating box/cylinder/hull pairs,
//! which need EPA, excepted).

use super::distance::{SignedDistance, closer_than, signed_distance_within};
use super::geometry::Group;
use super::model::CollisionModel;
use super::spheres::{SphereWorkspace, Verdict};
use crate::robot::{KinematicsWorkspace, RobotError};
use nalgebra::{IsometryMatrix3, Point3, Translation3, Vector3};

/// Per-thread mutable state of collision queries.
#[derive(Debug, Clone)]
pub struct CollisionWorkspace {
    pub(crate) kinematics: KinematicsWorkspace,
    /// World pose of every object (static ones set once).
    pub(crate) poses: Vec<IsometryMatrix3<f64>>,
    /// World bounding-ball centre of every group.
    pub(crate) centers: Vec<Point3<f64>>,
    distances: Vec<PairDistance>,
    pub(crate) q: Vec<f64>,
    /// Per group pair: bound of relative motion over the current edge (m).
    pub(crate) sweeps: Vec<f64>,
    /// Scratch of the sphere fast path, when the model has one.
    pub(crate) spheres: Option<SphereWorkspace>,
    /// Per group: whether `poses` holds its objects at the current
    /// placement (static groups always do).
    placed: Vec<bool>,
    /// Per object: within reach of the other group of the pair at hand.
    near: Vec<bool>,
    /// Certifications the sphere fast path left to the general path.
    pub(crate) deferred: u64,
}

/// Signed distance of one object pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairDistance {
    /// Index of the pair; names from [`CollisionModel::pair_names`].
    pub pair: usize,
    /// Distance between the (padded) shapes: `a` on the robot side, `b`
    /// the other; see [`SignedDistance`].
    pub signed: SignedDistance,
}

impl CollisionWorkspace {
    /// Allocates the workspace for `model`; reuse it across calls.
    pub fn new(model: &CollisionModel) -> Self {
        let poses = model.objects.iter().map(|o| o.local).collect();
        let centers = model.groups.iter().map(|g| g.center).collect();
        CollisionWorkspace {
            kinematics: KinematicsWorkspace::new(&model.robot),
            poses,
            centers,
            distances: Vec::with_capacity(model.pairs.len()),
            q: vec![0.0; model.robot.nq()],
            sweeps: vec![0.0; model.group_pairs.len()],
            spheres: model.spheres.as_ref().map(|s| SphereWorkspace::new(s, model.robot.nq())),
            placed: vec![true; model.groups.len()],
            near: vec![false; model.objects.len()],
            deferred: 0,
        }
    }

    /// How many motion certifications with this workspace the sphere fast
    /// path could not decide and left to the general path (exact convex
    /// distances, tens of times slower): a near-contact motion now and
    /// then; most of them means the robot's geometry or joints keep it off
    /// the fast path.
    pub fn deferred_certifications(&self) -> u64 {
        self.deferred
    }

    /// The pairs returned by the last [`CollisionModel::distances`] call with
    /// this workspace (for callers that must read them after releasing the
    /// borrow, e.g. to take their gradients).
    pub fn last_distances(&self) -> &[PairDistance] {
        &self.distances
    }

    /// The kinematics state of the last query that placed the shapes (frame
    /// poses at its `q`): every query but the boolean checks on the sphere
    /// fast path, which keep their own state.
    pub fn kinematics(&self) -> &KinematicsWorkspace {
        &self.kinematics
    }
}

/// Squared distance from `p` to a box.
fn aabb_distance_squared(p: &Point3<f64>, (lo, hi): &(Point3<f64>, Point3<f64>)) -> f64 {
    let d = (lo - p).sup(&Vector3::zeros()).sup(&(p - hi));
    d.norm_squared()
}

/// Lower bound of the distance between two bounding volumes (m), each a
/// ball (centre, radius) or, for static shapes, a world box: the box of
/// `b` if it has one, else the box of `a`, else the two balls.
fn volume_bound(
    ca: Point3<f64>,
    ra: f64,
    box_a: Option<&(Point3<f64>, Point3<f64>)>,
    cb: Point3<f64>,
    rb: f64,
    box_b: Option<&(Point3<f64>, Point3<f64>)>,
) -> f64 {
    match (box_a, box_b) {
        (_, Some(aabb)) => aabb_distance_squared(&ca, aabb).sqrt() - ra,
        (Some(aabb), None) => aabb_distance_squared(&cb, aabb).sqrt() - rb,
        (None, None) => (cb - ca).norm() - ra - rb,
    }
}

/// Whether a bounding-volume lower bound rules a pair out of "closer than
/// `limit`". Overlapping volumes (bound ≤ 0) say nothing about how deep
/// the shapes inside penetrate, so they never prune.
pub(crate) fn prunes(bound: f64, limit: f64) -> bool {
    bound > 0.0 && bound >= limit
}

impl CollisionModel {
    /// Places every moving object at `q`.
    pub(crate) fn place(&self, ws: &mut CollisionWorkspace, q: &[f64]) -> Result<(), RobotError> {
        self.place_centers(ws, q)?;
        for g in 0..self.groups.len() {
            self.place_group(ws, g);
        }
        Ok(())
    }

    /// Places the bounding-ball centre of every moving group at `q`; their
    /// objects wait for [`place_group`](Self::place_group).
    fn place_centers(&self, ws: &mut CollisionWorkspace, q: &[f64]) -> Result<(), RobotError> {
        self.robot.forward_kinematics(&mut ws.kinematics, q)?;
        self.place_centers_placed(ws);
        Ok(())
    }

    /// [`place_centers`](Self::place_centers) at the body poses already in
    /// `ws.kinematics`.
    fn place_centers_placed(&self, ws: &mut CollisionWorkspace) {
        for (g, group) in self.groups.iter().enumerate() {
            let Some(body) = group.body else { continue };
            ws.centers[g] = self.robot.body_pose(&ws.kinematics, body) * group.center;
            ws.placed[g] = false;
        }
    }

    /// Places the objects of group `g`, unless they already are.
    fn place_group(&self, ws: &mut CollisionWorkspace, g: usize) {
        let group = &self.groups[g];
        let Some(body) = group.body.filter(|_| !ws.placed[g]) else { return };
        let pose = self.robot.body_pose(&ws.kinematics, body);
        for i in group.objects.clone() {
            let local = &self.objects[i].local;
            ws.poses[i] = match self.objects[i].unrotated {
                true => {
                    let shift = pose.rotation * local.translation.vector;
                    IsometryMatrix3::from_parts(Translation3::from(pose.translation.vector + shift), pose.rotation)
                }
                false => pose * local,
            };
        }
        ws.placed[g] = true;
    }

    /// Lower bound of the distance between two groups' shapes (m).
    pub(crate) fn group_bound(&self, ws: &CollisionWorkspace, a: usize, b: usize) -> f64 {
        let (ga, gb): (&Group, &Group) = (&self.groups[a], &self.groups[b]);
        volume_bound(ws.centers[a], ga.radius, None, ws.centers[b], gb.radius, gb.aabb.as_ref())
    }

    /// Lower bound of the distance between two objects' shapes (m).
    pub(crate) fn object_bound(&self, ws: &CollisionWorkspace, i: usize, j: usize) -> f64 {
        let (oi, oj) = (&self.objects[i], &self.objects[j]);
        let (ci, cj) = (Point3::from(ws.poses[i].translation.vector), Point3::from(ws.poses[j].translation.vector));
        volume_bound(ci, oi.radius, None, cj, oj.radius, oj.aabb.as_ref())
    }

    /// Lower bound of the distance between object `i`'s shape and group
    /// `g`'s (m).
    fn object_group_bound(&self, ws: &CollisionWorkspace, i: usize, g: usize) -> f64 {
        let (o, group) = (&self.objects[i], &self.groups[g]);
        let c = Point3::from(ws.poses[i].translation.vector);
        volume_bound(c, o.radius, o.aabb.as_ref(), ws.centers[g], group.radius, group.aabb.as_ref())
    }

    /// Exact signed distance of pair `pair` at the placed poses.
    pub(crate) fn pair_distance(&self, ws: &CollisionWorkspace, pair: usize) -> PairDistance {
        self.pair_distance_within(ws, pair, f64::INFINITY)
    }

    /// [`pair_distance`](Self::pair_distance) for a caller that keeps it
    /// only when below `cutoff` (m): a cloud's nearest point is searched for
    /// within it (+∞ when none is that close).
    fn pair_distance_within(&self, ws: &CollisionWorkspace, pair: usize, cutoff: f64) -> PairDistance {
        let [i, j] = self.pairs[pair].map(|k| k as usize);
        let (oi, oj) = (&self.objects[i], &self.objects[j]);
        let cap = cutoff + oi.padding + oj.padding;
        let mut d = signed_distance_within(&oi.shape, &ws.poses[i], &oj.shape, &ws.poses[j], cap);
        // Padding inflates each shape along the normal.
        d.distance -= oi.padding + oj.padding;
        d.point_a += d.normal * oi.padding;
        d.point_b -= d.normal * oj.padding;
        PairDistance { pair, signed: d }
    }

    /// True when no checked pair of (padded) shapes touches at `q`. Stops
    /// at the first collision; bounding balls and boxes prune far pairs.
    ///
    /// # Errors
    /// A `q` of the wrong length or with non-finite values.
    pub fn collision_free(&self, ws: &mut CollisionWorkspace, q: &[f64]) -> Result<bool, RobotError> {
        if let (Some(fast), Some(scratch)) = (&self.spheres, ws.spheres.as_mut()) {
            self.robot.check_configuration(q)?;
            if fast.always_collides() {
                return Ok(false);
            }
            match fast.check_one(scratch, q) {
                Verdict::Collides => return Ok(false),
                Verdict::Free { unsure, .. } if !unsure[0] => return Ok(true),
                Verdict::Free { .. } => {}
            }
        }
        self.place(ws, q)?;
        Ok(self.placed_collision_free(ws))
    }

    pub(crate) fn placed_collision_free(&self, ws: &CollisionWorkspace) -> bool {
        for gp in &self.group_pairs {
            if self.group_bound(ws, gp.a, gp.b) > 0.0 {
                continue;
            }
            for pair in gp.pairs.clone() {
                let [i, j] = self.pairs[pair].map(|k| k as usize);
                if self.object_bound(ws, i, j) > 0.0 {
                    continue;
                }
                let (oi, oj) = (&self.objects[i], &self.objects[j]);
                if closer_than(&oi.shape, &ws.poses[i], &oj.shape, &ws.poses[j], oi.padding + oj.padding) {
                    return false;
                }
            }
        }
        true
    }

    /// Signed distances at `q` of every pair closer than `cutoff` (m; pass
    /// `f64::INFINITY` for all pairs), in pair order. Pairs whose bounding
    /// volumes are already `cutoff` apart are skipped without computing,
    /// and groups whose bounding balls are that far from everything are not
    /// even placed (see [`object_world_pose`](Self::object_world_pose)).
    ///
    /// # Errors
    /// A `q` of the wrong length or with non-finite values.
    pub fn distances<'w>(
        &self,
        ws: &'w mut CollisionWorkspace,
        q: &[f64],
        cutoff: f64,
    ) -> Result<&'w [PairDistance], RobotError> {
        self.place_centers(ws, q)?;
        Ok(self.placed_distances(ws, cutoff))
    }

    /// [`distances`](Self::distances) with the robot's bodies where
    /// `kinematics` (a workspace of this model's robot after its forward
    /// kinematics, e.g. one the caller needed anyway) has them; the
    /// gradients of these distances then follow from `ws` as usual.
    pub(crate) fn distances_at<'w>(
        &self,
        ws: &'w mut CollisionWorkspace,
        kinematics: &KinematicsWorkspace,
        cutoff: f64,
    ) -> &'w [PairDistance] {
        ws.kinematics.copy_body_poses_from(kinematics);
        self.place_centers_placed(ws);
        self.placed_distances(ws, cutoff)
    }

    /// The pairs closer than `cutoff` once the group centres are placed.
    fn placed_distances<'w>(&self, ws: &'w mut CollisionWorkspace, cutoff: f64) -> &'w [PairDistance] {
        ws.distances.clear();
        for gp in &self.group_pairs {
            if prunes(self.group_bound(ws, gp.a, gp.b), cutoff) {
                continue;
            }
            self.place_group(ws, gp.a);
            self.place_group(ws, gp.b);
            // Objects of either group out of reach of the other's volume
            // take all their pairs with them.
            let (objects_a, objects_b) = (self.groups[gp.a].objects.clone(), self.groups[gp.b].objects.clone());
            for j in objects_b.clone() {
                ws.near[j] = !prunes(self.object_group_bound(ws, j, gp.a), cutoff);
            }
            for (k, i) in objects_a.enumerate() {
                if prunes(self.object_group_bound(ws, i, gp.b), cutoff) {
                    continue;
                }
                for (l, j) in objects_b.clone().enumerate() {
                    if !ws.near[j] || prunes(self.object_bound(ws, i, j), cutoff) {
                        continue;
                    }
                    let d = self.pair_distance_within(ws, gp.pairs.start + k * objects_b.len() + l, cutoff);
                    if d.signed.distance < cutoff {
                        ws.distances.push(d);
                    }
                }
            }
        }
        &ws.distances
    }

    /// Signed distance of one pair at `q` (see [`pair_count`](Self::pair_count)).
    ///
    /// # Errors
    /// A `q` of the wrong length or with non-finite values.
    pub fn pair_distance_at(
        &self,
        ws: &mut CollisionWorkspace,
        q: &[f64],
        pair: usize,
    ) -> Result<PairDistance, RobotError> {
        self.place(ws, q)?;
        Ok(self.pair_distance(ws, pair))
    }

    /// The closest pair at `q` (the deepest when penetrating); `None` when
    /// the model checks no pair. Branch and bound on bounding volumes.
    ///
    /// # Errors
    /// A `q` of the wrong length or with non-finite values.
    pub fn min_distance(&self, ws: &mut CollisionWorkspace, q: &[f64]) -> Result<Option<PairDistance>, RobotError> {
        self.min_distance_below(ws, q, f64::INFINITY)
    }

    /// [`min_distance`](Self::min_distance) among the pairs closer than
    /// `bound` (m): `None` when there is none. A known distance (e.g. the
    /// smallest over the configurations seen so far) as `bound` prunes
    /// most pairs by their bounding volumes, and groups whose volumes are
    /// that far apart are not even placed.
    ///
    /// # Errors
    /// A `q` of the wrong length or with non-finite values.
    pub fn min_distance_below(
        &self,
        ws: &mut CollisionWorkspace,
        q: &[f64],
        bound: f64,
    ) -> Result<Option<PairDistance>, RobotError> {
        self.place_centers(ws, q)?;
        let mut best: Option<PairDistance> = None;
        let limit = |best: &Option<PairDistance>| best.map_or(bound, |b| b.signed.distance);
        for gp in &self.group_pairs {
            if prunes(self.group_bound(ws, gp.a, gp.b), limit(&best)) {
                continue;
            }
            self.place_group(ws, gp.a);
            self.place_group(ws, gp.b);
            for pair in gp.pairs.clone() {
                let [i, j] = self.pairs[pair].map(|k| k as usize);
                if prunes(self.object_bound(ws, i, j), limit(&best)) {
                    continue;
                }
                let d = self.pair_distance_within(ws, pair, limit(&best));
                if d.signed.distance < limit(&best) {
                    best = Some(d);
                }
            }
        }
        Ok(best)
    }

    /// World pose of object `object` (see [`object_count`](Self::object_count))
    /// as placed by the last query with `ws` that placed the shapes (see
    /// [`CollisionWorkspace::kinematics`]); after
    /// [`distances`](Self::distances), [`min_distance`](Self::min_distance)
    /// or [`min_distance_below`](Self::min_distance_below), only the objects
    /// of the pairs it could not prune by their groups' bounds (those of
    /// every pair it returned among them) are placed, the others keep older
    /// poses.
    pub fn object_world_pose<'w>(&self, ws: &'w CollisionWorkspace, object: usize) -> &'w IsometryMatrix3<f64> {
        &ws.poses[object]
    }

    /// For a distance `d` to a point cloud obstacle (as returned with
    /// `ws`), the cloud's point it was measured to: its index in the cloud
    /// as given and its world position (m); `None` for other pairs.
    pub fn nearest_cloud_point(&self, ws: &CollisionWorkspace, d: &PairDistance) -> Option<(usize, [f64; 3])> {
        let (_, j) = self.pair_objects(d.pair);
        let crate::scene::Shape::Points { points, radius } = &self.objects[j].shape else { return None };
        // The witness lies on the nearest ball, `radius` (+ padding) short of its centre.
        let centre = d.signed.point_b + d.signed.normal * (radius + self.objects[j].padding);
        let local = ws.poses[j].inverse_transform_point(&centre);
        let (_, k) = points.nearest(&[local.x, local.y, local.z], f64::INFINITY)?;
        let (p, index) = points.point(k);
        let world = ws.poses[j] * Point3::from(p);
        Some((index, [world.x, world.y, world.z]))
    }

    /// Shape of object `object`.
    pub fn object_shape(&self, object: usize) -> &crate::scene::Shape {
        &self.objects[object].shape
    }

    /// Gradient of `d.signed.distance` with respect to `q` (1/rad or 1/m
    /// per active joint), written into `out`, for a distance returned by
    /// [`distances`](Self::distances) or [`min_distance`](Self::min_distance)
    /// with this workspace and not re-queried since.
    ///
    /// It is `nᵀ (J_b(p_b) − J_a(p_a))`: the normal projected on the
    /// relative velocity of the witness points.
    ///
    /// # Errors
    /// [`RobotError::OutputShape`] when `out` does not hold nq values.
    pub fn distance_gradient(
        &self,
        ws: &CollisionWorkspace,
        d: &PairDistance,
        out: &mut [f64],
    ) -> Result<(), RobotError> {
        if out.len() != self.robot.nq() {
            return Err(RobotError::OutputShape { expected: self.robot.nq(), got: out.len() });
        }
        out.fill(0.0);
        let [i, j] = self.pairs[d.pair].map(|k| k as usize);
        let s = &d.signed;
        for (object, point, direction) in [(i, &s.point_a, -s.normal), (j, &s.point_b, s.normal)] {
            if let Some(body) = self.groups[self.objects[object].group].body {
                self.robot.add_projected_point_velocity(&ws.kinematics, body, &point.coords, &direction, out);
            }
        }
        Ok(())
    }
}
