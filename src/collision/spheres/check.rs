//! Lane-parallel checks over a [`SphereModel`]: forward kinematics of
//! [`LANES`] configurations at once, then the model's pairs with
//! bounding-volume early outs. Plain checks ask whether each pair keeps
//! its padded radii apart; certification checks (see `motion.rs`) ask
//! whether it keeps a clearance over a stretch of motion around each
//! configuration. Allocation-free once the workspace exists.
// Lane loops index several arrays by the lane on purpose (see `lanes.rs`).
#![allow(clippy::needless_range_loop)]

use super::lanes::{
    LANES, Lane, Real, box_approach_local, box_distance_squared_local, build, cylinder_approach_local,
    cylinder_distance_squared, distance_rate, lane_distance_squared, lane_max, lane_min, max, min, point_approach,
    point_distance_squared, rotate_to_local, segment_approach, segment_distance_squared, to_local,
};
use super::workspace::{Pair, Pending, SphereWorkspace};
use super::{SimdLevel, SphereModel, StaticKind, StaticShape};
use crate::robot::Motion;

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

/// True when every lane's squared distance `d2` exceeds its `pass`
/// ((limit + tolerance)², see [`SphereModel::pass_limit`]): the limits are
/// certainly cleared.
#[inline(always)]
fn all_beyond<T: Real>(d2: &Lane<T>, pass: &Lane<T>) -> bool {
    let mut all = true;
    for l in 0..LANES {
        all &= d2[l] > pass[l];
    }
    all
}

/// Lane flags gathered over a batch.
struct Flags<T> {
    unsure: [bool; LANES],
    split: [bool; LANES],
    /// Certification: per lane, the half-width (fraction of the motion)
    /// around the checked configuration over which every pair met so far
    /// keeps `half` (+∞ until a pair falls short of the lane's width).
    room: Lane<T>,
    /// Certification: per lane, the pairs that fell short of its width.
    short: [Pending; LANES],
}

/// Folds one pair's plain verdicts into the flags, given each lane's
/// squared distance `d2` (m², negative inside), what it must clear to pass
/// (`pass`, as for [`all_beyond`]) and the distance below which it fails
/// (`fail`, m, more than the `tolerance`): `None` when a lane certainly
/// fails, else the lanes that fall short of `pass` (all false when every
/// lane clears it).
#[inline(always)]
fn short_lanes<T: Real>(
    d2: &Lane<T>,
    pass: &Lane<T>,
    (fail, tolerance): (T, T),
    flags: &mut Flags<T>,
) -> Option<[bool; LANES]> {
    let mut short = [false; LANES];
    if all_beyond(d2, pass) {
        return Some(short);
    }
    let (near, band) = ((fail - tolerance) * (fail - tolerance), (fail + tolerance) * (fail + tolerance));
    for l in 0..LANES {
        let d = d2[l];
        if d < near {
            return None;
        }
        // NaN lands here too: the exact model decides.
        flags.unsure[l] |= d <= band || d.is_nan();
        short[l] = d <= pass[l];
    }
    Some(short)
}

/// How one pair bounds a certification lane's room: the distance `keep`
/// (m) it must stay above, its approach speed bound `sweep` (m per unit of
/// motion, valid over the lane's whole width), and, at the checked
/// configuration, its distance's rate of change `rate` (m per unit of
/// motion, in absolute value) with the bound `accel` of its second
/// derivative's (m per unit of motion², valid everywhere).
struct PairBounds<'a, T> {
    /// The pair, as [`Pending`] bits.
    pending: Pending,
    keep: T,
    sweep: &'a Lane<T>,
    rate: &'a Lane<T>,
    accel: T,
}

/// Certification: narrows each short lane's room to what the pair keeps
/// and flags the lanes whose room falls short of their half-width
/// `width` for splitting. The distance is a convex function of the points
/// (distance to a convex core, or between two centres), so along the
/// motion it stays above its tangent line at the checked configuration
/// minus the second-order remainder: `d(m + τ) ≥ d(m) − |τ| rate − τ²
/// accel / 2`. Where a motion grazes an obstacle, the rate is near zero
/// and this keeps a far wider room than the first-order `d(m) − |τ| sweep`;
/// the larger of the two is taken (both hold).
#[inline(always)]
fn narrow<T: Real>(
    distance: &Lane<T>,
    short: &[bool; LANES],
    pair: &PairBounds<T>,
    width: &Lane<T>,
    flags: &mut Flags<T>,
) {
    for l in 0..LANES {
        if !short[l] {
            continue;
        }
        let slack = distance[l] - pair.keep;
        // d ≥ keep + room · sweep: the pair keeps `half` over the room.
        let mut room = slack / pair.sweep[l];
        if slack > T::ZERO {
            let rate = pair.rate[l];
            let two = T::of(2.0);
            let second = two * slack / (rate + (rate * rate + two * pair.accel * slack).sqrt());
            // A NaN rate leaves the first-order room.
            if second > room {
                room = second;
            }
        }
        if room < width[l] || room.is_nan() {
            flags.split[l] = true;
            flags.room[l] = min(flags.room[l], room);
            flags.short[l] = flags.short[l].union(pair.pending);
        }
    }
}

impl<T: Real> StaticShape<T> {
    /// Squared distance (m², negative inside) from each lane's point to the
    /// shape's core, and the radius the core is swept by (m).
    #[inline(always)]
    #[cfg(test)]
    pub(super) fn core_distance_squared(&self, p: &[Lane<T>; 3]) -> (Lane<T>, T) {
        self.core_distance_squared_within(p, T::INFINITY)
    }

    /// The radius the shape's core is swept by (m).
    #[inline(always)]
    fn core_radius(&self) -> T {
        match &self.kind {
            StaticKind::Sphere { radius, .. }
            | StaticKind::Capsule { radius, .. }
            | StaticKind::Cloud { radius, .. } => *radius,
            StaticKind::Box { .. } | StaticKind::Cylinder { .. } => T::ZERO,
        }
    }

    /// Squared distance (m², negative inside) from each lane's point to the
    /// shape's core and the core's swept radius (m), exact for the lanes closer than `cap2` (m²) to the core and at least `cap2`
    /// for the others: a cloud's nearest-point search prunes everything
    /// farther (the other kinds are exact anyway).
    #[inline(always)]
    pub(super) fn core_distance_squared_within(&self, p: &[Lane<T>; 3], cap2: T) -> (Lane<T>, T) {
        match &self.kind {
            StaticKind::Sphere { center, radius } => (point_distance_squared(p, center), *radius),
            StaticKind::Capsule { a, ab, len2, radius } => (segment_distance_squared(p, a, ab, *len2), *radius),
            StaticKind::Box { frame, half } => (box_distance_squared_local(&to_local(p, frame), half), T::ZERO),
            StaticKind::Cylinder { frame, radius, half_length } => {
                (cylinder_distance_squared(&to_local(p, frame), *radius, *half_length), T::ZERO)
            }
            StaticKind::Cloud { frame, points, radius } => {
                let p = p.map(|c| c.map(T::to_f64));
                let local = to_local(&p, frame);
                // Rounded up a little: the cap must not cut off a lane the
                // caller would count as within it.
                let cap = cap2.to_f64().sqrt() * (1.0 + 1e-6) + 1e-9;
                let d2 = build(|l| {
                    let at = [local[0][l], local[1][l], local[2][l]];
                    // Nothing within the cap (or an empty cloud): beyond it.
                    T::of(points.nearest(&at, cap).map_or(f64::INFINITY, |(d2, _)| d2))
                });
                (d2, *radius)
            }
        }
    }

    /// Per lane, `e · v` where `e` is the offset from the core's point
    /// nearest `p` to `p` (so `|e|` is the distance to the core, as in
    /// [`core_distance_squared_within`](Self::core_distance_squared_within)) and `v` the
    /// point's velocity: the distance's rate of change times `|e|`.
    /// Meaningless for points inside the core.
    #[inline(always)]
    pub(super) fn core_approach(&self, p: &[Lane<T>; 3], v: &[Lane<T>; 3]) -> Lane<T> {
        match &self.kind {
            StaticKind::Sphere { center, .. } => point_approach(p, center, v),
            StaticKind::Capsule { a, ab, len2, .. } => segment_approach(p, a, ab, *len2, v),
            StaticKind::Box { frame, half } => {
                box_approach_local(&to_local(p, frame), half, &rotate_to_local(v, frame))
            }
            StaticKind::Cylinder { frame, radius, half_length } => {
                cylinder_approach_local(&to_local(p, frame), *radius, *half_length, &rotate_to_local(v, frame))
            }
            // The distance to a union of balls is not convex along a
            // motion: no rate, so certification keeps its first-order room.
            StaticKind::Cloud { .. } => [T::of(f64::NAN); LANES],
        }
    }
}

impl<T: Real> SphereModel<T> {
    /// Some pair that no joint moves collides: no configuration is free.
    pub(crate) fn always_collides(&self) -> bool {
        self.fixed_collision
    }

    /// Sets lane `l` to `q0 + (q1 − q0) t[l]` (the exact model's
    /// interpolation, to the bit).
    pub(super) fn set_along(&self, ws: &mut SphereWorkspace<T>, q0: &[f64], q1: &[f64], t: &Lane) {
        for ((lane, a), b) in ws.q.iter_mut().zip(q0).zip(q1) {
            for (v, &t) in lane.iter_mut().zip(t) {
                *v = a + (b - a) * t;
            }
        }
    }

    /// Runs the plain (`CERTIFY` false) or certification check on the
    /// configurations in the workspace.
    pub(super) fn check<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace<T>) -> Verdict {
        match self.isa {
            // SAFETY: levels are only set through `SimdLevel::best_up_to`,
            // which checked every enabled feature on this CPU.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe { self.check_avx512::<CERTIFY>(ws) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe { self.check_avx2::<CERTIFY>(ws) },
            _ => self.check_lanes::<CERTIFY>(ws),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    fn check_avx512<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace<T>) -> Verdict {
        self.check_lanes::<CERTIFY>(ws)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn check_avx2<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace<T>) -> Verdict {
        self.check_lanes::<CERTIFY>(ws)
    }

    /// Per lane, `(limit + tolerance)²` for the distance `limit` (m) a pair
    /// must clear to pass: `reach` for a plain check; for certification
    /// also the margins, with `sweep` the pair's approach speed bound (m per
    /// unit of motion).
    #[inline(always)]
    fn pass_limit<const CERTIFY: bool>(&self, ws: &SphereWorkspace<T>, reach: T, sweep: T) -> Lane<T> {
        let tolerance = self.tolerance;
        if !CERTIFY {
            return [(reach + tolerance) * (reach + tolerance); LANES];
        }
        let m = &ws.margins;
        build(|l| {
            let limit = max(reach + m.half + m.width[l] * sweep, reach + m.full) + tolerance;
            limit * limit
        })
    }

    /// [`pass_limit`](self.pass_limit) with a sweep bound per lane.
    #[inline(always)]
    fn pass_limit_lanes<const CERTIFY: bool>(&self, ws: &SphereWorkspace<T>, reach: T, sweep: &Lane<T>) -> Lane<T> {
        let tolerance = self.tolerance;
        if !CERTIFY {
            return [(reach + tolerance) * (reach + tolerance); LANES];
        }
        let m = &ws.margins;
        build(|l| {
            let limit = max(reach + m.half + m.width[l] * sweep[l], reach + m.full) + tolerance;
            limit * limit
        })
    }

    /// One sphere pair, `d2` apart squared (m²) with `reach` (m) to keep
    /// and approach speed bound `sweep`, folded into the flags: `None`
    /// when a lane fails; else the lanes a certification must narrow
    /// (none for a plain check, which flags them for splitting).
    #[inline(always)]
    fn screen<const CERTIFY: bool>(
        &self,
        ws: &SphereWorkspace<T>,
        d2: &Lane<T>,
        reach: T,
        sweep: &Lane<T>,
        flags: &mut Flags<T>,
    ) -> Option<[bool; LANES]> {
        let full = if CERTIFY { ws.margins.full } else { T::ZERO };
        let pass = self.pass_limit_lanes::<CERTIFY>(ws, reach, sweep);
        let short = short_lanes(d2, &pass, (reach + full, self.tolerance), flags)?;
        if CERTIFY {
            return Some(short);
        }
        flags.split = build(|l| flags.split[l] | short[l]);
        Some([false; LANES])
    }

    #[inline(always)]
    fn check_lanes<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace<T>) -> Verdict {
        // Poses and centres are placed as pairs need them: a check that
        // fails on the pair that failed last (a blocked search's usual
        // check) needs only that group's chain.
        ws.new_batch();
        if CERTIFY {
            ws.tight_done.fill(false);
            ws.tangent_done = false;
        }
        let mut flags = Flags {
            unsure: [false; LANES],
            split: [false; LANES],
            room: [T::INFINITY; LANES],
            short: [Pending::NONE; LANES],
        };
        // Only certification's parts of intervals leave pairs out.
        let (checking, masked) = (ws.checking, CERTIFY && ws.checking != Pending::ALL);
        let skip = |part: Pending| masked && !checking.covers(part);
        // Checked again below if it passes: the flags it sets do not change.
        let failed = match ws.last_failure {
            Some(Pair::Environment(g, o)) if !skip(Pending::environment(g)) => {
                self.check_shape::<CERTIFY>(ws, g, o, &mut flags)
            }
            Some(Pair::Robot(p)) if !skip(Pending::robot(self.self_pairs[p])) => {
                self.self_pair_centers(ws, p);
                self.check_self_pair::<CERTIFY>(ws, p, &mut flags)
            }
            _ => false,
        };
        if failed {
            return Verdict::Collides;
        }
        // Distal links first: they are the likelier to hit something.
        for g in (0..self.groups.len()).rev() {
            if !skip(Pending::environment(g)) && self.check_environment::<CERTIFY>(ws, g, &mut flags) {
                return Verdict::Collides;
            }
        }
        for block in &self.self_blocks {
            if let Some(segments) = block.segments {
                // Blocks with no pair pending are skipped before their boxes.
                let idle = masked && block.pairs.clone().all(|p| skip(Pending::robot(self.self_pairs[p])));
                if idle || self.segments_apart::<CERTIFY>(ws, segments) {
                    continue;
                }
            }
            for p in block.pairs.clone() {
                if masked {
                    if skip(Pending::robot(self.self_pairs[p])) {
                        continue;
                    }
                    // Groups whose shapes were not checked are placed here.
                    self.self_pair_centers(ws, p);
                }
                if self.check_self_pair::<CERTIFY>(ws, p, &mut flags) {
                    ws.last_failure = Some(Pair::Robot(p));
                    return Verdict::Collides;
                }
            }
        }
        if CERTIFY {
            ws.room = flags.room;
            ws.short = flags.short;
        }
        Verdict::Free { unsure: flags.unsure, split: flags.split }
    }

    /// Group `g` against the static shapes: true when a lane fails.
    #[inline(always)]
    fn check_environment<const CERTIFY: bool>(
        &self,
        ws: &mut SphereWorkspace<T>,
        g: usize,
        flags: &mut Flags<T>,
    ) -> bool {
        let group = &self.groups[g];
        // The box around the group's balls in every lane, grown by the
        // limit: shapes whose boxes it misses are cleared in every lane.
        let reach = lane_max(&self.pass_limit::<CERTIFY>(ws, group.radius, ws.group_sweep[g])).sqrt();
        let center = *self.group_center(ws, g);
        let lo: [T; 3] = build(|i| lane_min(&center[i]) - reach);
        let hi: [T; 3] = build(|i| lane_max(&center[i]) + reach);
        for chunk in &self.env[group.env.clone()] {
            // Per shape, the largest gap between the boxes along an axis.
            let mut gap = [T::NEG_INFINITY; LANES];
            for i in 0..3 {
                for k in 0..LANES {
                    gap[k] = max(gap[k], max(lo[i] - chunk.hi[i][k], chunk.lo[i][k] - hi[i]));
                }
            }
            // The shapes whose boxes meet, as bits (empty slots never do),
            // visited in order.
            let mut meet = 0u32;
            for k in 0..LANES {
                meet |= u32::from(gap[k] <= T::ZERO) << k;
            }
            while meet != 0 {
                let o = chunk.shapes[meet.trailing_zeros() as usize];
                meet &= meet - 1;
                if self.check_shape::<CERTIFY>(ws, g, o as usize, flags) {
                    ws.last_failure = Some(Pair::Environment(g, o as usize));
                    return true;
                }
            }
        }
        false
    }

    /// Group `g` against static shape `o`: true when a lane fails.
    #[inline(always)]
    fn check_shape<const CERTIFY: bool>(
        &self,
        ws: &mut SphereWorkspace<T>,
        g: usize,
        o: usize,
        flags: &mut Flags<T>,
    ) -> bool {
        let (group, shape, center) = (&self.groups[g], &self.statics[o], *self.group_center(ws, g));
        let radius = shape.core_radius();
        let pass = self.pass_limit::<CERTIFY>(ws, group.radius + radius, ws.group_sweep[g]);
        let (d2, _) = shape.core_distance_squared_within(&center, lane_max(&pass));
        if all_beyond(&d2, &pass) {
            return false;
        }
        self.place_clusters(ws, g);
        for c in group.clusters.clone() {
            let cluster = &self.clusters[c];
            let pass = self.pass_limit::<CERTIFY>(ws, cluster.radius + radius, ws.cluster_sweep[c]);
            let (d2, _) = shape.core_distance_squared_within(&ws.cluster_centers[c], lane_max(&pass));
            if all_beyond(&d2, &pass) {
                continue;
            }
            let sweep = if CERTIFY { self.tight_sweep(ws, c, 0) } else { [T::ZERO; LANES] };
            // The cluster again, with the tighter bound.
            if CERTIFY && all_beyond(&d2, &self.pass_limit_lanes::<CERTIFY>(ws, cluster.radius + radius, &sweep)) {
                continue;
            }
            self.place_spheres(ws, c);
            for s in cluster.spheres.clone() {
                let reach = self.spheres[s].reach + radius;
                // Beyond what `screen` passes, the distance is not needed.
                let cap2 = lane_max(&self.pass_limit_lanes::<CERTIFY>(ws, reach, &sweep));
                let (d2, _) = shape.core_distance_squared_within(&ws.centers[s], cap2);
                let Some(short) = self.screen::<CERTIFY>(ws, &d2, reach, &sweep, flags) else { return true };
                if !short.contains(&true) {
                    continue;
                }
                let distance = d2.map(|d| max(d, T::ZERO).sqrt());
                let velocity = self.sphere_velocity(ws, group.body, s);
                let rate = distance_rate(&shape.core_approach(&ws.centers[s], &velocity), &distance);
                let keep = reach + ws.margins.half + self.tolerance;
                let accel = self.cluster_accel(ws, c);
                let pair = PairBounds { pending: Pending::environment(g), keep, sweep: &sweep, rate: &rate, accel };
                narrow(&distance, &short, &pair, &ws.margins.width, flags);
            }
        }
        false
    }

    /// Places the centres of self pair `p`'s groups (every group's is
    /// placed once the environment pairs have been checked).
    fn self_pair_centers(&self, ws: &mut SphereWorkspace<T>, p: usize) {
        for g in self.self_pairs[p] {
            self.group_center(ws, g as usize);
        }
    }

    /// Self pair `p`, its groups' centres placed: true when a lane fails.
    #[inline(always)]
    fn check_self_pair<const CERTIFY: bool>(
        &self,
        ws: &mut SphereWorkspace<T>,
        p: usize,
        flags: &mut Flags<T>,
    ) -> bool {
        let [a, b] = self.self_pairs[p].map(|g| g as usize);
        let (ga, gb) = (&self.groups[a], &self.groups[b]);
        debug_assert!(ws.centered[a] && ws.centered[b], "self pair checked before its centres were placed");
        // Joints moving both sides leave the pair's distance unchanged.
        let depth = self.common_depth[p];
        let loose =
            |ws: &mut SphereWorkspace<T>, c: usize| if CERTIFY { self.loose_sweep(ws, c, depth) } else { T::ZERO };
        let [sweep_a, sweep_b] = if CERTIFY { self.pair_sweep(ws, p) } else { [T::ZERO; 2] };
        let limit = self.pass_limit::<CERTIFY>(ws, ga.radius + gb.radius, sweep_a + sweep_b);
        if all_beyond(&lane_distance_squared(&ws.group_centers[a], &ws.group_centers[b]), &limit) {
            return false;
        }
        self.place_clusters(ws, a);
        self.place_clusters(ws, b);
        for ca in ga.clusters.clone() {
            let (ka, sweep_ka) = (&self.clusters[ca], loose(ws, ca));
            let limit = self.pass_limit::<CERTIFY>(ws, ka.radius + gb.radius, sweep_ka + sweep_b);
            if all_beyond(&lane_distance_squared(&ws.cluster_centers[ca], &ws.group_centers[b]), &limit) {
                continue;
            }
            for cb in gb.clusters.clone() {
                let (kb, sweep_kb) = (&self.clusters[cb], loose(ws, cb));
                let limit = self.pass_limit::<CERTIFY>(ws, ka.radius + kb.radius, sweep_ka + sweep_kb);
                if all_beyond(&lane_distance_squared(&ws.cluster_centers[ca], &ws.cluster_centers[cb]), &limit) {
                    continue;
                }
                self.place_spheres(ws, ca);
                self.place_spheres(ws, cb);
                let sweep: Lane<T> = if CERTIFY {
                    let (a, b) = (self.tight_sweep(ws, ca, depth), self.tight_sweep(ws, cb, depth));
                    build(|l| a[l] + b[l])
                } else {
                    [T::ZERO; LANES]
                };
                for i in ka.spheres.clone() {
                    for j in kb.spheres.clone() {
                        let d2 = lane_distance_squared(&ws.centers[i], &ws.centers[j]);
                        let reach = self.spheres[i].reach + self.spheres[j].reach;
                        let Some(short) = self.screen::<CERTIFY>(ws, &d2, reach, &sweep, flags) else { return true };
                        if !short.contains(&true) {
                            continue;
                        }
                        let distance = d2.map(|d| max(d, T::ZERO).sqrt());
                        let rate = self.separation_rate(ws, (ga.body, i), (gb.body, j), &distance);
                        let accel = self.cluster_accel(ws, ca) + self.cluster_accel(ws, cb);
                        let keep = reach + ws.margins.half + self.tolerance;
                        let pending = Pending::robot(self.self_pairs[p]);
                        let pair = PairBounds { pending, keep, sweep: &sweep, rate: &rate, accel };
                        narrow(&distance, &short, &pair, &ws.margins.width, flags);
                    }
                }
            }
        }
        false
    }

    /// World poses of every body in every lane.
    #[cfg(test)]
    pub(super) fn forward_kinematics(&self, ws: &mut SphereWorkspace<T>) {
        ws.posed = 1;
        self.pose_up_to(ws, self.bodies.len() - 1);
    }

    /// World poses of bodies up to `last` (bodies come after their
    /// parents, so its chain is among them), once per batch.
    #[inline(always)]
    pub(super) fn pose_up_to(&self, ws: &mut SphereWorkspace<T>, last: usize) {
        for b in ws.posed..=last {
            let body = &self.bodies[b];
            let q = &ws.q[body.column];
            let value: Lane = build(|l| body.multiplier * q[l] + body.offset);
            let (done, rest) = ws.poses.split_at_mut(b);
            let (parent, pose) = (&done[body.parent], &mut rest[0]);
            let placement = (&body.rotation, &body.translation);
            match body.motion {
                Motion::Prismatic(_) => pose.set_prismatic(parent, placement, &body.axis, &value.map(T::of)),
                _ => {
                    let (s, c) = T::lane_sin_cos(&value);
                    pose.set_revolute(parent, placement, &body.axis, (&s, &c));
                }
            }
        }
        ws.posed = ws.posed.max(last + 1);
    }

    /// World centre of group `g`'s bounding ball, once per batch.
    #[inline(always)]
    pub(super) fn group_center<'w>(&self, ws: &'w mut SphereWorkspace<T>, g: usize) -> &'w [Lane<T>; 3] {
        if !ws.centered[g] {
            let group = &self.groups[g];
            self.pose_up_to(ws, group.body);
            ws.group_centers[g] = ws.poses[group.body].point(&group.center);
            ws.centered[g] = true;
        }
        &ws.group_centers[g]
    }

    /// World centres of group `g`'s clusters, once per batch.
    #[inline(always)]
    fn place_clusters(&self, ws: &mut SphereWorkspace<T>, g: usize) {
        if ws.clusters_placed[g] {
            return;
        }
        let group = &self.groups[g];
        // Its centre was placed first, which posed its chain.
        debug_assert!(ws.centered[g], "clusters placed before their group's centre");
        let pose = &ws.poses[group.body];
        for c in group.clusters.clone() {
            ws.cluster_centers[c] = pose.point(&self.clusters[c].center);
        }
        ws.clusters_placed[g] = true;
    }

    /// World centres of cluster `c`'s spheres, once per batch.
    #[inline(always)]
    pub(super) fn place_spheres(&self, ws: &mut SphereWorkspace<T>, c: usize) {
        if ws.spheres_placed[c] {
            return;
        }
        let cluster = &self.clusters[c];
        let body = self.groups[self.cluster_group[c] as usize].body;
        debug_assert!(ws.posed > body, "spheres placed before their body was posed");
        let pose = &ws.poses[body];
        for s in cluster.spheres.clone() {
            ws.centers[s] = pose.point(&self.spheres[s].center);
        }
        ws.spheres_placed[c] = true;
    }
}
