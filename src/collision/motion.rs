//! Motion (edge) validation: is the straight joint-space motion between two
//! configurations collision-free? Sampled at a resolution, or certified
//! for every configuration of the motion by conservative advancement.

use super::model::CollisionModel;
use super::query::{CollisionWorkspace, prunes};
use super::spheres::{Certification, LANES, SampleOrder, SphereModel, Verdict};
use crate::robot::RobotError;

impl CollisionModel {
    /// Certified check of the straight joint-space motion from `q0` to
    /// `q1`: true only if every configuration on it — not just sampled ones
    /// — keeps every checked pair at least `clearance / 2` apart (m); false
    /// as soon as a configuration reached is closer than `clearance`.
    ///
    /// On the sphere fast path, by bounded motion instead (same guarantee,
    /// per-sphere bounds): the motion is split into intervals until, at
    /// each interval's midpoint, every pair is `clearance / 2` plus its
    /// sweep bound over the half-width apart.
    ///
    /// Conservative advancement, pair by pair: only the joints that move one
    /// body of a pair but not the other change its distance, and over the
    /// whole motion no point of the pair moves relative to the other by more
    /// than `Σ |Δq_k| · lever_k` over those joints (levers bound each joint's
    /// reach for every q). After measuring distance `d`, the motion may
    /// advance by `(d − clearance/2)` divided by that bound; the smallest
    /// such step over all pairs is taken. Far pairs are skipped by their
    /// bounding volumes; pairs no joint moves are checked once.
    ///
    /// # Errors
    /// Bad configurations; a non-positive or non-finite `clearance`.
    pub fn motion_free_certified(
        &self,
        ws: &mut CollisionWorkspace,
        q0: &[f64],
        q1: &[f64],
        clearance: f64,
    ) -> Result<bool, RobotError> {
        self.check_motion(q0, q1, "clearance", clearance)?;
        match self.certify_fast(ws, (q0, q1), clearance) {
            Some(Certification::Certified) => return Ok(true),
            Some(Certification::Fails) => return Ok(false),
            // Undecided, sliding joints or no fast path: the general path decides.
            _ => {}
        }
        self.sweep_bounds(ws, q0, q1);
        let mut t = 0.0f64;
        loop {
            self.place_along(ws, q0, q1, t)?;
            let Some(step) = self.safe_step(ws, clearance, t == 0.0) else { return Ok(false) };
            if t >= 1.0 {
                return Ok(true);
            }
            t = (t + step).min(1.0);
        }
    }

    /// Certification on the sphere fast path (validated inputs), if the
    /// model has one; a fixed pair in collision fails everything.
    fn certify_fast(
        &self,
        ws: &mut CollisionWorkspace,
        motion: (&[f64], &[f64]),
        clearance: f64,
    ) -> Option<Certification> {
        let (fast, scratch) = (self.spheres.as_ref()?, ws.spheres.as_mut()?);
        if fast.always_collides() {
            return Some(Certification::Fails);
        }
        Some(fast.certify(scratch, motion, (clearance / 2.0, clearance)))
    }

    /// Validates both ends of a motion and its positive setting `name`.
    fn check_motion(&self, q0: &[f64], q1: &[f64], name: &str, value: f64) -> Result<(), RobotError> {
        self.robot.check_configuration(q0)?;
        self.robot.check_configuration(q1)?;
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(RobotError::NonFinite { joint: name.into(), index: 0, value })
        }
    }

    /// Places every moving object at `q0 + t (q1 − q0)`, without allocating.
    fn place_along(&self, ws: &mut CollisionWorkspace, q0: &[f64], q1: &[f64], t: f64) -> Result<(), RobotError> {
        let mut q = std::mem::take(&mut ws.q);
        for ((v, a), b) in q.iter_mut().zip(q0).zip(q1) {
            *v = a + (b - a) * t;
        }
        let placed = self.place(ws, &q);
        ws.q = q;
        placed
    }

    /// An upper bound (m) of how far any point of the robot's collision
    /// geometry moves, for every configuration, under the joint
    /// displacement `dq` (rad or m, one per active joint): `Σ |dq_k| ·
    /// lever_k` over the moving bodies, a prismatic joint counting 1.
    /// Pairs farther apart than this cannot close in one step.
    pub fn displacement_bound(&self, dq: &[f64]) -> f64 {
        (1..self.robot.body_count())
            .map(|b| {
                let (column, multiplier, prismatic, _) = self.robot.body_joint(b);
                let lever = if prismatic { 1.0 } else { self.levers[b] };
                dq.get(column).map_or(0.0, |d| d.abs()) * multiplier.abs() * lever
            })
            .sum()
    }

    /// Relative-motion bound of every group pair over the motion q0 → q1.
    fn sweep_bounds(&self, ws: &mut CollisionWorkspace, q0: &[f64], q1: &[f64]) {
        for (sweep, gp) in ws.sweeps.iter_mut().zip(&self.group_pairs) {
            *sweep = self.movers[gp.movers.clone()]
                .iter()
                .map(|&b| {
                    let (column, multiplier, prismatic, _) = self.robot.body_joint(b as usize);
                    let lever = if prismatic { 1.0 } else { self.levers[b as usize] };
                    (q1[column] - q0[column]).abs() * multiplier.abs() * lever
                })
                .sum();
        }
    }

    /// The largest advance (fraction of the motion) that keeps every pair
    /// at least clearance/2 apart, from the placed configuration; `None`
    /// when a pair is closer than `clearance`. Pairs that do not move
    /// relative to each other are checked only when `first`.
    fn safe_step(&self, ws: &CollisionWorkspace, clearance: f64, first: bool) -> Option<f64> {
        let mut step = f64::INFINITY;
        for (g, gp) in self.group_pairs.iter().enumerate() {
            let sweep = ws.sweeps[g];
            if sweep == 0.0 && !first {
                continue;
            }
            // Distance below which this pair would shorten the step, or fail.
            let limit = if sweep == 0.0 { clearance } else { clearance / 2.0 + step * sweep };
            if prunes(self.group_bound(ws, gp.a, gp.b), limit) {
                continue;
            }
            for pair in gp.pairs.clone() {
                let [i, j] = self.pairs[pair].map(|k| k as usize);
                let limit = if sweep == 0.0 { clearance } else { clearance / 2.0 + step * sweep };
                if prunes(self.object_bound(ws, i, j), limit) {
                    continue;
                }
                let d = self.pair_distance(ws, pair).signed.distance;
                if d < clearance {
                    return None;
                }
                if sweep > 0.0 {
                    step = step.min((d - clearance / 2.0) / sweep);
                }
            }
        }
        Some(step)
    }

    /// True when the straight joint-space motion from `q0` to `q1` is
    /// collision-free at `resolution`: configurations are checked so that
    /// no joint moves more than `resolution` (rad or m) between two checked
    /// ones, both ends included, coarse to fine for an early exit.
    ///
    /// # Errors
    /// Bad configurations; a non-positive or non-finite `resolution`
    /// ([`RobotError::NonFinite`] names it as joint `resolution`).
    pub fn motion_free(
        &self,
        ws: &mut CollisionWorkspace,
        q0: &[f64],
        q1: &[f64],
        resolution: f64,
    ) -> Result<bool, RobotError> {
        self.check_motion(q0, q1, "resolution", resolution)?;
        let span = q0.iter().zip(q1).map(|(a, b)| (b - a).abs()).fold(0.0, f64::max);
        let steps = ((span / resolution).ceil() as usize).max(1);
        let mut order = SampleOrder::new(steps);
        if let Some(fast) = &self.spheres {
            if fast.always_collides() {
                return Ok(false);
            }
            return self.motion_free_fast(fast, ws, q0, q1, steps, &mut order);
        }
        for k in order {
            self.place_along(ws, q0, q1, k as f64 / steps as f64)?;
            if !self.placed_collision_free(ws) {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// [`motion_free`](Self::motion_free) on the sphere fast path: the
    /// samples in the same order, [`LANES`] at a time; samples the fast
    /// path is unsure of go through the general check.
    fn motion_free_fast(
        &self,
        fast: &SphereModel,
        ws: &mut CollisionWorkspace,
        q0: &[f64],
        q1: &[f64],
        steps: usize,
        order: &mut SampleOrder,
    ) -> Result<bool, RobotError> {
        loop {
            let mut ks = [0; LANES];
            let mut n = 0;
            for k in order.by_ref().take(LANES) {
                ks[n] = k;
                n += 1;
            }
            if n == 0 {
                return Ok(true);
            }
            // Unused lanes repeat the last sample.
            let last = ks[n - 1];
            ks[n..].fill(last);
            let verdict = match ws.spheres.as_mut() {
                Some(scratch) => fast.check_samples(scratch, q0, q1, &ks, steps),
                None => Verdict::Free { unsure: [true; LANES], split: [false; LANES] },
            };
            let Verdict::Free { unsure, .. } = verdict else { return Ok(false) };
            for (&k, _) in ks[..n].iter().zip(unsure).filter(|(_, u)| *u) {
                self.place_along(ws, q0, q1, k as f64 / steps as f64)?;
                if !self.placed_collision_free(ws) {
                    return Ok(false);
                }
            }
        }
    }
}
