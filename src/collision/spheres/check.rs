//! Lane-parallel checks over a [`SphereModel`]: forward kinematics of
//! [`LANES`] configurations at once, then the model's pairs with
//! bounding-volume early outs. Plain checks ask whether each pair keeps
//! its padded radii apart; certification checks (see `motion.rs`) ask
//! whether it keeps a clearance over a stretch of motion around each
//! configuration. Allocation-free once the workspace exists.

use super::lanes::{
    LANES, Lane, LanePose, box_distance_squared, box_distance_squared_local, cylinder_distance_squared,
    lane_distance_squared, point_distance_squared, segment_distance_squared, sin_cos, to_local,
};
use super::{Isa, SphereModel, StaticKind, StaticShape, TOLERANCE};
use crate::robot::Motion;

/// Per-thread scratch of the sphere checks.
#[derive(Debug, Clone)]
pub(crate) struct SphereWorkspace {
    /// Per active joint: its value in each lane.
    q: Vec<Lane>,
    /// Per body: its world pose in each lane (the root stays the identity).
    poses: Vec<LanePose>,
    /// Per sphere: world centre, valid when its group is `placed`.
    centers: Vec<[Lane; 3]>,
    /// Per group: world centre of its bounding ball.
    group_centers: Vec<[Lane; 3]>,
    placed: Vec<bool>,
    /// Spheres of two groups near each other (capacity: the largest group).
    near_a: Vec<u32>,
    near_b: Vec<u32>,
    /// Certification of the current motion: per sphere, the prefix sums
    /// of its sweep terms (m per unit of motion), a leading 0 first, at
    /// `terms.start + sphere`; per group, its spheres' largest sweep.
    pub(super) prefix: Vec<f64>,
    pub(super) group_sweep: Vec<f64>,
    pub(super) margins: Margins,
    /// Intervals of the motion still to certify.
    pub(crate) intervals: std::collections::VecDeque<(f64, f64)>,
}

/// What a certification check asks of each pair (m): to stay `full` apart
/// at the checked configurations, and `half` apart over `width` (fraction
/// of the motion) on either side of them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Margins {
    pub(super) half: f64,
    pub(super) full: f64,
    pub(super) width: Lane,
}

impl SphereWorkspace {
    pub(crate) fn new(model: &SphereModel, nq: usize) -> SphereWorkspace {
        let largest = model.groups.iter().map(|g| g.spheres.len()).max().unwrap_or(0);
        SphereWorkspace {
            q: vec![[0.0; LANES]; nq],
            poses: vec![LanePose::IDENTITY; model.bodies.len()],
            centers: vec![[[0.0; LANES]; 3]; model.spheres.len()],
            group_centers: vec![[[0.0; LANES]; 3]; model.groups.len()],
            placed: vec![false; model.groups.len()],
            near_a: Vec::with_capacity(largest),
            near_b: Vec::with_capacity(largest),
            prefix: vec![0.0; model.sweep_terms.len() + model.spheres.len()],
            group_sweep: vec![0.0; model.groups.len()],
            margins: Margins { half: 0.0, full: 0.0, width: [0.0; LANES] },
            intervals: std::collections::VecDeque::with_capacity(256),
        }
    }
}

/// What a batch of lanes came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Some lane certainly collides (plain), or is closer than the full
    /// clearance (certification).
    Collides,
    /// No lane collides. Flagged lanes: `unsure`, a pair of theirs lies
    /// within the tolerance band of its threshold (the exact model
    /// decides); `split`, certification: free, but some pair does not keep
    /// its margin over the whole width.
    Free { unsure: [bool; LANES], split: [bool; LANES] },
}

/// True when every lane's squared distance `d2` exceeds its `limit²` by
/// the tolerance: the limits (m) are certainly cleared.
#[inline(always)]
fn all_beyond(d2: &Lane, limit: &Lane) -> bool {
    let mut all = true;
    for l in 0..LANES {
        all &= d2[l] > (limit[l] + TOLERANCE) * (limit[l] + TOLERANCE);
    }
    all
}

/// Lane flags gathered over a batch.
struct Flags {
    unsure: [bool; LANES],
    split: [bool; LANES],
}

/// Folds one pair into the flags, given each lane's squared distance `d2`
/// (m², negative inside) and the distance it must clear to pass (`pass`)
/// and below which it fails (`fail`, more than the tolerance): true when
/// a lane certainly fails.
#[inline(always)]
fn fails(d2: &Lane, pass: &Lane, fail: f64, flags: &mut Flags) -> bool {
    if all_beyond(d2, pass) {
        return false;
    }
    let (near, band) = ((fail - TOLERANCE) * (fail - TOLERANCE), (fail + TOLERANCE) * (fail + TOLERANCE));
    for l in 0..LANES {
        let d = d2[l];
        if d < near {
            return true;
        }
        // NaN lands here too: the exact model decides.
        flags.unsure[l] |= d <= band || d.is_nan();
        flags.split[l] |= d <= (pass[l] + TOLERANCE) * (pass[l] + TOLERANCE);
    }
    false
}

impl StaticShape {
    /// Squared distance (m², negative inside) from each lane's point to the
    /// shape's core, and the radius the core is swept by (m).
    #[inline(always)]
    fn core_distance_squared(&self, p: &[Lane; 3]) -> (Lane, f64) {
        match &self.kind {
            StaticKind::Sphere { center, radius } => (point_distance_squared(p, center), *radius),
            StaticKind::Capsule { a, ab, len2, radius } => (segment_distance_squared(p, a, ab, *len2), *radius),
            StaticKind::Box { rotation, translation, half } => {
                (box_distance_squared_local(&to_local(p, rotation, translation), half), 0.0)
            }
            StaticKind::Cylinder { rotation, translation, radius, half_length } => {
                (cylinder_distance_squared(&to_local(p, rotation, translation), *radius, *half_length), 0.0)
            }
        }
    }
}

impl SphereModel {
    /// Some pair that no joint moves collides: no configuration is free.
    pub(crate) fn always_collides(&self) -> bool {
        self.fixed_collision
    }

    /// Checks configuration `q` (length already validated).
    pub(crate) fn check_one(&self, ws: &mut SphereWorkspace, q: &[f64]) -> Verdict {
        for (lane, &v) in ws.q.iter_mut().zip(q) {
            *lane = [v; LANES];
        }
        self.check::<false>(ws)
    }

    /// Sets lane `l` to `q0 + (q1 − q0) t[l]` (the exact model's
    /// interpolation, to the bit).
    pub(super) fn set_along(&self, ws: &mut SphereWorkspace, q0: &[f64], q1: &[f64], t: &Lane) {
        for ((lane, a), b) in ws.q.iter_mut().zip(q0).zip(q1) {
            for (v, &t) in lane.iter_mut().zip(t) {
                *v = a + (b - a) * t;
            }
        }
    }

    /// Runs the plain (`CERTIFY` false) or certification check on the
    /// configurations in the workspace.
    pub(super) fn check<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace) -> Verdict {
        match self.isa {
            // SAFETY: `Isa::detect` found these instructions on this CPU.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.check_avx512::<CERTIFY>(ws) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.check_avx2::<CERTIFY>(ws) },
            Isa::Baseline => self.check_lanes::<CERTIFY>(ws),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    fn check_avx512<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace) -> Verdict {
        self.check_lanes::<CERTIFY>(ws)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn check_avx2<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace) -> Verdict {
        self.check_lanes::<CERTIFY>(ws)
    }

    /// Per lane, the distance (m) a pair must clear to pass: `reach` for a
    /// plain check; for certification also the margins, with `sweep` the
    /// pair's approach speed bound (m per unit of motion).
    #[inline(always)]
    fn pass_limit<const CERTIFY: bool>(ws: &SphereWorkspace, reach: f64, sweep: f64) -> Lane {
        if !CERTIFY {
            return [reach; LANES];
        }
        let m = &ws.margins;
        std::array::from_fn(|l| (reach + m.half + m.width[l] * sweep).max(reach + m.full))
    }

    /// Sweep bound of sphere `s` (m per unit of motion) leaving out the
    /// first `depth` joints that move it (certification only).
    #[inline(always)]
    fn sweep(&self, ws: &SphereWorkspace, s: usize, depth: usize) -> f64 {
        let at = self.spheres[s].terms.start + s;
        ws.prefix[at + self.spheres[s].terms.len()] - ws.prefix[at + depth]
    }

    #[inline(always)]
    fn check_lanes<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace) -> Verdict {
        self.forward_kinematics(ws);
        for (g, group) in self.groups.iter().enumerate() {
            ws.group_centers[g] = ws.poses[group.body].point(&group.center);
            ws.placed[g] = false;
        }
        let full = if CERTIFY { ws.margins.full } else { 0.0 };
        let mut flags = Flags { unsure: [false; LANES], split: [false; LANES] };
        for (g, group) in self.groups.iter().enumerate() {
            let group_limit = Self::pass_limit::<CERTIFY>(ws, group.radius, ws.group_sweep[g]);
            for &o in &self.env[group.env.clone()] {
                let shape = &self.statics[o as usize];
                if all_beyond(&box_distance_squared(&ws.group_centers[g], &shape.lo, &shape.hi), &group_limit) {
                    continue;
                }
                self.place(ws, g);
                for s in group.spheres.clone() {
                    let (d2, radius) = shape.core_distance_squared(&ws.centers[s]);
                    let reach = self.spheres[s].reach + radius;
                    let sweep = if CERTIFY { self.sweep(ws, s, 0) } else { 0.0 };
                    if fails(&d2, &Self::pass_limit::<CERTIFY>(ws, reach, sweep), reach + full, &mut flags) {
                        return Verdict::Collides;
                    }
                }
            }
        }
        for (p, &[a, b]) in self.self_pairs.iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            let (ga, gb) = (&self.groups[a], &self.groups[b]);
            let depth = self.common_depth[p];
            let largest = |g: &super::SphereGroup| {
                if CERTIFY { g.spheres.clone().map(|s| self.sweep(ws, s, depth)).fold(0.0, f64::max) } else { 0.0 }
            };
            let (sweep_a, sweep_b) = (largest(ga), largest(gb));
            let limit = Self::pass_limit::<CERTIFY>(ws, ga.radius + gb.radius, sweep_a + sweep_b);
            if all_beyond(&lane_distance_squared(&ws.group_centers[a], &ws.group_centers[b]), &limit) {
                continue;
            }
            self.place(ws, a);
            self.place(ws, b);
            // Only spheres that reach into the other group's ball take part.
            let (mut near_a, mut near_b) = (std::mem::take(&mut ws.near_a), std::mem::take(&mut ws.near_b));
            self.spheres_near::<CERTIFY>(ws, (a, b), depth, sweep_b, &mut near_a);
            if !near_a.is_empty() {
                self.spheres_near::<CERTIFY>(ws, (b, a), depth, sweep_a, &mut near_b);
            }
            let mut hit = false;
            'pairs: for &i in &near_a {
                for &j in &near_b {
                    let (i, j) = (i as usize, j as usize);
                    let d2 = lane_distance_squared(&ws.centers[i], &ws.centers[j]);
                    let reach = self.spheres[i].reach + self.spheres[j].reach;
                    let sweep = if CERTIFY { self.sweep(ws, i, depth) + self.sweep(ws, j, depth) } else { 0.0 };
                    if fails(&d2, &Self::pass_limit::<CERTIFY>(ws, reach, sweep), reach + full, &mut flags) {
                        hit = true;
                        break 'pairs;
                    }
                }
            }
            (ws.near_a, ws.near_b) = (near_a, near_b);
            if hit {
                return Verdict::Collides;
            }
        }
        Verdict::Free { unsure: flags.unsure, split: flags.split }
    }

    /// World poses of every body in every lane.
    #[inline(always)]
    fn forward_kinematics(&self, ws: &mut SphereWorkspace) {
        for (b, body) in self.bodies.iter().enumerate().skip(1) {
            let mut pose = ws.poses[body.parent].then_constant(&body.rotation, &body.translation);
            let q = &ws.q[body.column];
            let value: Lane = std::array::from_fn(|l| body.multiplier * q[l] + body.offset);
            match body.motion {
                Motion::Prismatic(axis) => pose.slide(&[axis.x, axis.y, axis.z], &value),
                motion => {
                    let (s, c) = sin_cos(&value);
                    match motion {
                        Motion::RevoluteX => pose.rotate_columns(1, 2, &s, &c),
                        Motion::RevoluteY => pose.rotate_columns(2, 0, &s, &c),
                        Motion::RevoluteZ => pose.rotate_columns(0, 1, &s, &c),
                        Motion::Revolute(axis) | Motion::Prismatic(axis) => {
                            pose.rotate_about(&[axis.x, axis.y, axis.z], &s, &c)
                        }
                    }
                }
            }
            ws.poses[b] = pose;
        }
    }

    /// The spheres of placed group `g` that may reach into group `other`'s
    /// bounding ball in some lane, into `out` (cleared first); `depth` and
    /// `other_sweep` as for the pair (certification).
    #[inline(always)]
    fn spheres_near<const CERTIFY: bool>(
        &self,
        ws: &SphereWorkspace,
        (g, other): (usize, usize),
        depth: usize,
        other_sweep: f64,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        let (center, radius) = (&ws.group_centers[other], self.groups[other].radius);
        for s in self.groups[g].spheres.clone() {
            let sweep = if CERTIFY { self.sweep(ws, s, depth) + other_sweep } else { 0.0 };
            let limit = Self::pass_limit::<CERTIFY>(ws, self.spheres[s].reach + radius, sweep);
            if !all_beyond(&lane_distance_squared(&ws.centers[s], center), &limit) {
                out.push(s as u32);
            }
        }
    }

    /// World centres of group `g`'s spheres, once per batch.
    #[inline(always)]
    fn place(&self, ws: &mut SphereWorkspace, g: usize) {
        if ws.placed[g] {
            return;
        }
        let group = &self.groups[g];
        let pose = &ws.poses[group.body];
        for s in group.spheres.clone() {
            ws.centers[s] = pose.point(&self.spheres[s].center);
        }
        ws.placed[g] = true;
    }
}
