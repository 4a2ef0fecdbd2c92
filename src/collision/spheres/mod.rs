//! The sphere fast path of boolean collision checks.
//!
//! When every moving collision object (robot links, attached objects) is a
//! sphere and every static one a sphere, capsule, box or cylinder — the
//! spherized robots of motion planning benchmarks — a
//! [`CollisionModel`](super::CollisionModel)
//! also compiles a [`SphereModel`]: flat arrays of sphere centres per body,
//! static shapes with their world boxes, and per body group the list of
//! static shapes and groups it is checked against (the model's pairs,
//! exactly). Checks then run [`LANES`] configurations side by
//! side: forward kinematics specialised to the bodies' joints, group
//! bounding spheres against world boxes, then sphere against shape in
//! closed form.
//!
//! The answers are the exact model's. Each lane's margin (distance minus
//! threshold, m) is computed to within rounding (≈1e-15 m) plus, for
//! URDFs that write π/2 to eleven digits, the bound of taking those joint
//! frames as exact quarter turns (`quarter_turns.rs`, ≤ 2.5e-10 m); a pair is
//! called free or colliding only when its margin clears ±[`TOLERANCE`],
//! a million times that, and a configuration with any pair inside the band
//! is handed to the exact model's own check.
//!
//! Plain checks run first in single precision (`single.rs`): eight f32
//! lanes per AVX2 register instead of four f64 ones. A batch with any pair
//! within that check's rounding band (about 0.1 mm) of its threshold goes
//! to the f64 check, so the answers stay the f64 check's, bit for bit.
//! Certification runs in f64.

mod check;
mod lanes;
mod motion;
mod quarter_turns;
mod real;
mod segments;
mod single;
mod sweep;
#[cfg(test)]
mod tests;
mod workspace;

pub(crate) use check::Verdict;
use lanes::FrameRotation;
pub use lanes::LANES;
pub(crate) use motion::{Certification, SampleOrder};
pub use quarter_turns::SnappedQuarterTurns;
use quarter_turns::norm;
pub(crate) use workspace::SphereWorkspace;

use super::distance::closer_than;
use super::geometry::{CollisionObject, Geometry, Group, lever_chain};
use crate::robot::{Motion, RobotModel};
use crate::scene::Shape;
use nalgebra::IsometryMatrix3;
use std::ops::Range;

/// Width (m) of the band around each pair's threshold inside which the
/// fast path defers to the exact model.
pub(crate) const TOLERANCE: f64 = 1e-9;

/// One moving body of the kinematic chain, as constants.
#[derive(Debug, Clone)]
struct LaneBody<T = f64> {
    parent: usize,
    /// Joint frame in the parent body frame at zero joint value.
    rotation: FrameRotation<T>,
    translation: [T; 3],
    motion: Motion,
    /// The joint's unit axis in its frame.
    axis: [T; 3],
    column: usize,
    multiplier: f64,
    offset: f64,
}

/// The spheres of one moving group (a link or an attached object).
#[derive(Debug, Clone)]
struct SphereGroup<T = f64> {
    body: usize,
    /// Into [`SphereModel::clusters`]: the group's spheres in small balls.
    clusters: Range<usize>,
    /// Bounding ball in the body frame; the radius includes the padding (m).
    center: [T; 3],
    radius: T,
    /// Into [`SphereModel::env`]: the static shapes checked against this
    /// group, [`LANES`] at a time.
    env: Range<usize>,
}

/// A few neighbouring spheres of a group, and a ball around them in the
/// body frame (the radius includes their reach, m).
#[derive(Debug, Clone)]
struct Cluster<T = f64> {
    spheres: Range<usize>,
    center: [T; 3],
    radius: T,
    /// Into [`SphereModel::sweep_terms`]: the joints moving the cluster,
    /// root first.
    terms: Range<usize>,
    /// Where its sweep prefix sums start in the workspace (one more slot
    /// than terms).
    slot: usize,
}

/// Spheres per cluster, at most.
const CLUSTER_SIZE: usize = 4;

/// Splits `spheres` (reordered in place; the first is number `offset` of
/// the model) into clusters of at most [`CLUSTER_SIZE`] by halving along
/// the longest extent of their centres.
fn cluster(spheres: &mut [BodySphere], offset: usize, out: &mut Vec<Cluster>) {
    let extent = |axis: usize| {
        let values = spheres.iter().map(|s| s.center[axis]);
        values.clone().fold(f64::NEG_INFINITY, f64::max) - values.fold(f64::INFINITY, f64::min)
    };
    if spheres.len() > CLUSTER_SIZE {
        let axis = (0..3).max_by(|&a, &b| extent(a).total_cmp(&extent(b))).unwrap_or(0);
        spheres.sort_by(|a, b| a.center[axis].total_cmp(&b.center[axis]));
        let half = spheres.len() / 2;
        let (low, high) = spheres.split_at_mut(half);
        cluster(low, offset, out);
        cluster(high, offset + half, out);
        return;
    }
    let (center, radius) = ball(spheres);
    out.push(Cluster { spheres: offset..offset + spheres.len(), center, radius, terms: 0..0, slot: 0 });
}

/// A ball around spheres (centre of their box; radius to the farthest
/// surface, m).
fn ball(spheres: &[BodySphere]) -> ([f64; 3], f64) {
    let center: [f64; 3] = std::array::from_fn(|i| {
        let values = spheres.iter().map(|s| s.center[i]);
        0.5 * (values.clone().fold(f64::NEG_INFINITY, f64::max) + values.fold(f64::INFINITY, f64::min))
    });
    let distance = |p: &[f64; 3]| (0..3).map(|i| (p[i] - center[i]).powi(2)).sum::<f64>().sqrt();
    (center, spheres.iter().map(|s| distance(&s.center) + s.reach).fold(0.0, f64::max))
}

/// A sphere on a body: centre in the body frame and the distance its
/// centre must keep from other shapes, radius plus padding (m).
#[derive(Debug, Clone)]
struct BodySphere<T = f64> {
    center: [T; 3],
    reach: T,
}

/// One joint's share of how fast the sphere centres of a cluster can
/// move: at most `lever` times the speed of the joint of body `body`. For
/// a revolute joint the lever bounds the distance from the joint's origin
/// to them for every q (m); a prismatic joint moves them exactly as fast
/// as it slides (`slides`, lever 1).
#[derive(Debug, Clone, Copy)]
struct SweepTerm<T = f64> {
    body: usize,
    lever: T,
    slides: bool,
}

/// A static shape in world coordinates (m), with its world bounding box.
#[derive(Debug, Clone)]
struct StaticShape<T = f64> {
    kind: StaticKind<T>,
    lo: [T; 3],
    hi: [T; 3],
}

#[derive(Debug, Clone)]
enum StaticKind<T = f64> {
    Sphere {
        center: [T; 3],
        radius: T,
    },
    /// Segment from `a` to `a + ab`, `len2 = |ab|²`, swept by `radius`.
    Capsule {
        a: [T; 3],
        ab: [T; 3],
        len2: T,
        radius: T,
    },
    Box {
        frame: lanes::Frame<T>,
        half: [T; 3],
    },
    Cylinder {
        frame: lanes::Frame<T>,
        radius: T,
        half_length: T,
    },
    /// Balls of `radius` at a cloud's points; `frame` places the points
    /// (queried in f64 in either precision: the tree is f64).
    Cloud {
        frame: lanes::Frame,
        points: std::sync::Arc<crate::point_cloud::PointTree>,
        radius: T,
    },
}

/// Up to [`LANES`] static shapes a group is checked
/// against, with their world boxes side by side (empty slots: inverted
/// boxes, which nothing meets).
#[derive(Debug, Clone)]
struct EnvChunk<T = f64> {
    lo: [lanes::Lane<T>; 3],
    hi: [lanes::Lane<T>; 3],
    shapes: [u32; lanes::LANES],
}

impl EnvChunk {
    fn new(shapes: &[u32], statics: &[StaticShape]) -> EnvChunk {
        let mut chunk = EnvChunk {
            lo: [[f64::INFINITY; lanes::LANES]; 3],
            hi: [[f64::NEG_INFINITY; lanes::LANES]; 3],
            shapes: [0; lanes::LANES],
        };
        for (k, &o) in shapes.iter().enumerate() {
            for i in 0..3 {
                chunk.lo[i][k] = statics[o as usize].lo[i];
                chunk.hi[i][k] = statics[o as usize].hi[i];
            }
            chunk.shapes[k] = o;
        }
        chunk
    }
}

/// Which compiled variant of the sphere fast path's checks runs: the
/// portable one, or one compiled for AVX2 + FMA or AVX-512 (x86-64). All
/// give the same answers (the fast-path tests run each one this CPU has).
///
/// By default the best one the CPU offers runs; the environment variable
/// `TANDEM_SIMD` (`baseline`, `avx2`, `avx512`, read when a collision model
/// is built) or [`CollisionModel::set_simd`](super::CollisionModel::set_simd)
/// ask for another: the best available one not above it runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// Portable code on [`LANES`]-wide arrays (auto-vectorised as the target allows).
    Baseline,
    /// Compiled with AVX2 and FMA enabled.
    Avx2,
    /// Compiled with AVX-512 (F, DQ, VL), AVX2 and FMA enabled.
    Avx512,
}

impl SimdLevel {
    /// Every level, lowest first.
    pub const ALL: [SimdLevel; 3] = [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512];

    /// Whether this CPU runs the level.
    pub fn is_available(self) -> bool {
        match self {
            SimdLevel::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => {
                SimdLevel::Avx2.is_available()
                    && std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The levels this CPU runs, lowest first.
    pub fn available() -> Vec<SimdLevel> {
        SimdLevel::ALL.into_iter().filter(|l| l.is_available()).collect()
    }

    /// The best available level not above `wanted` (the best of all for `None`).
    pub fn best_up_to(wanted: Option<SimdLevel>) -> SimdLevel {
        let cap = wanted.unwrap_or(SimdLevel::Avx512);
        SimdLevel::ALL.into_iter().rev().find(|l| *l <= cap && l.is_available()).unwrap_or(SimdLevel::Baseline)
    }

    /// Lower-case name, as `TANDEM_SIMD` spells it.
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Baseline => "baseline",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }

    /// The level `TANDEM_SIMD` asks for (`None`: unset, empty or `auto`).
    /// An unknown value is reported once on stderr and ignored.
    pub fn from_environment() -> Option<SimdLevel> {
        let value = std::env::var("TANDEM_SIMD").ok()?;
        let value = value.trim().to_ascii_lowercase();
        if value.is_empty() || value == "auto" {
            return None;
        }
        let level = SimdLevel::ALL.into_iter().find(|l| l.name() == value);
        if level.is_none() {
            static WARNED: std::sync::Once = std::sync::Once::new();
            WARNED.call_once(|| {
                eprintln!(
                    "warning: TANDEM_SIMD={value} is not baseline, avx2, avx512 or auto; using the best available"
                );
            });
        }
        level
    }
}

/// The spheres of a [`CollisionModel`](super::CollisionModel) as flat arrays for lane-parallel
/// boolean checks; see the [module documentation](self).
#[derive(Debug, Clone)]
pub(crate) struct SphereModel<T = f64> {
    bodies: Vec<LaneBody<T>>,
    spheres: Vec<BodySphere<T>>,
    groups: Vec<SphereGroup<T>>,
    clusters: Vec<Cluster<T>>,
    /// The group of each cluster.
    cluster_group: Vec<u32>,
    statics: Vec<StaticShape<T>>,
    env: Vec<EnvChunk<T>>,
    sweep_terms: Vec<SweepTerm<T>>,
    /// The sweep terms' levers by body then cluster (zero where the body's
    /// joint does not move the cluster).
    levers: Vec<T>,
    /// Pairs of moving groups (indices into `groups`), block by block.
    self_pairs: Vec<[u32; 2]>,
    /// The self pairs in blocks, and the segments (runs of groups along a
    /// chain, as ranges into `segment_groups`) the blocks lie between
    /// (see `segments.rs`).
    self_blocks: Vec<segments::SelfBlock>,
    segments: Vec<Range<usize>>,
    segment_groups: Vec<u32>,
    /// Per self pair: the joints moving both sides (the first ones of each
    /// side's terms), which leave their distance unchanged.
    common_depth: Vec<usize>,
    /// Some pair that no joint moves collides: every configuration collides.
    fixed_collision: bool,
    /// Joint frames replaced by exact quarter turns, and the error bound.
    snapped: SnappedQuarterTurns,
    pub(crate) isa: SimdLevel,
    /// Width (m) of the band around each pair's threshold inside which a
    /// check defers: [`TOLERANCE`] in f64; in f32, the bound of its
    /// rounding (see `single.rs`).
    tolerance: T,
    /// The single-precision plain check, when its error bound is small
    /// enough to be worth it (f64 models only).
    single: Option<Box<single::SinglePrecision>>,
}

fn column_major(pose: &IsometryMatrix3<f64>) -> [f64; 9] {
    let m = pose.rotation.matrix();
    std::array::from_fn(|k| m[(k % 3, k / 3)])
}

fn vector(v: &nalgebra::Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

impl StaticShape {
    fn new(o: &CollisionObject) -> Option<StaticShape> {
        let (rotation, translation) = (column_major(&o.local), vector(&o.local.translation.vector));
        let kind = match o.shape {
            Shape::Sphere { radius } => StaticKind::Sphere { center: translation, radius },
            Shape::Capsule { radius, half_length } => {
                let axis = o.local.rotation.matrix().column(2) * half_length;
                let a = o.local.translation.vector - axis;
                StaticKind::Capsule {
                    a: vector(&a),
                    ab: vector(&(axis * 2.0)),
                    len2: (axis * 2.0).norm_squared(),
                    radius,
                }
            }
            Shape::Box { half_extents } => {
                StaticKind::Box { frame: lanes::Frame::new(rotation, translation), half: vector(&half_extents) }
            }
            Shape::Cylinder { radius, half_length } => {
                StaticKind::Cylinder { frame: lanes::Frame::new(rotation, translation), radius, half_length }
            }
            Shape::Points { ref points, radius } => {
                StaticKind::Cloud { frame: lanes::Frame::new(rotation, translation), points: points.clone(), radius }
            }
            Shape::Convex(_) => return None,
        };
        let (lo, hi) = o.aabb?;
        Some(StaticShape { kind, lo: vector(&lo.coords), hi: vector(&hi.coords) })
    }
}

impl SphereModel {
    /// The fast path of `model`, or `None` when some moving object is not a
    /// sphere or some static object checked against one is a convex hull.
    pub(crate) fn compile(model: Geometry<'_>) -> Option<SphereModel> {
        let robot: &RobotModel = model.robot;
        let mut bodies: Vec<LaneBody> = robot
            .bodies
            .iter()
            .map(|b| {
                let placement = b.placement.after(&IsometryMatrix3::identity());
                LaneBody {
                    parent: b.parent,
                    rotation: FrameRotation::General(column_major(&placement)),
                    translation: vector(&placement.translation.vector),
                    motion: b.motion,
                    axis: vector(&b.motion.axis()),
                    column: b.column,
                    multiplier: b.multiplier,
                    offset: b.offset,
                }
            })
            .collect();
        // Moving groups, in model order; `index[g]` is the fast-path index of model group g.
        let mut index = vec![u32::MAX; model.groups.len()];
        let (mut groups, mut spheres, mut sweep_terms) = (Vec::new(), Vec::new(), Vec::new());
        let mut clusters = Vec::new();
        for (g, group) in model.groups.iter().enumerate() {
            let Some(body) = group.body else { continue };
            let start = spheres.len();
            for o in &model.objects[group.objects.clone()] {
                let Shape::Sphere { radius } = o.shape else { return None };
                // The checks compare squared distances to (reach ± tolerance)².
                if radius + o.padding <= TOLERANCE {
                    return None;
                }
                spheres.push(BodySphere { center: vector(&o.local.translation.vector), reach: radius + o.padding });
            }
            index[g] = groups.len() as u32;
            let first = clusters.len();
            cluster(&mut spheres[start..], start, &mut clusters);
            for (k, c) in clusters[first..].iter_mut().enumerate() {
                let farthest = spheres[c.spheres.clone()].iter().map(|s| norm(&s.center)).fold(0.0, f64::max);
                let at = sweep_terms.len();
                sweep_terms.extend(lever_chain(robot, body, farthest).map(|(body, lever)| {
                    let slides = robot.bodies[body].motion.is_prismatic();
                    SweepTerm { body, lever: if slides { 1.0 } else { lever }, slides }
                }));
                sweep_terms[at..].reverse();
                c.terms = at..sweep_terms.len();
                // Clusters' terms follow each other: one more slot per cluster.
                c.slot = at + first + k;
            }
            let (center, radius) = ball(&spheres[start..]);
            groups.push(SphereGroup { body, clusters: first..clusters.len(), center, radius, env: 0..0 });
        }
        let (mut statics, mut static_index) = (Vec::new(), vec![u32::MAX; model.objects.len()]);
        let mut env_lists = vec![Vec::new(); groups.len()];
        let (mut self_pairs, mut common_depth, mut fixed_collision) = (Vec::new(), Vec::new(), false);
        // Depth of each body below the root (parents come before children).
        let mut depth = vec![0usize; robot.bodies.len()];
        for b in 1..depth.len() {
            depth[b] = depth[robot.bodies[b].parent] + 1;
        }
        for gp in model.group_pairs {
            let (a, b): (&Group, &Group) = (&model.groups[gp.a], &model.groups[gp.b]);
            if a.body.is_some() && b.body.is_some() {
                self_pairs.push([index[gp.a], index[gp.b]]);
                // The joints moving both sides: those above their meeting body, and its own.
                common_depth.push(depth[gp.meet as usize]);
                continue;
            }
            if a.body == Some(0) {
                // Neither side moves: the answer is the same for every q.
                fixed_collision |= gp.pairs.clone().any(|p| {
                    let [i, j] = model.pairs[p].map(|k| &model.objects[k as usize]);
                    closer_than(&i.shape, &i.local, &j.shape, &j.local, i.padding + j.padding)
                });
                continue;
            }
            for j in b.objects.clone() {
                if static_index[j] == u32::MAX {
                    static_index[j] = statics.len() as u32;
                    statics.push(StaticShape::new(&model.objects[j])?);
                }
                env_lists[index[gp.a] as usize].push(static_index[j]);
            }
        }
        let mut env = Vec::new();
        for (group, list) in groups.iter_mut().zip(env_lists) {
            let start = env.len();
            env.extend(list.chunks(lanes::LANES).map(|c| EnvChunk::new(c, &statics)));
            group.env = start..env.len();
        }
        let mut cluster_group = vec![0; clusters.len()];
        for (g, group) in groups.iter().enumerate() {
            cluster_group[group.clusters.clone()].fill(g as u32);
        }
        let parents: Vec<usize> = bodies.iter().map(|b| b.parent).collect();
        let blocks = segments::blocks(&groups, &parents, &mut self_pairs, &mut common_depth);
        let extent = extents(bodies.len(), &groups, &clusters, &spheres);
        let snapped = quarter_turns::snap(&mut bodies, &extent);
        let mut levers = vec![0.0; robot.bodies.len() * clusters.len()];
        for (c, cluster) in clusters.iter().enumerate() {
            for term in &sweep_terms[cluster.terms.clone()] {
                levers[term.body * clusters.len() + c] = term.lever;
            }
        }
        Some(SphereModel {
            levers,
            bodies,
            spheres,
            groups,
            clusters,
            cluster_group,
            statics,
            env,
            sweep_terms,
            self_pairs,
            self_blocks: blocks.blocks,
            segments: blocks.segments,
            segment_groups: blocks.groups,
            common_depth,
            fixed_collision,
            snapped,
            isa: SimdLevel::best_up_to(SimdLevel::from_environment()),
            tolerance: TOLERANCE,
            single: None,
        })
        .map(|mut fast| {
            fast.keep_parting_blocks(robot.limits());
            fast.single = single::SinglePrecision::new(&fast, robot).map(Box::new);
            fast
        })
    }

    /// The quarter turns the fast path snapped (see `quarter_turns.rs`).
    pub(crate) fn snapped(&self) -> SnappedQuarterTurns {
        self.snapped
    }
}

/// Per body, the largest distance (m) from its origin of a point the fast
/// path places on it: sphere, cluster and group centres.
fn extents(bodies: usize, groups: &[SphereGroup], clusters: &[Cluster], spheres: &[BodySphere]) -> Vec<f64> {
    let mut extent = vec![0.0f64; bodies];
    for group in groups {
        let e = &mut extent[group.body];
        *e = e.max(norm(&group.center));
        for cluster in &clusters[group.clusters.clone()] {
            *e = e.max(norm(&cluster.center));
            *e = spheres[cluster.spheres.clone()].iter().fold(*e, |e, s| e.max(norm(&s.center)));
        }
    }
    extent
}
