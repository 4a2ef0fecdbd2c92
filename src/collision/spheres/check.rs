//! Lane-parallel boolean checks over a [`SphereModel`]: forward kinematics
//! of [`LANES`] configurations at once, then the model's pairs with
//! bounding-volume early outs. Allocation-free once the workspace exists.

use super::lanes::{
    LANES, Lane, LanePose, box_distance_squared, box_signed_distance, cylinder_signed_distance, lane_distance,
    point_distance, segment_distance, sin_cos, to_local,
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
}

impl SphereWorkspace {
    pub(crate) fn new(model: &SphereModel, nq: usize) -> SphereWorkspace {
        SphereWorkspace {
            q: vec![[0.0; LANES]; nq],
            poses: vec![LanePose::IDENTITY; model.bodies.len()],
            centers: vec![[[0.0; LANES]; 3]; model.spheres.len()],
            group_centers: vec![[[0.0; LANES]; 3]; model.groups.len()],
            placed: vec![false; model.groups.len()],
        }
    }
}

/// What a batch of lanes came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Some lane certainly collides.
    Collides,
    /// Every lane is certainly free, except those flagged: a pair of theirs
    /// lies within the tolerance band of its threshold, for the exact model.
    Free { unsure: [bool; LANES] },
}

/// Sample indices `0..=steps` of a motion, coarse to fine: the end, the
/// start, then the odd multiples of halving strides (every index once),
/// so that a blocked motion is found early.
#[derive(Debug, Clone)]
pub(crate) struct SampleOrder {
    steps: usize,
    ends: u8,
    stride: usize,
    next: usize,
}

impl SampleOrder {
    pub(crate) fn new(steps: usize) -> SampleOrder {
        let stride = steps.next_power_of_two();
        SampleOrder { steps, ends: 0, stride, next: stride / 2 }
    }
}

impl Iterator for SampleOrder {
    type Item = usize;

    fn next(&mut self) -> Option<usize> {
        if self.ends < 2 {
            self.ends += 1;
            return Some(if self.ends == 1 { self.steps } else { 0 });
        }
        while self.stride > 1 {
            if self.next < self.steps {
                let k = self.next;
                self.next += self.stride;
                return Some(k);
            }
            self.stride /= 2;
            self.next = self.stride / 2;
        }
        None
    }
}

/// Folds one pair's margins (m) into the verdict: true when a lane
/// certainly collides; lanes inside the tolerance band are flagged.
#[inline(always)]
fn collides(margin: &Lane, unsure: &mut [bool; LANES]) -> bool {
    if margin.iter().fold(true, |all, &m| all & (m > TOLERANCE)) {
        return false;
    }
    for (u, &m) in unsure.iter_mut().zip(margin) {
        if m < -TOLERANCE {
            return true;
        }
        // NaN lands here too: the exact model decides.
        *u |= m <= TOLERANCE || m.is_nan();
    }
    false
}

impl StaticShape {
    /// Distance from each lane's sphere centre `p` to the shape, minus the
    /// sphere's `reach` (m): negative when they touch.
    #[inline(always)]
    fn margin(&self, p: &[Lane; 3], reach: f64) -> Lane {
        let (mut d, offset) = match &self.kind {
            StaticKind::Sphere { center, radius } => (point_distance(p, center), reach + radius),
            StaticKind::Capsule { a, ab, len2, radius } => (segment_distance(p, a, ab, *len2), reach + radius),
            StaticKind::Box { rotation, translation, half } => {
                (box_signed_distance(&to_local(p, rotation, translation), half), reach)
            }
            StaticKind::Cylinder { rotation, translation, radius, half_length } => {
                (cylinder_signed_distance(&to_local(p, rotation, translation), *radius, *half_length), reach)
            }
        };
        for v in &mut d {
            *v -= offset;
        }
        d
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
        self.check(ws)
    }

    /// Checks the samples `ks` of the motion from `q0` to `q1` in `steps`
    /// steps, sample k at `q0 + (q1 − q0) k / steps` (the exact model's
    /// interpolation, to the bit).
    pub(crate) fn check_samples(
        &self,
        ws: &mut SphereWorkspace,
        q0: &[f64],
        q1: &[f64],
        ks: &[usize; LANES],
        steps: usize,
    ) -> Verdict {
        for ((lane, a), b) in ws.q.iter_mut().zip(q0).zip(q1) {
            for (v, &k) in lane.iter_mut().zip(ks) {
                *v = a + (b - a) * (k as f64 / steps as f64);
            }
        }
        self.check(ws)
    }

    fn check(&self, ws: &mut SphereWorkspace) -> Verdict {
        match self.isa {
            // SAFETY: `Isa::detect` found these instructions on this CPU.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.check_avx512(ws) },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.check_avx2(ws) },
            Isa::Baseline => self.check_lanes(ws),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    fn check_avx512(&self, ws: &mut SphereWorkspace) -> Verdict {
        self.check_lanes(ws)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn check_avx2(&self, ws: &mut SphereWorkspace) -> Verdict {
        self.check_lanes(ws)
    }

    #[inline(always)]
    fn check_lanes(&self, ws: &mut SphereWorkspace) -> Verdict {
        self.forward_kinematics(ws);
        for (g, group) in self.groups.iter().enumerate() {
            ws.group_centers[g] = ws.poses[group.body].point(&group.center);
            ws.placed[g] = false;
        }
        let mut unsure = [false; LANES];
        for (g, group) in self.groups.iter().enumerate() {
            let far = (group.radius + TOLERANCE) * (group.radius + TOLERANCE);
            for &o in &self.env[group.env.clone()] {
                let shape = &self.statics[o as usize];
                let d2 = box_distance_squared(&ws.group_centers[g], &shape.lo, &shape.hi);
                if d2.iter().fold(true, |all, &d| all & (d > far)) {
                    continue;
                }
                self.place(ws, g);
                for s in group.spheres.clone() {
                    if collides(&shape.margin(&ws.centers[s], self.spheres[s].reach), &mut unsure) {
                        return Verdict::Collides;
                    }
                }
            }
        }
        for &[a, b] in &self.self_pairs {
            let (a, b) = (a as usize, b as usize);
            let mut bound = lane_distance(&ws.group_centers[a], &ws.group_centers[b]);
            for v in &mut bound {
                *v -= self.groups[a].radius + self.groups[b].radius;
            }
            if bound.iter().fold(true, |all, &m| all & (m > TOLERANCE)) {
                continue;
            }
            self.place(ws, a);
            self.place(ws, b);
            for i in self.groups[a].spheres.clone() {
                for j in self.groups[b].spheres.clone() {
                    let mut margin = lane_distance(&ws.centers[i], &ws.centers[j]);
                    for v in &mut margin {
                        *v -= self.spheres[i].reach + self.spheres[j].reach;
                    }
                    if collides(&margin, &mut unsure) {
                        return Verdict::Collides;
                    }
                }
            }
        }
        Verdict::Free { unsure }
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

#[cfg(test)]
mod tests {
    use super::SampleOrder;

    #[test]
    fn sample_order_visits_every_index_once_ends_first() {
        for steps in 1..70 {
            let order: Vec<usize> = SampleOrder::new(steps).collect();
            assert_eq!(order[..2], [steps, 0]);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..=steps).collect::<Vec<_>>(), "{steps}");
        }
    }
}
