//! The LQR tracking policy π_R (the dissertation's Algorithm 1, §3.3.4).

use super::ControlError;
use crate::trajectory::JointTrajectory;
use nalgebra::DMatrix;
use tandem_solvers::riccati::{
    DareProblem, DareSettings, LinearDynamics, double_integrator, finite_horizon_riccati, solve_dare,
};

/// Weights of the tracking cost `Σ eᵀQe + νᵀRν`, per joint: `Q =
/// diag(position, velocity)` on the error state, `R = control` on the
/// acceleration error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingWeights {
    /// Weight on position error (1/rad²).
    pub position: f64,
    /// Weight on velocity error (s²/rad²).
    pub velocity: f64,
    /// Weight on acceleration error (s⁴/rad²).
    pub control: f64,
}

impl Default for TrackingWeights {
    fn default() -> Self {
        TrackingWeights { position: 100.0, velocity: 1.0, control: 0.1 }
    }
}

/// Constant gains (the DARE solution) or gains varying along the reference
/// (the finite-horizon recursion ending at the goal).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GainSchedule {
    /// One gain `K` from the discrete algebraic Riccati equation.
    #[default]
    Constant,
    /// `K_i` for each waypoint `i` from the finite-horizon Riccati recursion
    /// over the reference, with the DARE cost-to-go as terminal cost.
    TimeVarying,
}

/// Which reference derivatives the policy feeds forward.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Feedforward {
    /// The reference velocity enters the error state; no feedforward
    /// acceleration. An arm at rest is always pulled forward along the
    /// reference, so every rollout ends at the goal.
    #[default]
    Velocity,
    /// Also the reference acceleration `u_d` of eq. 3.12. Exact for an arm
    /// on schedule; an arm lagging at rest in a decelerating stretch can
    /// settle where `u_d` cancels the feedback, short of the goal.
    Acceleration,
}

/// Per-caller state of policy queries: the progress along the reference
/// found by the last query (its hint for the next) and scratch space. One per
/// control loop (or thread).
#[derive(Debug, Clone)]
pub struct PolicyWorkspace {
    progress: Option<f64>,
    error: Vec<f64>,
}

impl PolicyWorkspace {
    /// The progress along the reference found by the last query (waypoint
    /// coordinate `s ∈ [0, T − 1]`), `None` before the first.
    pub fn progress(&self) -> Option<f64> {
        self.progress
    }

    /// Forgets the progress: the next query searches the whole reference.
    pub fn reset(&mut self) {
        self.progress = None;
    }
}

/// What one query found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolicyQuery {
    /// The waypoint nearest to the closest point of the reference.
    pub index: usize,
    /// The closest point of the reference, as a waypoint coordinate `s ∈
    /// [0, T − 1]`: waypoint `⌊s⌋` plus the fraction `s − ⌊s⌋` of the
    /// segment to the next (the reference is a polyline).
    pub progress: f64,
    /// Joint-space distance to the closest point (rad, Euclidean).
    pub distance: f64,
    /// Joint-space arc length of the reference from its start to the
    /// closest point (rad).
    pub arc_length: f64,
    /// The point tracked: the progress plus the look-ahead, at most `T − 1`.
    pub target: f64,
}

/// An LQR policy that steers the arm back onto a reference from anywhere
/// nearby: `a = −K (x − x_d) + a_d` on the joint-space double integrator
/// with state `x = [q, q̇]`, integrated over one time step to a joint
/// velocity command. Immutable and `Send + Sync`; queries allocate nothing.
///
/// The reference is a polyline through its waypoints, and `x_d` is taken at
/// the closest point of it (plus a look-ahead), interpolated between
/// waypoints, so the command varies continuously with `q` — finite
/// differences of the policy (the arbitration metrics) see the reference's
/// direction, not a staircase of waypoint indices. The closest point is
/// searched by *progress*: from the point found by the previous query,
/// forward along the reference while the distance keeps falling (a few
/// segments of patience), back at most `backtrack` waypoints; the whole
/// reference only on the first query, preferring the earliest of nearly
/// equidistant points. A reference that reverses, loops or crosses itself is
/// followed in order, never short-cut to a later pass through the same place.
#[derive(Debug, Clone)]
pub struct TrackingPolicy {
    reference: JointTrajectory,
    /// One gain (n × 2n, column-major) or one per waypoint.
    gains: Vec<DMatrix<f64>>,
    /// Segments searched past the last improvement before the forward search stops.
    patience: usize,
    /// Arc length a query may move back from the previous progress (rad).
    backtrack: f64,
    /// Arc length from the first waypoint to each waypoint (rad).
    arc: Vec<f64>,
    /// Waypoints between the closest point and the point tracked.
    lookahead: f64,
    feedforward: Feedforward,
}

/// Relative tolerance under which two distances count as equal (a later
/// waypoint wins a tie during the forward search, the earlier one on a
/// first, global search).
const TIE: f64 = 1e-9;

impl TrackingPolicy {
    /// Builds the policy for `reference` with the given weights.
    ///
    /// # Errors
    /// A reference time step outside [`MIN_TIME_STEP`](super::MIN_TIME_STEP)
    /// ..= [`MAX_TIME_STEP`](super::MAX_TIME_STEP), more joints than
    /// [`MAX_REFERENCE_JOINTS`](super::MAX_REFERENCE_JOINTS), a weight
    /// outside [`WEIGHT_RANGE`](super::WEIGHT_RANGE); a Riccati failure
    /// (not seen within the ranges of weights and time steps: the double
    /// integrator is controllable).
    pub fn new(
        reference: JointTrajectory,
        weights: TrackingWeights,
        schedule: GainSchedule,
    ) -> Result<Self, ControlError> {
        let dt = reference.dt();
        if !(super::MIN_TIME_STEP..=super::MAX_TIME_STEP).contains(&dt) {
            return Err(ControlError::InvalidTimeStep { dt });
        }
        if reference.dof() > super::MAX_REFERENCE_JOINTS {
            return Err(ControlError::TooManyJoints { count: reference.dof() });
        }
        let w = weights;
        for (name, value) in [("position", w.position), ("velocity", w.velocity), ("control", w.control)] {
            if !super::WEIGHT_RANGE.contains(&value) {
                return Err(ControlError::InvalidWeight { name, value });
            }
        }
        let (a, b, q, r) = double_integrator_problem(reference.dof(), reference.dt(), &weights);
        let dare = solve_dare(&DareProblem::new(&a, &b, &q, &r), &DareSettings::default())?;
        let gains = match schedule {
            GainSchedule::Constant => vec![dare.k],
            GainSchedule::TimeVarying => {
                let horizon = reference.len().saturating_sub(1).max(1);
                let mut fh = finite_horizon_riccati(&LinearDynamics::constant(&a, &b), &q, &r, &dare.p, horizon)?;
                // The last waypoint keeps the terminal (DARE) gain.
                fh.gains.push(dare.k);
                fh.gains.truncate(reference.len());
                fh.gains
            }
        };
        let mut arc = Vec::with_capacity(reference.len());
        arc.push(0.0);
        for i in 1..reference.len() {
            let step: f64 =
                reference.position(i).iter().zip(reference.position(i - 1)).map(|(a, b)| (a - b) * (a - b)).sum();
            arc.push(arc[i - 1] + step.sqrt());
        }
        Ok(TrackingPolicy {
            reference,
            gains,
            patience: 3,
            backtrack: 0.2,
            arc,
            lookahead: 1.0,
            feedforward: Feedforward::default(),
        })
    }

    /// The policy of the reference through `waypoints` (one slice of
    /// `joints.len()` values each, the start first), `dt` seconds apart: the
    /// policy's time step and joint count are checked first, then the
    /// waypoints ([`JointTrajectory::new`]).
    ///
    /// # Errors
    /// As [`new`](Self::new) and [`JointTrajectory::new`].
    pub fn from_waypoints(
        joints: Vec<String>,
        dt: f64,
        waypoints: &[Vec<f64>],
        weights: TrackingWeights,
        schedule: GainSchedule,
    ) -> Result<Self, ControlError> {
        if !(super::MIN_TIME_STEP..=super::MAX_TIME_STEP).contains(&dt) {
            return Err(ControlError::InvalidTimeStep { dt });
        }
        if joints.len() > super::MAX_REFERENCE_JOINTS {
            return Err(ControlError::TooManyJoints { count: joints.len() });
        }
        Self::new(JointTrajectory::new(joints, dt, waypoints)?, weights, schedule)
    }

    /// Chooses the feedforward terms (default [`Feedforward::Velocity`]).
    pub fn with_feedforward(mut self, feedforward: Feedforward) -> Self {
        self.feedforward = feedforward;
        self
    }

    /// Tracks the point `steps` waypoints after the closest one (default 1):
    /// the reference segment starts at the closest point (Algorithm 1), and
    /// aiming one step ahead keeps the arm moving along it.
    pub fn with_lookahead(mut self, steps: usize) -> Self {
        self.lookahead = steps as f64;
        self
    }

    /// Bounds the search: at most `backtrack` of arc length back from the
    /// previous progress (rad; default 0.2) and `patience` segments of the
    /// forward search past the last improvement (default 3, at least 1).
    /// A negative or NaN `backtrack` counts as 0.
    pub fn with_search(mut self, backtrack: f64, patience: usize) -> Self {
        self.backtrack = backtrack.max(0.0);
        self.patience = patience.max(1);
        self
    }

    /// The reference being tracked.
    pub fn reference(&self) -> &JointTrajectory {
        &self.reference
    }

    /// The gain applied at waypoint `index` (n × 2n: position then velocity columns).
    pub fn gain(&self, index: usize) -> &DMatrix<f64> {
        &self.gains[index.min(self.gains.len() - 1)]
    }

    /// A workspace for queries of this policy.
    pub fn workspace(&self) -> PolicyWorkspace {
        PolicyWorkspace { progress: None, error: vec![0.0; 2 * self.reference.dof()] }
    }

    /// The velocity command at configuration `q` with current joint velocity
    /// `velocity` (zero when `None`), written into `command` (rad/s or m/s).
    /// The progress found becomes the workspace's hint for the next query.
    ///
    /// # Errors
    /// Wrong lengths or non-finite values in `q` or `velocity`; `command` is
    /// then left untouched.
    pub fn query(
        &self,
        ws: &mut PolicyWorkspace,
        q: &[f64],
        velocity: Option<&[f64]>,
        command: &mut [f64],
    ) -> Result<PolicyQuery, ControlError> {
        let found = self.probe(ws, q, velocity, command)?;
        ws.progress = Some(found.progress);
        Ok(found)
    }

    /// As [`TrackingPolicy::query`], searching from the workspace's progress
    /// without moving it: for finite-difference probes around the state.
    ///
    /// # Errors
    /// As [`TrackingPolicy::query`].
    pub fn probe(
        &self,
        ws: &mut PolicyWorkspace,
        q: &[f64],
        velocity: Option<&[f64]>,
        command: &mut [f64],
    ) -> Result<PolicyQuery, ControlError> {
        let n = self.reference.dof();
        check_vector("q", q, n)?;
        if ws.error.len() != 2 * n {
            ws.error.resize(2 * n, 0.0); // a workspace made for another policy: resized once
        }
        if let Some(v) = velocity {
            check_vector("velocity", v, n)?;
        }
        if command.len() != n {
            return Err(ControlError::WrongLength { what: "command", expected: n, got: command.len() });
        }
        let last = (self.reference.len() - 1) as f64;
        // A hint past the end (a workspace made for another policy) is lost.
        let hint = ws.progress.filter(|&s| s <= last);
        let mut found = match hint {
            Some(s) => self.search_from(q, s),
            None => self.search_all(q),
        };
        found.target = (found.progress + self.lookahead).min(last);
        self.command_at(ws, &found, q, velocity, command);
        Ok(found)
    }

    /// `command = v + (a_d − K e)·dt` with the error state `e` against the
    /// reference interpolated at `found.target`.
    fn command_at(
        &self,
        ws: &mut PolicyWorkspace,
        found: &PolicyQuery,
        q: &[f64],
        velocity: Option<&[f64]>,
        command: &mut [f64],
    ) {
        let n = self.reference.dof();
        let r = &self.reference;
        let (i, t) = split(found.target, r.len());
        let j = (i + 1).min(r.len() - 1);
        // The reference ends at rest on its goal.
        let at_goal = found.target >= (r.len() - 1) as f64;
        let lerp = |a: &[f64], b: &[f64], k: usize| a[k] + t * (b[k] - a[k]);
        for k in 0..n {
            ws.error[k] = q[k] - lerp(r.position(i), r.position(j), k);
            let vd = if at_goal { 0.0 } else { lerp(r.velocity(i), r.velocity(j), k) };
            ws.error[n + k] = velocity.map_or(0.0, |v| v[k]) - vd;
        }
        let (ki, kj) = (self.gain(i), self.gain(j));
        let dt = r.dt();
        let feedforward = !at_goal && self.feedforward == Feedforward::Acceleration;
        for k in 0..n {
            // u_k = a_d,k − Σ_c K[k, c] e_c, then v⁺ = v + u·dt.
            let feedback: f64 = (0..2 * n).map(|c| (ki[(k, c)] + t * (kj[(k, c)] - ki[(k, c)])) * ws.error[c]).sum();
            let ad = if feedforward { lerp(r.acceleration(i), r.acceleration(j), k) } else { 0.0 };
            command[k] = velocity.map_or(0.0, |v| v[k]) + (ad - feedback) * dt;
        }
    }

    /// Closed-loop rollout of a kinematic arm (`q ← q + q̇·dt`, `q̇` the
    /// policy's command) from rest at `start` for `steps` ticks; returns the
    /// visited configurations, `start` first.
    pub fn rollout(&self, start: &[f64], steps: usize) -> Result<Vec<Vec<f64>>, ControlError> {
        let n = self.reference.dof();
        let dt = self.reference.dt();
        let mut ws = self.workspace();
        let (mut q, mut v, mut command) = (start.to_vec(), vec![0.0; n], vec![0.0; n]);
        let mut path = Vec::with_capacity(steps + 1);
        path.push(q.clone());
        for _ in 0..steps {
            self.query(&mut ws, &q, Some(&v), &mut command)?;
            v.copy_from_slice(&command);
            q.iter_mut().zip(&v).for_each(|(q, v)| *q += v * dt);
            path.push(q.clone());
        }
        Ok(path)
    }

    /// The closest point over the whole reference; of points within a
    /// relative [`TIE`] of the closest, the earliest.
    fn search_all(&self, q: &[f64]) -> PolicyQuery {
        let mut best = self.project(q, 0);
        for segment in 1..self.segments() {
            let p = self.project(q, segment);
            if p.distance < best.distance * (1.0 - TIE) {
                best = p;
            }
        }
        best
    }

    /// Local search from progress `s`: forward while the distance falls
    /// (ties move forward; `patience` segments past the last improvement),
    /// otherwise back by at most `backtrack` of arc length while it falls.
    fn search_from(&self, q: &[f64], s: f64) -> PolicyQuery {
        let first = (s.floor() as usize).min(self.segments() - 1);
        let mut best = self.project(q, first);
        let mut since = 0;
        for segment in first + 1..self.segments() {
            let p = self.project(q, segment);
            if p.distance <= best.distance * (1.0 + TIE) {
                best = p;
                since = 0;
            } else {
                since += 1;
                if since >= self.patience {
                    break;
                }
            }
        }
        if best.progress <= s {
            let lowest = self.arc_at(s) - self.backtrack;
            for segment in (0..first).rev() {
                let p = self.project(q, segment);
                if p.arc_length < lowest || p.distance >= best.distance * (1.0 - TIE) {
                    break;
                }
                best = p;
            }
        }
        best
    }

    /// Number of polyline segments (one for a single-waypoint reference).
    fn segments(&self) -> usize {
        self.reference.len().saturating_sub(1).max(1)
    }

    /// The closest point of segment `i` (waypoints `i` and `i + 1`) to `q`.
    fn project(&self, q: &[f64], i: usize) -> PolicyQuery {
        let r = &self.reference;
        let a = r.position(i);
        let b = r.position((i + 1).min(r.len() - 1));
        let (mut ab2, mut aq_ab) = (0.0, 0.0);
        for k in 0..q.len() {
            let ab = b[k] - a[k];
            ab2 += ab * ab;
            aq_ab += (q[k] - a[k]) * ab;
        }
        let t = if ab2 > 0.0 { (aq_ab / ab2).clamp(0.0, 1.0) } else { 0.0 };
        let d2: f64 = (0..q.len()).map(|k| (q[k] - a[k] - t * (b[k] - a[k])).powi(2)).sum();
        let progress = (i as f64 + t).min((r.len() - 1) as f64);
        let arc_length = self.arc_at(progress);
        PolicyQuery { index: progress.round() as usize, progress, distance: d2.sqrt(), arc_length, target: progress }
    }

    /// Arc length at waypoint coordinate `s` (rad).
    fn arc_at(&self, s: f64) -> f64 {
        let (i, t) = split(s, self.reference.len());
        let j = (i + 1).min(self.arc.len() - 1);
        self.arc[i] + t * (self.arc[j] - self.arc[i])
    }

    /// Joint-space arc length of the whole reference (rad).
    pub fn length(&self) -> f64 {
        self.arc[self.arc.len() - 1]
    }
}

/// Waypoint `i = ⌊s⌋` and fraction `t = s − i` of a waypoint coordinate,
/// with `i + t` clamped to the reference of `len` waypoints.
fn split(s: f64, len: usize) -> (usize, f64) {
    let last = len - 1;
    let i = (s.max(0.0).floor() as usize).min(last);
    if i == last { (i, 0.0) } else { (i, s - i as f64) }
}

fn check_vector(what: &'static str, x: &[f64], n: usize) -> Result<(), ControlError> {
    if x.len() != n {
        return Err(ControlError::WrongLength { what, expected: n, got: x.len() });
    }
    match x.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(ControlError::NonFinite { what, index, value: x[index] }),
    }
}

/// Error dynamics of `n` decoupled double integrators sampled every `dt`,
/// with the tracking weights as `Q = diag(position·I, velocity·I)`, `R = control·I`.
fn double_integrator_problem(
    n: usize,
    dt: f64,
    w: &TrackingWeights,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (a, b) = double_integrator(n, dt);
    let q = DMatrix::from_fn(2 * n, 2 * n, |i, j| match (i == j, i < n) {
        (false, _) => 0.0,
        (true, true) => w.position,
        (true, false) => w.velocity,
    });
    (a, b, q, DMatrix::identity(n, n) * w.control)
}
