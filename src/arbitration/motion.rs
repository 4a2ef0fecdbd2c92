//! The motion limits in the tick: acceleration, deceleration and jerk of
//! the executed command sequence, braking-aware position limits, and the
//! controlled stop every hold becomes.
//!
//! The arbiter remembers the command it executed last (`v`, rad/s) and the
//! acceleration that took it there (`a`, rad/s²). Each tick's command `u`
//! then meets, per joint and as hard bounds of the same QP that keeps the
//! distances:
//!
//! - acceleration `|u − v| ≤ A·dt` while the speed grows, `D·dt` while it
//!   shrinks (ISO 10218's deceleration), and jerk `|(u − v)/dt − a| ≤ J·dt`
//!   — the finite differences a Panda's controller checks at its own
//!   period;
//! - the velocity limit, reachable: accelerating to `u`, the joint can
//!   still ramp its acceleration back to zero within the jerk limit
//!   without passing the limit (`u + a'²/2J ≤ v_max`, `a' = (u − v)/dt`);
//! - its position limit, reachable: from `q + u·dt` the joint can still
//!   stop before the limit ([`stopping_distance`]; without jerk this is
//!   `|q̇| ≤ √(2D(q_max − q))`).
//!
//! **What keeps every tick feasible.** The *braking step* `b` — each joint
//! slowing toward rest as fast as its deceleration and jerk allow,
//! landing at zero acceleration ([`brake_velocity`]) — meets the
//! acceleration and jerk bounds by construction, and from a state that met
//! the bounds before it meets the reachable velocity and position limits
//! too. The tick widens every bound and every distance row to admit `b`, so
//! its problem is never empty and decelerating at the limit is always
//! allowed. Two things can still exceed a limit, and both are reported:
//! a braking step that would itself pass a joint's position limit (only
//! from a state that could not stop in time when it was handed over, e.g.
//! a robot already moving fast toward its limit) is clamped at the limit;
//! and a braking step the certification finds in contact (the linearised
//! distance rows kept the *stop* clear, exact geometry did not) halts at
//! once, with [`TickStatus::Halted`](super::TickStatus::Halted) and a zero
//! command: a category-0 stop where the alternative is a collision.

use crate::robot::JointMotionLimits;

/// The executed sequence's state, and this tick's braking step. Allocated
/// once for `n` joints.
#[derive(Debug, Clone)]
pub struct MotionStage {
    /// The command executed last (rad/s; zero at rest).
    pub(crate) velocity: Vec<f64>,
    /// The acceleration that reached it, `(v − v_before)/dt` (rad/s²).
    pub(crate) acceleration: Vec<f64>,
    /// This tick's braking step (rad/s).
    pub(crate) brake: Vec<f64>,
}

impl MotionStage {
    pub(crate) fn new(n: usize) -> Self {
        MotionStage { velocity: vec![0.0; n], acceleration: vec![0.0; n], brake: vec![0.0; n] }
    }

    /// At rest.
    pub(crate) fn reset(&mut self) {
        self.velocity.fill(0.0);
        self.acceleration.fill(0.0);
        self.brake.fill(0.0);
    }

    /// The braking step of every joint for period `dt` (s); zero without
    /// limits (`limits` empty).
    pub(crate) fn plan_brake(&mut self, limits: &[JointMotionLimits], dt: f64) {
        if limits.is_empty() {
            self.brake.fill(0.0);
            return;
        }
        for (j, l) in limits.iter().enumerate() {
            self.brake[j] = brake_velocity(self.velocity[j], self.acceleration[j], l, dt);
        }
    }

    /// Records `qdot` as executed for period `dt`; a `stopped` arm (a
    /// category-0 stop, zero command) rests from zero acceleration.
    pub(crate) fn executed(&mut self, qdot: &[f64], dt: f64, stopped: bool) {
        if stopped {
            self.reset();
            return;
        }
        for ((v, a), u) in self.velocity.iter_mut().zip(&mut self.acceleration).zip(qdot) {
            *a = (u - *v) / dt;
            *v = *u;
        }
    }
}

/// The next velocity of a joint braking from velocity `v` (rad/s) and
/// acceleration `a` (rad/s²) over one period `dt` (s): the acceleration
/// falls toward `−D` (against the motion) as fast as the jerk allows, and
/// eases back so that the speed reaches zero with zero acceleration
/// instead of passing it. Exactly zero once stopped.
pub fn brake_velocity(v: f64, a: f64, limits: &JointMotionLimits, dt: f64) -> f64 {
    let (d, j) = (limits.deceleration, limits.jerk);
    let jd = j * dt;
    // The stop lands this tick: zero velocity with an acceleration the
    // next tick can take back to zero.
    let land = -v / dt;
    if (land - a).abs() <= jd && land.abs() <= jd.min(d) {
        return 0.0;
    }
    // Braking against s = the sign of the motion (of the acceleration at rest).
    let s = if v != 0.0 { v.signum() } else { -a.signum() };
    let (v, a) = (s * v, s * a);
    // The hardest deceleration that can still land: v + a'·dt ≥ a'²/2J.
    let landing = j * (dt - (dt * dt + 2.0 * v.max(0.0) / j).sqrt());
    // Past the deceleration limit (only after a category-0 stop the arbiter
    // rests from) the limit comes first, the jerk second.
    let next = (a - jd).max(-d).max(landing).min(a + jd).max(-d);
    s * (v + next * dt)
}

/// An upper bound on how far a joint moving at `v` (rad/s) with
/// acceleration `a` (rad/s²) travels forward (in `+`; 0 when it cannot)
/// before it is at rest under [`brake_velocity`]: its acceleration first
/// ramps to `−D` (time `t₁ = (a + D)/J`, at most at the peak speed `v̂ = v
/// + a⁺²/2J`), then `v̂²/2D`, then the ramp back to zero (`D³/24J²`).
pub fn stopping_distance(v: f64, a: f64, limits: &JointMotionLimits) -> f64 {
    let (d, j) = (limits.deceleration, limits.jerk);
    let peak = v + a.max(0.0).powi(2) / (2.0 * j);
    if peak <= 0.0 {
        return 0.0;
    }
    let ramp = (a.max(-d) + d) / j;
    peak * ramp + peak * peak / (2.0 * d) + d * d * d / (24.0 * j * j)
}

/// This tick's bounds `[lo, hi]` (rad/s) on one joint's command from the
/// acceleration, deceleration and jerk limits and the reachable velocity
/// range `[down, up]`, given the last command `v` and its acceleration `a`.
pub(crate) fn rate_bounds(v: f64, a: f64, limits: &JointMotionLimits, dt: f64, down: f64, up: f64) -> (f64, f64) {
    let (acc, dec, jerk) = (limits.acceleration, limits.deceleration, limits.jerk);
    // Acceleration: speeding up at A, slowing down at D; a change through
    // zero slows first (v/D of the period), then speeds up.
    let toward_zero = |v: f64| {
        if v >= dec * dt { v - dec * dt } else { -acc * (dt - v / dec) }
    };
    let (mut lo, mut hi) = if v >= 0.0 { (toward_zero(v), v + acc * dt) } else { (v - acc * dt, -toward_zero(-v)) };
    // Jerk.
    lo = lo.max(v + (a - jerk * dt) * dt);
    hi = hi.min(v + (a + jerk * dt) * dt);
    // The velocity limits, reachable with the jerk: u + a'|a'|/2J within
    // [down, up], a' = (u − v)/dt.
    let c = 1.0 / (2.0 * jerk * dt * dt);
    // The largest x ≥ 0 with x + c·x² ≤ room.
    let reach = |room: f64| (-1.0 + (1.0 + 4.0 * c * room).sqrt()) / (2.0 * c);
    hi = hi.min(up);
    lo = lo.max(down);
    if up >= v {
        hi = hi.min(v + reach(up - v));
    }
    if down <= v {
        lo = lo.max(v - reach(v - down));
    }
    (lo, hi)
}

/// The largest command in `[lo, hi]` (rad/s) from which a joint at `q`
/// (last command `v`, acceleration `a`) can still stop before `upper` (rad):
/// `q + u·dt + stopping_distance(u, (u − v)/dt) ≤ upper`, by bisection (the
/// left side grows with `u`). `lo` when even `lo` cannot.
pub(crate) fn reachable_upper(
    q: f64,
    v: f64,
    limits: &JointMotionLimits,
    dt: f64,
    upper: f64,
    (lo, hi): (f64, f64),
) -> f64 {
    let ends_at = |u: f64| q + u * dt + stopping_distance(u, (u - v) / dt, limits);
    if ends_at(hi) <= upper {
        return hi;
    }
    if ends_at(lo) > upper {
        return lo;
    }
    let (mut ok, mut bad) = (lo, hi);
    // 1e-9 rad/s is far below any limit's tolerance.
    while bad - ok > 1e-9 * (1.0 + bad.abs()) {
        let mid = 0.5 * (ok + bad);
        if ends_at(mid) <= upper { ok = mid } else { bad = mid }
    }
    ok
}

/// Counts the acceleration and jerk limit violations of an executed
/// command sequence, as a robot's controller would see it: finite
/// differences at the control period, from rest. Allocation-free per
/// command after [`MotionAudit::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct MotionAudit {
    velocity: Vec<f64>,
    acceleration: Vec<f64>,
    /// Commands with some joint's acceleration (deceleration) or jerk past
    /// its limit by more than a relative 1e-9.
    pub violations: usize,
    /// The largest `|q̈| / limit` seen (the deceleration limit while
    /// slowing down, else the acceleration limit).
    pub peak_acceleration_ratio: f64,
    /// The largest `|q⃛| / jerk limit` seen.
    pub peak_jerk_ratio: f64,
    /// The last command's largest acceleration and jerk ratios over the
    /// joints (as the peaks, for that command alone).
    pub last_ratios: [f64; 2],
}

impl MotionAudit {
    /// An audit of `n` joints at rest.
    pub fn new(n: usize) -> Self {
        MotionAudit {
            velocity: vec![0.0; n],
            acceleration: vec![0.0; n],
            violations: 0,
            peak_acceleration_ratio: 0.0,
            peak_jerk_ratio: 0.0,
            last_ratios: [0.0; 2],
        }
    }

    /// Records `qdot` (rad/s), executed for `dt` (s), against `limits`;
    /// returns whether it broke one.
    pub fn observe(&mut self, qdot: &[f64], dt: f64, limits: &[JointMotionLimits]) -> bool {
        let mut broke = false;
        self.last_ratios = [0.0; 2];
        for (j, (&u, l)) in qdot.iter().zip(limits).enumerate() {
            let (v, a) = (self.velocity[j], self.acceleration[j]);
            let acc = (u - v) / dt;
            let jerk = (acc - a) / dt;
            let slowing = u.abs() < v.abs() || u * v < 0.0;
            let limit = if slowing { l.deceleration.max(l.acceleration) } else { l.acceleration };
            let (ra, rj) = (acc.abs() / limit, jerk.abs() / l.jerk);
            self.peak_acceleration_ratio = self.peak_acceleration_ratio.max(ra);
            self.peak_jerk_ratio = self.peak_jerk_ratio.max(rj);
            self.last_ratios = [self.last_ratios[0].max(ra), self.last_ratios[1].max(rj)];
            broke |= ra > 1.0 + 1e-9 || rj > 1.0 + 1e-9 || !acc.is_finite();
            self.velocity[j] = u;
            self.acceleration[j] = acc;
        }
        self.violations += usize::from(broke);
        broke
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::LimitSource;

    fn panda_joint1() -> JointMotionLimits {
        JointMotionLimits {
            velocity: 2.175,
            acceleration: 15.0,
            deceleration: 15.0,
            jerk: 7500.0,
            velocity_profile: None,
            sources: [LimitSource::Urdf, LimitSource::Default, LimitSource::Default, LimitSource::Default],
        }
    }

    /// A small deterministic generator (no dependency for one test).
    fn lcg(state: &mut u64) -> f64 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn braking_meets_every_limit_stops_still_and_within_its_stopping_distance() {
        let l = panda_joint1();
        let mut seed = 7;
        for &dt in &[1e-3, 1e-2, 1.0 / 15.0] {
            for _ in 0..2000 {
                let v = (2.0 * lcg(&mut seed) - 1.0) * l.velocity;
                let a = (2.0 * lcg(&mut seed) - 1.0) * l.acceleration;
                let bound = stopping_distance(v, a, &l);
                let (mut x, mut vel, mut acc, mut most) = (0.0_f64, v, a, 0.0_f64);
                for _ in 0..100_000 {
                    let next = brake_velocity(vel, acc, &l, dt);
                    let next_acc = (next - vel) / dt;
                    assert!(next_acc.abs() <= l.deceleration.max(l.acceleration) * (1.0 + 1e-12), "acc {next_acc}");
                    assert!((next_acc - acc).abs() <= l.jerk * dt * (1.0 + 1e-9) + 1e-9, "jerk at dt {dt}");
                    x += next * dt;
                    most = most.max(x);
                    vel = next;
                    acc = next_acc;
                    if vel == 0.0 && acc.abs() <= l.jerk * dt {
                        break;
                    }
                }
                assert_eq!(vel, 0.0, "stopped from v {v} a {a} at dt {dt}");
                assert_eq!(brake_velocity(0.0, acc, &l, dt), 0.0, "still once stopped");
                // The discrete stop may overshoot the continuous bound by the
                // period's own step (the first tick is executed at full v).
                assert!(
                    most <= bound + 1.5 * (v.abs() + l.acceleration * dt) * dt + 1e-12,
                    "v {v} a {a} dt {dt}: {most} > {bound}"
                );
            }
        }
    }

    #[test]
    fn the_bounds_always_admit_the_brake_from_a_state_they_allowed() {
        let l = panda_joint1();
        let mut seed = 11;
        let dt = 1e-3;
        for _ in 0..200 {
            let (mut v, mut a) = (0.0, 0.0);
            for _ in 0..400 {
                let (lo, hi) = rate_bounds(v, a, &l, dt, -l.velocity, l.velocity);
                let b = brake_velocity(v, a, &l, dt);
                assert!(lo <= hi + 1e-12, "empty at v {v} a {a}");
                assert!(b >= lo - 1e-9 && b <= hi + 1e-9, "brake {b} outside [{lo}, {hi}] at v {v} a {a}");
                let u = lo + (hi - lo) * lcg(&mut seed);
                a = (u - v) / dt;
                v = u;
                assert!(v.abs() <= l.velocity + 1e-9);
            }
        }
    }
}
