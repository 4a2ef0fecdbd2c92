//! Motion (edge) validation: is the straight joint-space motion between two
//! configurations collision-free? Sampled at a resolution, or certified
//! for every configuration of the motion by conservative advancement.

use super::model::CollisionModel;
use super::query::{CollisionWorkspace, prunes};
use super::spheres::{Certification, LANES, SampleOrder, SphereModel, Verdict};
use crate::robot::RobotError;
use crate::settings::InvalidSetting;
use std::time::Instant;

/// Finest resolution of a sampled motion check (rad or m): 10 µrad, 10 µm
/// at a 1 m lever. Finer ones only burn time (1e-300 once overflowed the
/// sample count to zero, so only the ends were checked).
pub const MIN_RESOLUTION: f64 = 1e-5;

/// Smallest clearance of a certified motion check (m): each advance is at
/// least `clearance / 2` over the fastest point's sweep.
pub const MIN_CLEARANCE: f64 = 1e-6;

/// Most configurations one motion check may place (sampled) or steps it
/// may advance (certified): a motion needing more is refused (sampled) or
/// not certified, instead of running for hours.
pub const MAX_MOTION_SAMPLES: usize = 1 << 22;

/// Samples between two looks at the clock of a motion check with a deadline.
const CLOCK_EVERY: usize = 256;

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
        Ok(self.motion_free_certified_by(ws, q0, q1, clearance, None)?.unwrap_or(false))
    }

    /// [`motion_free_certified`](Self::motion_free_certified) that gives
    /// up at `deadline`: `None` when the clock ran out first. A motion
    /// that would need more than [`MAX_MOTION_SAMPLES`] advances is not
    /// certified (`Some(false)`).
    ///
    /// # Errors
    /// Bad configurations; a `clearance` below [`MIN_CLEARANCE`] or not finite.
    pub fn motion_free_certified_by(
        &self,
        ws: &mut CollisionWorkspace,
        q0: &[f64],
        q1: &[f64],
        clearance: f64,
        deadline: Option<Instant>,
    ) -> Result<Option<bool>, RobotError> {
        self.check_motion(q0, q1)?;
        if !(clearance.is_finite() && clearance >= MIN_CLEARANCE) {
            let expected = format!("finite and at least {MIN_CLEARANCE} m");
            return Err(InvalidSetting::number("clearance", clearance, expected).into());
        }
        match self.certify_fast(ws, (q0, q1), clearance) {
            Some(Certification::Certified) => return Ok(Some(true)),
            Some(Certification::Fails) => return Ok(Some(false)),
            // Undecided: the general path decides.
            Some(Certification::Undecided) => ws.deferred += 1,
            // No fast path: the general path decides.
            None => {}
        }
        self.sweep_bounds(ws, q0, q1);
        let mut t = 0.0f64;
        for advance in 0..MAX_MOTION_SAMPLES {
            if advance % CLOCK_EVERY == CLOCK_EVERY - 1 && deadline.is_some_and(|d| Instant::now() > d) {
                return Ok(None);
            }
            self.place_along(ws, q0, q1, t)?;
            let Some(step) = self.safe_step(ws, clearance, t == 0.0) else { return Ok(Some(false)) };
            if t >= 1.0 {
                return Ok(Some(true));
            }
            t = (t + step).min(1.0);
        }
        Ok(Some(false))
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

    /// Validates both ends of a motion.
    fn check_motion(&self, q0: &[f64], q1: &[f64]) -> Result<(), RobotError> {
        self.robot.check_configuration(q0)?;
        self.robot.check_configuration(q1)
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
            *sweep = self
                .movers(gp)
                .map(|b| {
                    let (column, multiplier, prismatic, _) = self.robot.body_joint(b);
                    let lever = if prismatic { 1.0 } else { self.levers[b] };
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
    /// Bad configurations; a `resolution` below [`MIN_RESOLUTION`] or not
    /// finite; a motion that needs more than [`MAX_MOTION_SAMPLES`]
    /// configurations at that resolution ([`RobotError::InvalidSetting`]).
    pub fn motion_free(
        &self,
        ws: &mut CollisionWorkspace,
        q0: &[f64],
        q1: &[f64],
        resolution: f64,
    ) -> Result<bool, RobotError> {
        let answer = self.motion_free_by(ws, q0, q1, resolution, None)?;
        Ok(answer.expect("a motion check without a deadline always answers"))
    }

    /// [`motion_free`](Self::motion_free) that gives up at `deadline`:
    /// `None` when the clock ran out before the answer.
    ///
    /// # Errors
    /// As [`motion_free`](Self::motion_free).
    pub fn motion_free_by(
        &self,
        ws: &mut CollisionWorkspace,
        q0: &[f64],
        q1: &[f64],
        resolution: f64,
        deadline: Option<Instant>,
    ) -> Result<Option<bool>, RobotError> {
        self.sampled_motion_free(ws, (q0, q1), resolution, deadline, SampleOrder::new)
    }

    /// [`motion_free_by`](Self::motion_free_by) for a motion whose start
    /// `q0` is already known to pass (a search tree's node, say): every
    /// configuration but that one is checked. A search's steps check up
    /// to about nine configurations each, [`LANES`] at a time; leaving
    /// out the start saves a whole batch on those that need nine
    /// (MotionBenchMaker's Panda problems: 2.1 % of planning and
    /// simplification's instructions, same paths).
    ///
    /// # Errors
    /// As [`motion_free`](Self::motion_free).
    pub fn extension_free_by(
        &self,
        ws: &mut CollisionWorkspace,
        (q0, q1): (&[f64], &[f64]),
        resolution: f64,
        deadline: Option<Instant>,
    ) -> Result<Option<bool>, RobotError> {
        self.sampled_motion_free(ws, (q0, q1), resolution, deadline, SampleOrder::after_start)
    }

    /// The sampled check of `q0 → q1` at `resolution`, over the sample
    /// indices `order` gives for the motion's number of steps.
    fn sampled_motion_free(
        &self,
        ws: &mut CollisionWorkspace,
        (q0, q1): (&[f64], &[f64]),
        resolution: f64,
        deadline: Option<Instant>,
        order: fn(usize) -> SampleOrder,
    ) -> Result<Option<bool>, RobotError> {
        self.check_motion(q0, q1)?;
        let steps = motion_samples(q0, q1, resolution)?;
        let mut order = order(steps);
        if let Some(fast) = &self.spheres {
            if fast.always_collides() {
                return Ok(Some(false));
            }
            return self.motion_free_fast(fast, ws, (q0, q1), steps, &mut order, deadline);
        }
        for (i, k) in order.enumerate() {
            if i % CLOCK_EVERY == CLOCK_EVERY - 1 && deadline.is_some_and(|d| Instant::now() > d) {
                return Ok(None);
            }
            self.place_along(ws, q0, q1, k as f64 / steps as f64)?;
            if !self.placed_collision_free(ws) {
                return Ok(Some(false));
            }
        }
        Ok(Some(true))
    }

    /// [`motion_free`](Self::motion_free) on the sphere fast path: the
    /// samples in the same order, [`LANES`] at a time; samples the fast
    /// path is unsure of go through the general check.
    fn motion_free_fast(
        &self,
        fast: &SphereModel,
        ws: &mut CollisionWorkspace,
        (q0, q1): (&[f64], &[f64]),
        steps: usize,
        order: &mut SampleOrder,
        deadline: Option<Instant>,
    ) -> Result<Option<bool>, RobotError> {
        for batch in 0.. {
            if batch % (CLOCK_EVERY / LANES) == 0 && batch > 0 && deadline.is_some_and(|d| Instant::now() > d) {
                return Ok(None);
            }
            let mut ks = [0; LANES];
            let mut n = 0;
            for k in order.by_ref().take(LANES) {
                ks[n] = k;
                n += 1;
            }
            if n == 0 {
                break;
            }
            // Unused lanes repeat the last sample.
            let last = ks[n - 1];
            ks[n..].fill(last);
            let verdict = match ws.spheres.as_mut() {
                Some(scratch) => fast.check_samples(scratch, q0, q1, &ks, steps),
                None => Verdict::Free { unsure: [true; LANES], split: [false; LANES] },
            };
            let Verdict::Free { unsure, .. } = verdict else { return Ok(Some(false)) };
            for (&k, _) in ks[..n].iter().zip(unsure).filter(|(_, u)| *u) {
                self.place_along(ws, q0, q1, k as f64 / steps as f64)?;
                if !self.placed_collision_free(ws) {
                    return Ok(Some(false));
                }
            }
        }
        Ok(Some(true))
    }
}

/// Number of steps of the sampled check of `q0 → q1` at `resolution`
/// (samples `0..=steps`), refusing a resolution below [`MIN_RESOLUTION`]
/// and motions that need more than [`MAX_MOTION_SAMPLES`] samples.
fn motion_samples(q0: &[f64], q1: &[f64], resolution: f64) -> Result<usize, RobotError> {
    if !(resolution.is_finite() && resolution >= MIN_RESOLUTION) {
        let expected = format!("finite and at least {MIN_RESOLUTION} (rad or m)");
        return Err(InvalidSetting::number("resolution", resolution, expected).into());
    }
    let span = q0.iter().zip(q1).map(|(a, b)| (b - a).abs()).fold(0.0, f64::max);
    let steps = (span / resolution).ceil().max(1.0);
    if steps.is_nan() || steps > MAX_MOTION_SAMPLES as f64 {
        let expected = format!(
            "coarse enough for at most {MAX_MOTION_SAMPLES} samples over a motion of {span} (rad or m), which needs {steps:e}"
        );
        return Err(InvalidSetting::number("resolution", resolution, expected).into());
    }
    Ok(steps as usize)
}
