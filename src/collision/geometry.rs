//! What a [`CollisionModel`](super::CollisionModel) is made of: collision
//! objects placed on bodies (or in the world), their rigid groups, and the
//! pairs of groups checked. The model's queries and its sphere fast path
//! both read these tables; the fast path compiles them into flat arrays.

use crate::robot::RobotModel;
use crate::scene::Shape;
use nalgebra::{IsometryMatrix3, Point3};
use std::ops::Range;

/// Where a collision object comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectSource {
    /// Collision element `element` (URDF order) of link `link` (description index).
    RobotLink {
        /// Description index of the link.
        link: usize,
        /// Index of the `<collision>` element in the link.
        element: usize,
    },
    /// Obstacle `index` of the scene.
    Obstacle(usize),
    /// Object `index` of the scene (free or attached).
    Object(usize),
}

/// One shape placed on a body (or in the world).
#[derive(Debug, Clone)]
pub(crate) struct CollisionObject {
    pub(crate) group: usize,
    pub(crate) shape: Shape,
    /// Pose of the shape in its body frame (world for static objects).
    pub(crate) local: IsometryMatrix3<f64>,
    /// Bounding radius including the padding.
    pub(crate) radius: f64,
    /// Padding added to this object (m): robot and attached objects only.
    pub(crate) padding: f64,
    pub(crate) source: ObjectSource,
    /// World bounding box of a static object.
    pub(crate) aabb: Option<(Point3<f64>, Point3<f64>)>,
    /// `local` has the identity rotation (placing it is a translation).
    pub(crate) unrotated: bool,
}

/// A rigid set of objects: a robot link (or a named surface of one, see
/// [`CollisionModelBuilder::surface_groups`](super::CollisionModelBuilder::surface_groups)), an attached object, an obstacle.
#[derive(Debug, Clone)]
pub(crate) struct Group {
    pub(crate) name: String,
    /// The link a surface group belongs to (its own name otherwise): SRDF
    /// pairs and allowed contacts naming the link cover its surfaces too.
    pub(crate) owner: String,
    /// The body carrying the group; `None` for static groups.
    pub(crate) body: Option<usize>,
    pub(crate) objects: Range<usize>,
    /// Bounding-ball centre, in the body frame (world for static groups).
    pub(crate) center: Point3<f64>,
    pub(crate) radius: f64,
    pub(crate) aabb: Option<(Point3<f64>, Point3<f64>)>,
}

/// Two groups checked against each other, and their object pairs.
#[derive(Debug, Clone)]
pub(crate) struct GroupPair {
    pub(crate) a: usize,
    pub(crate) b: usize,
    /// Every object of `a` against every object of `b`, `a`-major: pair
    /// `pairs.start + k·|b| + l` is object `k` of `a` with object `l` of `b`.
    pub(crate) pairs: Range<usize>,
    /// The deepest body both groups' bodies descend from (the root for a
    /// static group): the joints that change the pair's relative pose are
    /// those from either group's body up to it, not including it (see
    /// [`CollisionModel::movers`](super::CollisionModel::movers)).
    pub(crate) meet: u32,
}

/// The tables of a collision model, borrowed: what the sphere fast path
/// compiles.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Geometry<'a> {
    pub(crate) robot: &'a RobotModel,
    pub(crate) objects: &'a [CollisionObject],
    pub(crate) groups: &'a [Group],
    pub(crate) group_pairs: &'a [GroupPair],
    /// Object index pairs, grouped by group pair.
    pub(crate) pairs: &'a [[u32; 2]],
}

/// For a point `reach` (m) from the origin of body `body`, each body from
/// `body` up to (not including) the root with an upper bound of the
/// distance from its joint origin to the point: the offsets of the bodies
/// in between plus `reach` (triangle inequality, so valid for every q).
pub(crate) fn lever_chain(robot: &RobotModel, body: usize, reach: f64) -> impl Iterator<Item = (usize, f64)> + '_ {
    let mut at = (body, reach);
    std::iter::from_fn(move || {
        let (b, lever) = at;
        if b == 0 {
            return None;
        }
        at = (robot.parent_body(b), lever + robot.body_joint(b).3);
        Some((b, lever))
    })
}
