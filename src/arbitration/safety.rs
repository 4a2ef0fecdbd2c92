//! Hard constraints on the executed step, in every mode: joint position and
//! velocity limits as bounds on `u`, and linearised signed distances of the
//! pairs within reach, `−∇d · u ≤ rate · (d − margin)`.
//!
//! A pair moving apart (`∇d · u ≥ 0`) always satisfies its row while it is
//! outside the margin, so separating motion is never slowed. With `rate =
//! 1/dt` the row keeps the linearised distance after one step above the
//! margin; `ObstacleAvoidance` uses a smaller rate (a control barrier
//! function: approach slows in proportion to the distance left). A pair
//! already inside the margin may not approach further (its row's bound is
//! 0), and a pair no active joint moves has no row. So `u = 0` meets every
//! distance row, and with the state within its limits, every tick's
//! problem is feasible.

use super::motion::{MotionStage, rate_bounds, reachable_upper};
use crate::collision::{CollisionModel, CollisionWorkspace, PairDistance};
use crate::robot::JointMotionLimits;
use crate::robot::{KinematicsWorkspace, RobotModel};
use crate::settings::{InvalidSetting, non_negative, positive};

/// Settings of the hard constraints.
///
/// ```
/// # use tandem::arbitration::SafetySettings;
/// let s = SafetySettings::default();
/// assert!(s.collisions && s.certify && s.motion_limits);
/// assert_eq!((s.margin, s.avoidance_gain, s.certification_clearance, s.max_distance_rows), (0.005, 2.0, 1e-4, 32));
/// assert_eq!((s.default_velocity_limit, s.velocity_scale), (2.0, 1.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetySettings {
    /// Keep away from collisions: distance rows and certified steps. Off,
    /// only the joint position and velocity limits bound the command: the
    /// dissertation's unassisted baseline (`NoAssist`).
    pub collisions: bool,
    /// Distance every checked pair keeps, linearised (m). It absorbs the
    /// linearisation error of one step; the certification below guarantees
    /// contact-free motion whatever it is.
    pub margin: f64,
    /// `ObstacleAvoidance`: pairs approach at most `avoidance_gain · (d −
    /// margin)` (1/s).
    pub avoidance_gain: f64,
    /// Velocity limit of joints whose URDF gives none (rad/s or m/s).
    pub default_velocity_limit: f64,
    /// Factor on the URDF velocity limits.
    pub velocity_scale: f64,
    /// Certify each step against the exact geometry: every configuration
    /// of the straight motion `q → q + u·dt` keeps
    /// `certification_clearance / 2` from everything, else the step is
    /// halved (up to 4 times) or the arm holds.
    pub certify: bool,
    /// Clearance of the certification (m).
    pub certification_clearance: f64,
    /// Most distance rows per tick, the closest pairs first.
    pub max_distance_rows: usize,
    /// Keep the robot's acceleration, deceleration and jerk limits
    /// ([`RobotModel::motion_limits`]) on the executed command sequence,
    /// brake within them on every hold, and keep the distance and position
    /// limits reachable by braking (see the module `motion`). Off, a hold
    /// zeroes the velocity in one tick and a command may change by any
    /// amount (tandem before 2026-12).
    pub motion_limits: bool,
}

impl Default for SafetySettings {
    fn default() -> Self {
        SafetySettings {
            collisions: true,
            // The shipped problems' optimizer margin: a Panda grasp of a 6 cm
            // box leaves 7 mm between the fingers' outer spheres and the box.
            margin: 0.005,
            avoidance_gain: 2.0,
            default_velocity_limit: 2.0,
            velocity_scale: 1.0,
            certify: true,
            certification_clearance: 1e-4,
            max_distance_rows: 32,
            motion_limits: true,
        }
    }
}

impl SafetySettings {
    /// Checks every setting: a margin finite and at least 0; the gain,
    /// limits, scale and clearance above 0.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        non_negative("margin", self.margin, "m")?;
        positive("avoidance_gain", self.avoidance_gain, "1/s")?;
        positive("default_velocity_limit", self.default_velocity_limit, "rad/s or m/s")?;
        positive("velocity_scale", self.velocity_scale, "")?;
        positive("certification_clearance", self.certification_clearance, "m")
    }
}

/// One hard-constraint row `gᵀu ≤ h`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Row {
    /// `u_j ≤ hi_j`.
    Upper(usize),
    /// `−u_j ≤ −lo_j`.
    Lower(usize),
    /// Distance row `k`.
    Distance(usize),
}

/// The rows of one tick. Allocated once for `n` joints.
#[derive(Debug, Clone)]
pub struct SafetyRows {
    n: usize,
    pub(crate) lo: Vec<f64>,
    pub(crate) hi: Vec<f64>,
    /// Distance rows, row-major `count × n`, and their bounds.
    g: Vec<f64>,
    h: Vec<f64>,
    pub(crate) count: usize,
    /// Smallest signed distance among the pairs within reach (m), and
    /// among those some joint moves.
    pub(crate) min_distance: f64,
    pub(crate) min_moving_distance: f64,
    /// The pairs within reach, closest first once trimmed.
    pairs: Vec<PairDistance>,
    gradient: Vec<f64>,
    /// The collision queries of the rows, the certification and the
    /// learned state, at the tick's configuration.
    pub(crate) collision: CollisionWorkspace,
}

impl SafetyRows {
    /// Rows for `n` joints, at most `max_rows` distance rows, from `model`.
    pub(crate) fn new(n: usize, max_rows: usize, model: &CollisionModel) -> Self {
        SafetyRows {
            n,
            lo: vec![0.0; n],
            hi: vec![0.0; n],
            g: vec![0.0; max_rows * n],
            h: vec![0.0; max_rows],
            count: 0,
            min_distance: f64::INFINITY,
            min_moving_distance: f64::INFINITY,
            pairs: Vec::with_capacity(model.pair_count()),
            gradient: vec![0.0; n],
            collision: CollisionWorkspace::new(model),
        }
    }

    /// The arm's joint count these rows are for.
    pub fn joints(&self) -> usize {
        self.n
    }

    /// Bounds `lo ≤ u ≤ hi` from the velocity limits and from the position
    /// limits reached in one period `dt`. Outside its limits, a joint must
    /// move back toward them (as fast as its velocity limit allows). With
    /// `motion` (the executed sequence, see [`super::motion`]), also the
    /// acceleration, deceleration and jerk limits, the velocity and
    /// position limits reachable under them, and always the braking step.
    pub(crate) fn build_bounds(
        &mut self,
        robot: &RobotModel,
        q: &[f64],
        dt: f64,
        settings: &SafetySettings,
        motion: Option<&MotionStage>,
    ) {
        let motion_limits = robot.motion_limits();
        for (j, limits) in robot.limits().iter().enumerate() {
            let (down_v, up_v) = motion_limits[j].velocity_range(q[j], settings.velocity_scale);
            let up = if limits.upper.is_finite() { (limits.upper - q[j]) / dt } else { f64::INFINITY };
            let down = if limits.lower.is_finite() { (limits.lower - q[j]) / dt } else { f64::NEG_INFINITY };
            self.hi[j] = up_v.min(up.max(down_v));
            self.lo[j] = down_v.max(down.min(up_v)).min(self.hi[j]);
            let Some(m) = motion else { continue };
            let l = &motion_limits[j];
            let (v, a, brake) = (m.velocity[j], m.acceleration[j], m.brake[j]);
            let (rate_lo, rate_hi) = rate_bounds(v, a, l, dt, down_v, up_v);
            let (mut lo, mut hi) = (self.lo[j].max(rate_lo), self.hi[j].min(rate_hi));
            if lo <= hi {
                if limits.upper.is_finite() {
                    hi = reachable_upper(q[j], v, l, dt, limits.upper, (lo, hi));
                }
                if limits.lower.is_finite() {
                    lo = -reachable_upper(-q[j], -v, l, dt, -limits.lower, (-hi, -lo));
                }
            }
            // Decelerating at the limit is always allowed; the position
            // limit itself stays hard (see the module `motion`).
            let (lo, hi) = if lo <= hi { (lo.min(brake), hi.max(brake)) } else { (brake, brake) };
            self.hi[j] = hi.min(up.max(down_v));
            self.lo[j] = lo.max(down.min(up_v)).min(self.hi[j]);
        }
    }

    /// Distance rows for the pairs closer than `cutoff` (m) at the
    /// placement in `kinematics`: `−∇d · u ≤ rate · max(d − margin, 0)`,
    /// the closest `max` pairs that some joint moves; with `braking` (the
    /// motion limits and the period), braking-aware ([`braking_bound`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn build_distances(
        &mut self,
        model: &CollisionModel,
        kinematics: &KinematicsWorkspace,
        cutoff: f64,
        rate: f64,
        settings: &SafetySettings,
        braking: Option<(&[JointMotionLimits], f64)>,
    ) {
        let n = self.n;
        self.pairs.clear();
        self.count = 0;
        self.min_distance = f64::INFINITY;
        self.min_moving_distance = f64::INFINITY;
        if !settings.collisions {
            return;
        }
        self.pairs.extend_from_slice(model.distances_at(&mut self.collision, kinematics, cutoff));
        let keep = self.pairs.len().min(settings.max_distance_rows).min(self.h.len());
        if keep < self.pairs.len() {
            self.pairs.select_nth_unstable_by(keep, |a, b| a.signed.distance.total_cmp(&b.signed.distance));
        }
        for pair in &self.pairs[..keep] {
            let distance = pair.signed.distance;
            self.min_distance = self.min_distance.min(distance);
            let moved = model.distance_gradient(&self.collision, pair, &mut self.gradient).is_ok()
                && self.gradient.iter().any(|g| g.abs() > 1e-12);
            if !moved {
                continue;
            }
            self.min_moving_distance = self.min_moving_distance.min(distance);
            let row = &mut self.g[self.count * n..(self.count + 1) * n];
            for (r, g) in row.iter_mut().zip(&self.gradient) {
                *r = -g;
            }
            let room = (distance - settings.margin).max(0.0);
            self.h[self.count] = match braking {
                None => rate * room,
                Some((limits, dt)) => braking_bound(row, &self.lo, &self.hi, limits, dt, rate, room),
            };
            self.count += 1;
        }
    }

    /// Number of rows (bounds count two per joint).
    pub(crate) fn total(&self) -> usize {
        2 * self.n + self.count
    }

    /// Row `row` as `(g, h)` written into `g` (n values); returns `h`.
    pub(crate) fn row(&self, row: Row, g: &mut [f64]) -> f64 {
        match row {
            Row::Upper(j) => {
                g.fill(0.0);
                g[j] = 1.0;
                self.hi[j]
            }
            Row::Lower(j) => {
                g.fill(0.0);
                g[j] = -1.0;
                -self.lo[j]
            }
            Row::Distance(k) => {
                g.copy_from_slice(&self.g[k * self.n..(k + 1) * self.n]);
                self.h[k]
            }
        }
    }

    /// `h − gᵀu` of a row (negative when violated).
    pub(crate) fn slack(&self, row: Row, u: &[f64]) -> f64 {
        match row {
            Row::Upper(j) => self.hi[j] - u[j],
            Row::Lower(j) => u[j] - self.lo[j],
            Row::Distance(k) => {
                let g = &self.g[k * self.n..(k + 1) * self.n];
                self.h[k] - g.iter().zip(u).map(|(g, u)| g * u).sum::<f64>()
            }
        }
    }

    /// Every row, bounds first.
    pub(crate) fn rows(&self) -> impl Iterator<Item = Row> + '_ {
        (0..self.n).flat_map(|j| [Row::Upper(j), Row::Lower(j)]).chain((0..self.count).map(Row::Distance))
    }

    /// Clamps `u` into the bounds (exactly, after a solver's tolerance).
    pub(crate) fn clamp(&self, u: &mut [f64]) {
        for ((u, lo), hi) in u.iter_mut().zip(&self.lo).zip(&self.hi) {
            *u = u.clamp(*lo, *hi);
        }
    }
}

/// The bound `h` of a braking-aware distance row `s = r·u ≤ h` (`r = −∇d`,
/// `s` the pair's approach speed, m/s) with `room = max(d − margin, 0)` (m),
/// under this tick's joint bounds `[lo, hi]`: the approach of this step and
/// of the stop after it fits the room, `s·(dt + t_ramp + s̄/2a) ≤ room` — a
/// stop at the pair's deceleration `a = ½ Σ|r_j|·D_j` (half of what every
/// joint slowing this approach could give: the other rows and bounds share
/// the joints), after the jerk-limited ramp `t_ramp = max (A_j + D_j)/J_j`,
/// from at most this tick's fastest approach `s̄ = max r·u` over the bounds
/// (`s² ≤ s·s̄` keeps the row linear). And never below the slowest
/// approach the bounds allow (`min r·u`), so that every row admits the
/// command that slows its pair fastest.
fn braking_bound(
    row: &[f64],
    lo: &[f64],
    hi: &[f64],
    limits: &[JointMotionLimits],
    dt: f64,
    rate: f64,
    room: f64,
) -> f64 {
    let (mut fastest, mut slowest, mut decel, mut ramp) = (0.0, 0.0, 0.0, 0.0_f64);
    for (j, r) in row.iter().enumerate() {
        let (a, b) = (r * lo[j], r * hi[j]);
        fastest += a.max(b);
        slowest += a.min(b);
        decel += 0.5 * r.abs() * limits[j].deceleration;
        ramp = ramp.max((limits[j].acceleration + limits[j].deceleration) / limits[j].jerk);
    }
    let rate = if fastest > 0.0 && decel > 0.0 { rate.min(1.0 / (dt + ramp + fastest / (2.0 * decel))) } else { rate };
    (rate * room).max(slowest)
}
