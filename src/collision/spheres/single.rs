//! The plain check in single precision. Eight f32 lanes fill one AVX2
//! register where eight f64 lanes take two, so the plain check (most of
//! a search's collision work) costs about half as many vector operations.
//! Its verdicts are those of the f64 check, to the bit of every answer:
//!
//! - A bound on its rounding, `band` (m), is derived from the model
//!   (below). Where every pair clears its threshold by more than `band`,
//!   or some pair falls short of it by more than `band`, the f64 check
//!   would say the same: free, or colliding.
//! - Any pair closer than `band` to its threshold (and NaN) sends the
//!   batch to the f64 check, which decides as it always does (its own
//!   band of `TOLERANCE` hands the closest calls to the exact model).
//!
//! The bound: a joint angle rounded to f32 is off by at most `u · 8` rad
//! (`u` the unit roundoff of f32; larger angles are reduced by π/2 in f64
//! instead), and the f32 kernels return sine and cosine within a few `u`.
//! Each placement multiplies unit-bounded rotations, so rotation entries
//! drift by a few `u` per body along a chain; a point's error is then at
//! most a few `u` per body times the largest coordinate the check meets,
//! `scale` (the robot's reach from the world origin over its slides'
//! limits, plus the farthest static coordinate). Squared distances near a
//! threshold add a few `u` more. `band = u · scale · (64 (depth + 2) + 8
//! depth)` keeps a wide factor over that sum, and a test measures the
//! actual error against it (`tests.rs`: about 1/200 of the band on the
//! benchmark robots). Configurations whose slides lie outside the
//! limits the bound assumed go to the f64 check directly.
//!
//! Certification stays in f64: its margins are the answer. (A first pass
//! in f32 that answered only the batches whose pairs all clear their
//! limits by the band deferred half of the Panda's batches and cost 20 %
//! more instructions.)

use super::check::Verdict;
use super::lanes::{LANES, Lane, single};
use super::quarter_turns::norm;
use super::real::SINGLE_REDUCTION_LIMIT;
use super::workspace::SphereWorkspace;
use super::{
    BodySphere, Cluster, EnvChunk, LaneBody, SimdLevel, SphereGroup, SphereModel, StaticKind, StaticShape, SweepTerm,
};
use crate::robot::{Motion, RobotModel};

/// Above this band (m) the single-precision check would defer too often
/// to be worth running (a scene spread over hundreds of metres).
const LARGEST_BAND: f64 = 1e-3;

/// The single-precision copy of a [`SphereModel`] and what its error
/// bound assumes.
#[derive(Debug, Clone)]
pub(crate) struct SinglePrecision {
    pub(super) model: SphereModel<f32>,
    /// The sliding joints' ranges the bound assumed.
    slides: Vec<SlideRange>,
}

/// A sliding joint's column of q and the range of its value (m) that the
/// rounding bound assumed: its limits.
#[derive(Debug, Clone, Copy)]
struct SlideRange {
    column: usize,
    lower: f64,
    upper: f64,
}

impl SinglePrecision {
    /// The f32 copy of `model` (a compiled f64 model of `robot`), or `None`
    /// when its rounding bound exceeds [`LARGEST_BAND`], a slide is
    /// unlimited, or some sphere is not wider than twice the bound.
    pub(super) fn new(model: &SphereModel, robot: &RobotModel) -> Option<SinglePrecision> {
        let (band, slides) = rounding_band(model, robot)?;
        if band > LARGEST_BAND || model.spheres.iter().any(|s| s.reach <= 2.0 * band) {
            return None;
        }
        let single = SphereModel {
            bodies: model.bodies.iter().map(LaneBody::single).collect(),
            spheres: model
                .spheres
                .iter()
                .map(|s| BodySphere { center: single(&s.center), reach: s.reach as f32 })
                .collect(),
            groups: model.groups.iter().map(SphereGroup::single).collect(),
            clusters: model.clusters.iter().map(Cluster::single).collect(),
            cluster_group: model.cluster_group.clone(),
            statics: model.statics.iter().map(StaticShape::single).collect(),
            env: model.env.iter().map(EnvChunk::single).collect(),
            sweep_terms: model
                .sweep_terms
                .iter()
                .map(|t| SweepTerm { body: t.body, lever: t.lever as f32, slides: t.slides })
                .collect(),
            levers: model.levers.iter().map(|&l| l as f32).collect(),
            self_pairs: model.self_pairs.clone(),
            self_blocks: model.self_blocks.clone(),
            segments: model.segments.clone(),
            segment_groups: model.segment_groups.clone(),
            common_depth: model.common_depth.clone(),
            fixed_collision: model.fixed_collision,
            snapped: model.snapped,
            isa: model.isa,
            tolerance: band as f32,
            single: None,
        };
        Some(SinglePrecision { model: single, slides })
    }

    /// The band (m) of the bound.
    pub(super) fn band(&self) -> f64 {
        self.model.tolerance as f64
    }

    /// Whether the bound holds for the lanes of `q`: every slide within
    /// the limits it assumed.
    pub(super) fn covers(&self, q: &[Lane]) -> bool {
        self.slides.iter().all(|s| q[s.column].iter().all(|&v| v >= s.lower && v <= s.upper))
    }
}

/// `band` (see the module documentation) and the slides' assumed ranges,
/// or `None` when a slide has no finite limits.
fn rounding_band(model: &SphereModel, robot: &RobotModel) -> Option<(f64, Vec<SlideRange>)> {
    let limits = robot.limits();
    let n = model.bodies.len();
    let (mut origin, mut depth, mut slides) = (vec![0.0f64; n], vec![0usize; n], Vec::new());
    for b in 1..n {
        let body = &model.bodies[b];
        let slide = if matches!(body.motion, Motion::Prismatic(_)) {
            let (lower, upper) = (limits[body.column].lower, limits[body.column].upper);
            if !(lower.is_finite() && upper.is_finite()) {
                return None;
            }
            slides.push(SlideRange { column: body.column, lower, upper });
            body.multiplier.abs() * lower.abs().max(upper.abs()) + body.offset.abs()
        } else {
            0.0
        };
        origin[b] = origin[body.parent] + norm(&body.translation) + slide;
        depth[b] = depth[body.parent] + 1;
    }
    let reach = model.groups.iter().map(|g| origin[g.body] + norm(&g.center) + g.radius).fold(0.0, f64::max);
    let world = model
        .statics
        .iter()
        .map(|s| norm(&std::array::from_fn(|i| s.lo[i].abs().max(s.hi[i].abs()))))
        .fold(0.0, f64::max);
    let deepest = depth.iter().copied().max().unwrap_or(0);
    let u = f32::EPSILON as f64 / 2.0;
    let angle = SINGLE_REDUCTION_LIMIT as f64 * deepest as f64;
    Some((u * (reach + world) * (64.0 * (deepest + 2) as f64 + angle), slides))
}

impl SphereModel {
    /// The plain check of the configurations in the workspace: in single
    /// precision when the model has it and its bound covers them, in f64
    /// when it does not or when a pair lies within its band.
    #[inline]
    pub(super) fn check_plain(&self, ws: &mut SphereWorkspace) -> Verdict {
        if let (Some(single), Some(scratch)) = (self.single.as_deref(), ws.single.as_deref_mut())
            && single.covers(&ws.q)
        {
            scratch.q.copy_from_slice(&ws.q);
            match single.model.check::<false>(scratch) {
                Verdict::Collides => return Verdict::Collides,
                Verdict::Free { unsure, split } if !unsure.contains(&true) => return Verdict::Free { unsure, split },
                Verdict::Free { .. } => {}
            }
        }
        self.check::<false>(ws)
    }

    /// The single-precision check's band (m), `None` without one.
    pub(crate) fn single_precision_band(&self) -> Option<f64> {
        self.single.as_deref().map(SinglePrecision::band)
    }

    /// Runs both precisions' checks compiled for `level`.
    pub(crate) fn set_isa(&mut self, level: SimdLevel) {
        self.isa = level;
        if let Some(single) = self.single.as_deref_mut() {
            single.model.isa = level;
        }
    }

    /// Checks configuration `q` (length already validated).
    pub(crate) fn check_one(&self, ws: &mut SphereWorkspace, q: &[f64]) -> Verdict {
        for (lane, &v) in ws.q.iter_mut().zip(q) {
            *lane = [v; LANES];
        }
        self.check_plain(ws)
    }
}

impl LaneBody {
    fn single(&self) -> LaneBody<f32> {
        LaneBody {
            parent: self.parent,
            rotation: self.rotation.single(),
            translation: single(&self.translation),
            motion: self.motion,
            axis: single(&self.axis),
            column: self.column,
            multiplier: self.multiplier,
            offset: self.offset,
        }
    }
}

impl SphereGroup {
    fn single(&self) -> SphereGroup<f32> {
        SphereGroup {
            body: self.body,
            clusters: self.clusters.clone(),
            center: single(&self.center),
            radius: self.radius as f32,
            env: self.env.clone(),
        }
    }
}

impl Cluster {
    fn single(&self) -> Cluster<f32> {
        Cluster {
            spheres: self.spheres.clone(),
            center: single(&self.center),
            radius: self.radius as f32,
            terms: self.terms.clone(),
            slot: self.slot,
        }
    }
}

impl StaticShape {
    fn single(&self) -> StaticShape<f32> {
        let kind = match &self.kind {
            StaticKind::Sphere { center, radius } => {
                StaticKind::Sphere { center: single(center), radius: *radius as f32 }
            }
            StaticKind::Capsule { a, ab, len2, radius } => {
                StaticKind::Capsule { a: single(a), ab: single(ab), len2: *len2 as f32, radius: *radius as f32 }
            }
            StaticKind::Box { frame, half } => StaticKind::Box { frame: frame.single(), half: single(half) },
            StaticKind::Cylinder { frame, radius, half_length } => {
                StaticKind::Cylinder { frame: frame.single(), radius: *radius as f32, half_length: *half_length as f32 }
            }
            StaticKind::Cloud { frame, points, radius } => {
                StaticKind::Cloud { frame: frame.clone(), points: points.clone(), radius: *radius as f32 }
            }
        };
        StaticShape { kind, lo: single(&self.lo), hi: single(&self.hi) }
    }
}

impl EnvChunk {
    fn single(&self) -> EnvChunk<f32> {
        EnvChunk { lo: self.lo.map(|x| single(&x)), hi: self.hi.map(|x| single(&x)), shapes: self.shapes }
    }
}
