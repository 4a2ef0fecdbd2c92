//! Sweep bounds of certification (see `motion.rs`): how fast, in metres
//! per unit of motion, the sphere centres of each cluster can move along
//! the straight motion `q0 → q1`.
//!
//! A revolute joint `k` turning at `|Δq_k|` moves a point at most
//! `|Δq_k| · r` where `r` is the point's distance from the joint's origin;
//! a prismatic joint sliding at `|Δq_k|` moves every point after it at
//! exactly that speed (its term has lever 1, and the levers of the joints
//! before it include the farthest it slides).
//! The loose bound takes for `r` the lever (link offsets and the sphere's
//! offset added up, valid for every q) and holds over the whole motion.
//! The tight bound, per lane, measures `r` at the interval's midpoint and
//! adds what the joints after `k` can change it by over the half-width
//! `w`: `r(t) ≤ r(m) + w · Σ_{j>k} |Δq_j| · lever_j` (joint `k` turns the
//! point about its own origin, and the joints before it move both
//! together). Joints at the root side of a chain that two clusters share
//! change neither's distance to the other: the sums leave the first
//! `depth` of them out.
// Lane loops index several arrays by the lane on purpose (see `lanes.rs`).
#![allow(clippy::needless_range_loop)]

use super::SphereModel;
use super::lanes::{LANES, Lane, Real, build, cross, distance_rate, max, min, offset_dot};
use super::workspace::SphereWorkspace;
use crate::robot::Motion;

impl<T: Real> SphereModel<T> {
    /// Loose sweep bounds of every cluster and their maxima per group for
    /// the motion from `q0` to `q1`: a pass over the moving joints, all
    /// clusters at once (root first, as the prefix sums add them; clusters
    /// a joint does not move add a zero, which changes no bit). Prefix sums
    /// and self pairs' bounds wait until a check needs them.
    pub(super) fn start_sweeps(&self, ws: &mut SphereWorkspace<T>, q0: &[f64], q1: &[f64]) {
        for ((body, rate), signed) in self.bodies.iter().zip(&mut ws.rates).zip(&mut ws.signed_rates) {
            *signed = T::of((q1[body.column] - q0[body.column]) * body.multiplier);
            *rate = T::of((q1[body.column] - q0[body.column]).abs() * body.multiplier.abs());
        }
        ws.cluster_sweep.fill(T::ZERO);
        let columns = self.levers.chunks_exact(self.clusters.len().max(1));
        for (&rate, levers) in ws.rates.iter().zip(columns).filter(|(rate, _)| **rate != T::ZERO) {
            for (sweep, &lever) in ws.cluster_sweep.iter_mut().zip(levers) {
                *sweep += rate * lever;
            }
        }
        for (g, group) in self.groups.iter().enumerate() {
            ws.group_sweep[g] = ws.cluster_sweep[group.clusters.clone()].iter().fold(T::ZERO, |a, &b| max(a, b));
        }
        self.start_segment_sweeps(ws);
        ws.prefix_done.fill(false);
        ws.pair_done.fill(false);
        ws.accel_done.fill(false);
    }

    /// Prefix sums of cluster `c`'s loose sweep terms, once per motion.
    #[inline(always)]
    fn ensure_prefix(&self, ws: &mut SphereWorkspace<T>, c: usize) {
        if ws.prefix_done[c] {
            return;
        }
        let cluster = &self.clusters[c];
        let prefix = &mut ws.prefix[cluster.slot..=cluster.slot + cluster.terms.len()];
        prefix[0] = T::ZERO;
        for (k, term) in self.sweep_terms[cluster.terms.clone()].iter().enumerate() {
            prefix[k + 1] = prefix[k] + ws.rates[term.body] * term.lever;
        }
        ws.prefix_done[c] = true;
    }

    /// Loose sweep bound of cluster `c` without its first `depth` joints.
    #[inline(always)]
    pub(super) fn loose_sweep(&self, ws: &mut SphereWorkspace<T>, c: usize, depth: usize) -> T {
        if depth == 0 {
            return ws.cluster_sweep[c];
        }
        self.ensure_prefix(ws, c);
        let cluster = &self.clusters[c];
        ws.prefix[cluster.slot + cluster.terms.len()] - ws.prefix[cluster.slot + depth.min(cluster.terms.len())]
    }

    /// Per side of self pair `p`, the largest loose sweep bound of its
    /// clusters without the joints moving both sides, once per motion.
    #[inline(always)]
    pub(super) fn pair_sweep(&self, ws: &mut SphereWorkspace<T>, p: usize) -> [T; 2] {
        if !ws.pair_done[p] {
            let depth = self.common_depth[p];
            for (side, g) in self.self_pairs[p].into_iter().enumerate() {
                let mut largest = T::ZERO;
                for c in self.groups[g as usize].clusters.clone() {
                    largest = max(largest, self.loose_sweep(ws, c, depth));
                }
                ws.pair_sweep[p][side] = largest;
            }
            ws.pair_done[p] = true;
        }
        ws.pair_sweep[p]
    }

    /// Per lane, the smaller of the tight and loose sweep bounds of placed
    /// cluster `c` without its first `depth` joints, over the lanes'
    /// intervals (tight sums computed once per batch).
    #[inline(always)]
    pub(super) fn tight_sweep(&self, ws: &mut SphereWorkspace<T>, c: usize, depth: usize) -> Lane<T> {
        let cluster = &self.clusters[c];
        let (slot, n) = (cluster.slot, cluster.terms.len());
        if !ws.tight_done[c] {
            self.ensure_prefix(ws, c);
            let (center, total) = (ws.cluster_centers[c], ws.prefix[slot + n]);
            ws.tight[slot] = [T::ZERO; LANES];
            for (k, term) in self.sweep_terms[cluster.terms.clone()].iter().enumerate() {
                let (origin, rate) = (ws.poses[term.body].t, ws.rates[term.body]);
                let mut next = ws.tight[slot + k];
                if term.slides {
                    // A slide moves every point after it at its own speed.
                    for l in 0..LANES {
                        next[l] += rate;
                    }
                    ws.tight[slot + k + 1] = next;
                    continue;
                }
                // What the joints after this one can add to the distance.
                let tail = total - ws.prefix[slot + k + 1];
                for l in 0..LANES {
                    let (x, y, z) =
                        (center[0][l] - origin[0][l], center[1][l] - origin[1][l], center[2][l] - origin[2][l]);
                    let r = (x * x + y * y + z * z).sqrt() + cluster.radius + ws.margins.width[l] * tail;
                    next[l] += rate * r;
                }
                ws.tight[slot + k + 1] = next;
            }
            ws.tight_done[c] = true;
        }
        let depth = depth.min(n);
        let loose = self.loose_sweep(ws, c, depth);
        let (all, skipped) = (&ws.tight[slot + n], &ws.tight[slot + depth]);
        build(|l| min(all[l] - skipped[l], loose))
    }
}

/// Second-order bounds (see `narrow` in `check.rs`): the velocities of
/// the placed configurations along the motion, and bounds of the sphere
/// centres' accelerations.
impl<T: Real> SphereModel<T> {
    /// Per body and lane, the world angular velocity of its frame and the
    /// linear velocity of its origin along the motion (per unit of motion),
    /// once per batch: a revolute joint adds its rate about its world axis
    /// to the angular velocity; the origin moves with the parent's twist,
    /// and a prismatic joint adds its rate along its world axis.
    fn ensure_tangent(&self, ws: &mut SphereWorkspace<T>) {
        if ws.tangent_done {
            return;
        }
        self.pose_up_to(ws, self.bodies.len() - 1);
        ws.angular[0] = [[T::ZERO; LANES]; 3];
        ws.linear[0] = [[T::ZERO; LANES]; 3];
        for (b, body) in self.bodies.iter().enumerate().skip(1) {
            let (pose, parent) = (&ws.poses[b], &ws.poses[body.parent]);
            let (spin, mut linear) = (ws.angular[body.parent], ws.linear[body.parent]);
            let arm: [Lane<T>; 3] = build(|i| build(|l| pose.t[i][l] - parent.t[i][l]));
            let carried = cross(&spin, &arm);
            let rate = ws.signed_rates[b];
            let axis = body.axis;
            let along: [Lane<T>; 3] = build(|i| {
                build(|l| rate * (pose.r[i][l] * axis[0] + pose.r[3 + i][l] * axis[1] + pose.r[6 + i][l] * axis[2]))
            });
            let mut angular = spin;
            let turned = if matches!(body.motion, Motion::Prismatic(_)) { &mut linear } else { &mut angular };
            for i in 0..3 {
                for l in 0..LANES {
                    turned[i][l] += along[i][l];
                }
            }
            for i in 0..3 {
                for l in 0..LANES {
                    linear[i][l] += carried[i][l];
                }
            }
            ws.angular[b] = angular;
            ws.linear[b] = linear;
        }
        ws.tangent_done = true;
    }

    /// World velocity along the motion (per unit of motion) of placed
    /// sphere `s` on `body`, per lane.
    #[inline(always)]
    pub(super) fn sphere_velocity(&self, ws: &mut SphereWorkspace<T>, body: usize, s: usize) -> [Lane<T>; 3] {
        self.ensure_tangent(ws);
        let (center, origin) = (&ws.centers[s], &ws.poses[body].t);
        let arm: [Lane<T>; 3] = build(|i| build(|l| center[i][l] - origin[i][l]));
        let mut v = cross(&ws.angular[body], &arm);
        for i in 0..3 {
            for l in 0..LANES {
                v[i][l] += ws.linear[body][i][l];
            }
        }
        v
    }

    /// Per lane, the absolute rate of change along the motion (per unit of
    /// motion) of the distance between the centres of placed spheres `i`
    /// and `j` (each with its body), `distance` apart (m).
    #[inline(always)]
    pub(super) fn separation_rate(
        &self,
        ws: &mut SphereWorkspace<T>,
        (body_i, i): (usize, usize),
        (body_j, j): (usize, usize),
        distance: &Lane<T>,
    ) -> Lane<T> {
        let (vi, vj) = (self.sphere_velocity(ws, body_i, i), self.sphere_velocity(ws, body_j, j));
        let relative: [Lane<T>; 3] = build(|k| build(|l| vi[k][l] - vj[k][l]));
        distance_rate(&offset_dot(&ws.centers[i], &ws.centers[j], &relative), distance)
    }

    /// A bound (m per unit of motion², valid for every configuration of
    /// the motion) of the acceleration of cluster `c`'s sphere centres, once
    /// per motion. With `p' = Σ_k δ_k u_k`, `u_k = a_k × (p − o_k)` for a
    /// revolute joint and `a_k` for a prismatic one: `|u_k'| ≤ 2 Ω_k L_k +
    /// Σ_{j≥k} ρ_j L_j` (revolute) or `Ω_k` (prismatic), where `ρ = |δ|`,
    /// `L` the levers and `Ω_k` the sum of the rates of the revolute joints
    /// before `k` (the angular speed of its frame).
    #[inline(always)]
    pub(super) fn cluster_accel(&self, ws: &mut SphereWorkspace<T>, c: usize) -> T {
        if ws.accel_done[c] {
            return ws.accel[c];
        }
        // The tails Σ_{j≥k} ρ_j L_j from the loose sweep's prefix sums.
        self.ensure_prefix(ws, c);
        let cluster = &self.clusters[c];
        let prefix = &ws.prefix[cluster.slot..=cluster.slot + cluster.terms.len()];
        let total = prefix[cluster.terms.len()];
        let (mut spin, mut accel) = (T::ZERO, T::ZERO);
        for (k, term) in self.sweep_terms[cluster.terms.clone()].iter().enumerate() {
            let rate = ws.rates[term.body];
            let tail = max(total - prefix[k], T::ZERO);
            accel += rate * if term.slides { spin } else { T::of(2.0) * spin * term.lever + tail };
            if !term.slides {
                spin += rate;
            }
        }
        ws.accel[c] = accel;
        ws.accel_done[c] = true;
        accel
    }
}
