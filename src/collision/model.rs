//! The compiled collision model: every collision object of the robot and
//! the scene, grouped by rigid body, with the list of pairs to check.

use super::CollisionError;
use super::geometry::{CollisionObject, Geometry, Group, GroupPair, ObjectSource, lever_chain};
use super::spheres::{SimdLevel, SnappedQuarterTurns, SphereModel};
use crate::robot::{RobotDescription, RobotModel, Srdf};
use crate::scene::{Scene, Shape, ShapeError};
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Vector3};
use std::sync::Arc;

/// The robot and its scene as collision geometry, with the pairs to check.
/// Immutable and `Send + Sync`; queries run with a
/// [`CollisionWorkspace`](super::CollisionWorkspace). See the
/// [module example](super).
#[derive(Debug, Clone)]
pub struct CollisionModel {
    pub(crate) robot: Arc<RobotModel>,
    pub(crate) objects: Vec<CollisionObject>,
    pub(crate) groups: Vec<Group>,
    pub(crate) group_pairs: Vec<GroupPair>,
    /// Object index pairs, grouped by group pair.
    pub(crate) pairs: Vec<[u32; 2]>,
    /// Per body: an upper bound (m) of the distance from its joint axis
    /// origin to any point of a collision object it moves, for every q.
    pub(crate) levers: Vec<f64>,
    padding: f64,
    /// The lane-parallel boolean checks, when the geometry allows them.
    pub(crate) spheres: Option<SphereModel>,
}

/// Builds a [`CollisionModel`].
#[derive(Debug, Clone)]
pub struct CollisionModelBuilder {
    robot: Arc<RobotModel>,
    scene: Scene,
    disabled: Vec<(String, String)>,
    padding: f64,
    geometry: Option<Arc<RobotDescription>>,
    surfaces: Vec<String>,
}

impl CollisionModelBuilder {
    /// The obstacles and objects to check against (default: none).
    pub fn scene(mut self, scene: &Scene) -> Self {
        self.scene = scene.clone();
        self
    }

    /// Leaves out the robot link pairs the SRDF disables (`disable_collisions`).
    pub fn srdf(mut self, srdf: &Srdf) -> Self {
        self.disabled.extend(srdf.disabled_pairs.iter().map(|p| (p.link1.clone(), p.link2.clone())));
        self
    }

    /// Inflates every robot shape and attached object by `padding` (m, ≥ 0):
    /// distances are reported to the padded shapes.
    pub fn padding(mut self, padding: f64) -> Self {
        self.padding = padding;
        self
    }

    /// Takes the links' collision geometry from another description of the
    /// same robot (matched by link name), e.g. a spherized URDF.
    pub fn geometry_from(mut self, description: Arc<RobotDescription>) -> Self {
        self.geometry = Some(description);
        self
    }

    /// The robot collision elements named `name` (their URDF `<collision
    /// name="…">`) form a group of their own, named `name`, instead of
    /// joining their link's: pairs can then be allowed for that surface
    /// alone, e.g. a gripper's finger pads against the object it grasps
    /// ([`Scene::allow_contact`](crate::scene::Scene::allow_contact) with
    /// `name`). SRDF pairs and allowed contacts naming the link still cover
    /// the surface. Several elements of a link may share the name.
    pub fn surface_groups<S: Into<String>>(mut self, names: impl IntoIterator<Item = S>) -> Self {
        self.surfaces.extend(names.into_iter().map(Into::into));
        self
    }

    /// Compiles the model.
    ///
    /// # Errors
    /// A negative or non-finite padding, a mesh tandem cannot read, a
    /// geometry description naming links the robot lacks, an attachment to
    /// an unknown frame, allowed-contact names that match nothing, a
    /// surface name that no collision element has or that names a link,
    /// obstacle or object.
    pub fn build(self) -> Result<CollisionModel, CollisionError> {
        if !(self.padding.is_finite() && self.padding >= 0.0) {
            return Err(ShapeError::InvalidShape { what: "padding", value: self.padding }.into());
        }
        let geometry = self.geometry.as_deref().unwrap_or(self.robot.description());
        self.check_surfaces(geometry)?;
        let mut compiler =
            Compiler { robot: &self.robot, objects: Vec::new(), groups: Vec::new(), surfaces: &self.surfaces };
        compiler.robot_links(geometry, self.padding)?;
        compiler.scene(&self.scene, self.padding)?;
        let Compiler { objects, groups, .. } = compiler;
        // Links without geometry are legal names too (nothing to allow, but not a typo).
        let links = self.robot.description().links().iter().map(|l| l.name.as_str());
        let names: Vec<&str> = groups.iter().map(|g| g.name.as_str()).chain(links).collect();
        for (a, b) in self.scene.allowed_contacts() {
            for n in [a, b] {
                if !names.contains(&n.as_str()) {
                    return Err(CollisionError::UnknownName {
                        name: n.clone(),
                        suggestions: crate::robot::suggest_names(n, names.iter().copied()),
                    });
                }
            }
        }
        // Name pairs sorted, looked up by binary search without allocating:
        // an SRDF of a large robot lists thousands, and a model has
        // hundreds of group pairs to test (each sample of a dataset builds
        // its models).
        fn key<'a>(a: &'a str, b: &'a str) -> (&'a str, &'a str) {
            if a <= b { (a, b) } else { (b, a) }
        }
        fn sorted(pairs: &[(String, String)]) -> Vec<(&str, &str)> {
            let mut keys: Vec<(&str, &str)> = pairs.iter().map(|(a, b)| key(a, b)).collect();
            keys.sort_unstable();
            keys
        }
        let (disabled, allowed) = (sorted(&self.disabled), sorted(self.scene.allowed_contacts()));
        let is_excluded = |a: &Group, b: &Group| {
            let listed = |set: &[(&str, &str)]| {
                [(&a.name, &b.name), (&a.name, &b.owner), (&a.owner, &b.name), (&a.owner, &b.owner)]
                    .iter()
                    .any(|(x, y)| set.binary_search(&key(x, y)).is_ok())
            };
            match (a.body, b.body) {
                (None, None) => true,
                (Some(ba), Some(bb)) => {
                    ba == bb
                        || self.robot.parent_body(ba) == bb
                        || self.robot.parent_body(bb) == ba
                        || listed(&disabled)
                        || listed(&allowed)
                }
                _ => listed(&allowed),
            }
        };
        let (mut group_pairs, pairs) = pair_up(&groups, is_excluded);
        let levers = levers(&self.robot, &objects, &groups);
        let tree = BodyTree::new(&self.robot);
        for gp in &mut group_pairs {
            gp.meet = tree.meet(groups[gp.a].body.unwrap_or(0), groups[gp.b].body.unwrap_or(0)) as u32;
        }
        let mut model = CollisionModel {
            robot: self.robot,
            objects,
            groups,
            group_pairs,
            pairs,
            levers,
            padding: self.padding,
            spheres: None,
        };
        model.set_fast_path(true);
        Ok(model)
    }

    /// Every surface name is some robot collision element's, and no link's,
    /// obstacle's or object's.
    fn check_surfaces(&self, geometry: &RobotDescription) -> Result<(), CollisionError> {
        let links = self.robot.description().links();
        let element_names =
            || geometry.links().iter().flat_map(|l| l.collisions.iter().filter_map(|c| c.name.as_deref()));
        for name in &self.surfaces {
            let taken = links.iter().any(|l| l.name == *name)
                || self.scene.obstacle(name).is_some()
                || self.scene.object(name).is_some();
            if taken {
                return Err(CollisionError::SurfaceNameTaken { name: name.clone() });
            }
            if !element_names().any(|e| e == name) {
                return Err(CollisionError::UnknownSurface {
                    name: name.clone(),
                    suggestions: crate::robot::suggest_names(name, element_names()),
                });
            }
        }
        Ok(())
    }
}

/// Every non-excluded group pair, moving-versus-static first (the likelier
/// collisions, for early exit), with their object pairs.
fn pair_up(groups: &[Group], excluded: impl Fn(&Group, &Group) -> bool) -> (Vec<GroupPair>, Vec<[u32; 2]>) {
    let mut candidates: Vec<(usize, usize)> = Vec::new();
    for a in 0..groups.len() {
        for b in a + 1..groups.len() {
            if !excluded(&groups[a], &groups[b]) {
                candidates.push((a, b));
            }
        }
    }
    candidates.sort_by_key(|&(a, b)| groups[a].body.is_some() && groups[b].body.is_some());
    let (mut group_pairs, mut pairs) = (Vec::new(), Vec::new());
    for (a, b) in candidates {
        // Static groups always come second, so queries can rely on it.
        let (a, b) = if groups[a].body.is_none() { (b, a) } else { (a, b) };
        let start = pairs.len();
        for i in groups[a].objects.clone() {
            for j in groups[b].objects.clone() {
                pairs.push([i as u32, j as u32]);
            }
        }
        group_pairs.push(GroupPair { a, b, pairs: start..pairs.len(), meet: 0 });
    }
    (group_pairs, pairs)
}

struct Compiler<'a> {
    robot: &'a RobotModel,
    objects: Vec<CollisionObject>,
    groups: Vec<Group>,
    /// Element names that form groups of their own.
    surfaces: &'a [String],
}

impl Compiler<'_> {
    fn robot_links(&mut self, geometry: &RobotDescription, padding: f64) -> Result<(), CollisionError> {
        let own = self.robot.description();
        // A geometry link the robot lacks would silently lose its shapes: refuse it.
        if let Some(stray) = geometry.links().iter().find(|l| !l.collisions.is_empty() && own.link(&l.name).is_none()) {
            return Err(CollisionError::UnknownName {
                name: stray.name.clone(),
                suggestions: crate::robot::suggest_names(&stray.name, own.links().iter().map(|l| l.name.as_str())),
            });
        }
        for (li, link) in own.links().iter().enumerate() {
            let Some(source) = geometry.link(&link.name) else { continue };
            let (body, in_body) = self.robot.frame_in_body(self.robot.link_frame(li));
            // The link's own group, then one group per surface name on it.
            let mut parts: Vec<Option<&String>> = vec![None];
            for element in &source.collisions {
                if let Some(name) = surface_of(element, self.surfaces).filter(|n| !parts.contains(&Some(n))) {
                    parts.push(Some(name));
                }
            }
            for part in parts {
                let start = self.objects.len();
                for (k, element) in
                    source.collisions.iter().enumerate().filter(|(_, e)| surface_of(e, self.surfaces) == part)
                {
                    let shape = Shape::from_geometry(&element.geometry)
                        .map_err(|e| CollisionError::LinkGeometry {
                            urdf: geometry.source().to_string(),
                            link: link.name.clone(),
                            element: k,
                            mesh: match &element.geometry {
                                crate::robot::Geometry::Mesh { path, .. } => Some(path.clone()),
                                _ => None,
                            },
                            source: Box::new(e.into()),
                        })?
                        .ok_or_else(|| CollisionError::UnreadableMesh { link: link.name.clone() })?;
                    let source = ObjectSource::RobotLink { link: li, element: k };
                    self.push_object(shape, in_body * element.origin, padding, source, false);
                }
                self.push_group(part.unwrap_or(&link.name), &link.name, Some(body), start);
            }
        }
        Ok(())
    }

    fn scene(&mut self, scene: &Scene, padding: f64) -> Result<(), CollisionError> {
        for (i, o) in scene.obstacles().iter().enumerate() {
            let start = self.objects.len();
            self.push_object(o.shape.clone(), o.pose, 0.0, ObjectSource::Obstacle(i), true);
            self.push_group(&o.name, &o.name, None, start);
        }
        for (i, o) in scene.objects().iter().enumerate() {
            let start = self.objects.len();
            match &o.attachment {
                Some(att) => {
                    let frame = self.robot.frame_id(&att.frame)?;
                    let (body, in_body) = self.robot.frame_in_body(frame);
                    self.push_object(o.shape.clone(), in_body * att.pose, padding, ObjectSource::Object(i), false);
                    self.push_group(&o.name, &o.name, Some(body), start);
                }
                None => {
                    self.push_object(o.shape.clone(), o.pose, 0.0, ObjectSource::Object(i), true);
                    self.push_group(&o.name, &o.name, None, start);
                }
            }
        }
        Ok(())
    }

    fn push_object(
        &mut self,
        shape: Shape,
        local: IsometryMatrix3<f64>,
        padding: f64,
        source: ObjectSource,
        is_static: bool,
    ) {
        let aabb = is_static.then(|| world_aabb(&shape, &local));
        let radius = shape.bounding_radius() + padding;
        let group = self.groups.len();
        let unrotated = local.rotation == Rotation3::identity();
        self.objects.push(CollisionObject { group, shape, local, radius, padding, source, aabb, unrotated });
    }

    /// Closes a group over the objects pushed since `start` (none: no group).
    fn push_group(&mut self, name: &str, owner: &str, body: Option<usize>, start: usize) {
        let objects = &self.objects[start..];
        if objects.is_empty() {
            return;
        }
        let n = objects.len() as f64;
        let center = Point3::from(objects.iter().map(|o| o.local.translation.vector).sum::<Vector3<f64>>() / n);
        let radius =
            objects.iter().map(|o| (o.local.translation.vector - center.coords).norm() + o.radius).fold(0.0, f64::max);
        let aabb = body.is_none().then(|| {
            objects.iter().filter_map(|o| o.aabb).fold(
                (Point3::from(Vector3::repeat(f64::INFINITY)), Point3::from(Vector3::repeat(f64::NEG_INFINITY))),
                |(lo, hi), (a, b)| (lo.inf(&a), hi.sup(&b)),
            )
        });
        let objects = start..self.objects.len();
        let (name, owner) = (name.to_string(), owner.to_string());
        self.groups.push(Group { name, owner, body, objects, center, radius, aabb });
    }
}

/// The surface group `element` belongs to: its name, if one of `surfaces`.
fn surface_of<'e>(element: &'e crate::robot::CollisionElement, surfaces: &[String]) -> Option<&'e String> {
    element.name.as_ref().filter(|n| surfaces.contains(n))
}

/// For each body, the largest distance from its joint origin to a point of
/// an object it carries or moves through its descendants (see [`lever_chain`]).
fn levers(robot: &RobotModel, objects: &[CollisionObject], groups: &[Group]) -> Vec<f64> {
    let mut levers = vec![0.0f64; robot.body_count()];
    for o in objects {
        let Some(body) = groups[o.group].body else { continue };
        for (b, lever) in lever_chain(robot, body, o.local.translation.vector.norm() + o.radius) {
            levers[b] = levers[b].max(lever);
        }
    }
    levers
}

/// Ancestor queries on the body tree: depths and binary-lifting tables,
/// so the deepest common ancestor of two bodies costs O(log depth). Listing
/// every pair's movers instead cost O(n⁴) time and O(n³) memory in the
/// number of links (10 s and 700 MB for a 1,000-link chain).
struct BodyTree {
    depth: Vec<u32>,
    /// `up[k][b]`: the ancestor 2^k levels above body `b` (the root above the root).
    up: Vec<Vec<u32>>,
}

impl BodyTree {
    fn new(robot: &RobotModel) -> BodyTree {
        let n = robot.body_count();
        // Bodies are sorted so that a parent comes before its children.
        let mut depth = vec![0u32; n];
        let parents: Vec<u32> = (0..n).map(|b| robot.parent_body(b) as u32).collect();
        for b in 1..n {
            depth[b] = depth[parents[b] as usize] + 1;
        }
        let levels = (usize::BITS - n.max(1).leading_zeros()) as usize;
        let mut up = vec![parents];
        for k in 1..levels {
            let prev = &up[k - 1];
            let next = prev.iter().map(|&p| prev[p as usize]).collect();
            up.push(next);
        }
        BodyTree { depth, up }
    }

    /// The deepest common ancestor of bodies `a` and `b` (a body is its own ancestor).
    fn meet(&self, mut a: usize, mut b: usize) -> usize {
        if self.depth[a] < self.depth[b] {
            std::mem::swap(&mut a, &mut b);
        }
        let mut rise = self.depth[a] - self.depth[b];
        let mut k = 0;
        while rise > 0 {
            if rise & 1 == 1 {
                a = self.up[k][a] as usize;
            }
            rise >>= 1;
            k += 1;
        }
        if a == b {
            return a;
        }
        for level in self.up.iter().rev() {
            if level[a] != level[b] {
                a = level[a] as usize;
                b = level[b] as usize;
            }
        }
        self.up[0][a] as usize
    }
}

/// Tight world bounding box of a shape at `pose`.
fn world_aabb(shape: &Shape, pose: &IsometryMatrix3<f64>) -> (Point3<f64>, Point3<f64>) {
    let r = pose.rotation.matrix();
    let axis = r.column(2).into_owned();
    // Half extent of a disc of radius ρ normal to `axis`, along world axis i.
    let disc = |rho: f64| axis.map(|a| rho * (1.0 - a * a).max(0.0).sqrt());
    let half = match shape {
        Shape::Sphere { radius } => Vector3::repeat(*radius),
        Shape::Capsule { radius, half_length } => axis.abs() * *half_length + Vector3::repeat(*radius),
        Shape::Cylinder { radius, half_length } => axis.abs() * *half_length + disc(*radius),
        Shape::Box { half_extents } => r.abs() * half_extents,
        Shape::Convex(hull) => {
            let (mut lo, mut hi) = (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY));
            for p in hull.polyhedron.points() {
                let w = pose * Point3::new(p.x, p.y, p.z);
                lo = lo.inf(&w.coords);
                hi = hi.sup(&w.coords);
            }
            return (lo.into(), hi.into());
        }
        // The corners of the points' box, placed, grown by the radius (an
        // empty cloud: an inverted box, which nothing meets).
        Shape::Points { points, radius } => {
            let (mut lo, mut hi) = (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY));
            if let Some((a, b)) = points.bounds() {
                for k in 0..8 {
                    let corner = Point3::from(std::array::from_fn(|i| if k >> i & 1 == 1 { b[i] } else { a[i] }));
                    let w = pose * corner;
                    lo = lo.inf(&(w.coords - Vector3::repeat(*radius)));
                    hi = hi.sup(&(w.coords + Vector3::repeat(*radius)));
                }
            }
            return (lo.into(), hi.into());
        }
    };
    let c = pose.translation.vector;
    ((c - half).into(), (c + half).into())
}

impl CollisionModel {
    /// Starts a model of `robot` alone, with its own URDF collision geometry,
    /// no padding and the default self-collision pairs: every pair of links
    /// on different bodies that are not parent and child.
    pub fn builder(robot: Arc<RobotModel>) -> CollisionModelBuilder {
        CollisionModelBuilder {
            robot,
            scene: Scene::new(),
            disabled: Vec::new(),
            padding: 0.0,
            geometry: None,
            surfaces: Vec::new(),
        }
    }

    /// The robot model the configurations refer to.
    pub fn robot(&self) -> &Arc<RobotModel> {
        &self.robot
    }

    /// Padding of robot shapes (m).
    pub fn padding(&self) -> f64 {
        self.padding
    }

    /// Whether boolean checks ([`collision_free`](Self::collision_free),
    /// [`motion_free`](Self::motion_free)) run on the sphere fast path:
    /// [`LANES`](super::LANES) configurations at a time, on flat sphere
    /// data. It is compiled when every robot shape and attached object is
    /// a sphere and no obstacle is a mesh hull, and gives the general
    /// path's answers.
    pub fn has_fast_path(&self) -> bool {
        self.spheres.is_some()
    }

    /// The robot, objects, groups and pairs, for the fast path's compiler.
    pub(crate) fn geometry(&self) -> Geometry<'_> {
        Geometry {
            robot: &self.robot,
            objects: &self.objects,
            groups: &self.groups,
            group_pairs: &self.group_pairs,
            pairs: &self.pairs,
        }
    }

    /// Turns the sphere fast path on (when the geometry allows it; the
    /// default) or off (every boolean check on the general path, e.g. to
    /// cross-check the two). Workspaces made before keep working.
    pub fn set_fast_path(&mut self, enabled: bool) {
        self.spheres = if enabled { SphereModel::compile(self.geometry()) } else { None };
    }

    /// Runs the sphere fast path's checks compiled for `wanted` (the best
    /// available level not above it; `None`: the best of all, ignoring
    /// `TANDEM_SIMD`) and returns the level that runs, `None` without a
    /// fast path. Answers do not change; speed does.
    pub fn set_simd(&mut self, wanted: Option<SimdLevel>) -> Option<SimdLevel> {
        let spheres = self.spheres.as_mut()?;
        spheres.set_isa(SimdLevel::best_up_to(wanted));
        Some(spheres.isa)
    }

    /// Joint frames the fast path takes as exact quarter turns (URDFs'
    /// eleven-digit π/2, a few 1e-12 rad off), with the bound (m) on how far
    /// any sphere it places then lies from the exact model's: within a
    /// quarter of the tolerance band inside which it defers to the exact
    /// model, or nothing is snapped. `None` without a fast path.
    pub fn snapped_quarter_turns(&self) -> Option<SnappedQuarterTurns> {
        self.spheres.as_ref().map(|s| s.snapped())
    }

    /// The band (m) of the fast path's single-precision plain check: it
    /// answers a boolean check when every pair clears its threshold, or
    /// some pair misses it, by more than this, and hands the rest to the
    /// f64 check, so answers do not change. `None` without a fast path, or
    /// when the scene's extent makes the band too wide to be worth it
    /// (over 1 mm). About 0.1 mm for the benchmark robots.
    pub fn single_precision_band(&self) -> Option<f64> {
        self.spheres.as_ref()?.single_precision_band()
    }

    /// The level of the fast path's checks (see [`SimdLevel`]), `None`
    /// without a fast path.
    pub fn simd(&self) -> Option<SimdLevel> {
        self.spheres.as_ref().map(|s| s.isa)
    }

    /// Number of object pairs checked.
    pub fn pair_count(&self) -> usize {
        self.pairs.len()
    }

    /// Number of collision objects (robot elements, then obstacles, then objects).
    pub fn object_count(&self) -> usize {
        self.objects.len()
    }

    /// Where object `index` comes from.
    pub fn object_source(&self, index: usize) -> ObjectSource {
        self.objects[index].source
    }

    /// The objects of pair `pair`: (a, b) indices, a on the robot side.
    pub fn pair_objects(&self, pair: usize) -> (usize, usize) {
        let [a, b] = self.pairs[pair];
        (a as usize, b as usize)
    }

    /// Bodies whose joints change the relative pose of group pair `gp`:
    /// from either side's body up to their deepest common ancestor, not
    /// including it.
    pub(crate) fn movers(&self, gp: &GroupPair) -> impl Iterator<Item = usize> + '_ {
        let meet = gp.meet as usize;
        let climb = move |from: Option<usize>| {
            let mut at = from.unwrap_or(0);
            std::iter::from_fn(move || {
                (at != meet).then(|| {
                    let b = at;
                    at = self.robot.parent_body(b);
                    b
                })
            })
        };
        climb(self.groups[gp.a].body).chain(climb(self.groups[gp.b].body))
    }

    /// Body names (link, obstacle or object) of pair `pair`.
    pub fn pair_names(&self, pair: usize) -> (&str, &str) {
        let (a, b) = self.pair_objects(pair);
        (self.group_name(a), self.group_name(b))
    }

    /// Name of the body (link, obstacle or object) holding object `index`.
    pub fn group_name(&self, object: usize) -> &str {
        &self.groups[self.objects[object].group].name
    }

    /// Pairs of bodies checked against each other, by name.
    pub fn body_pairs(&self) -> impl Iterator<Item = (&str, &str)> {
        self.group_pairs.iter().map(|g| (self.groups[g.a].name.as_str(), self.groups[g.b].name.as_str()))
    }
}
