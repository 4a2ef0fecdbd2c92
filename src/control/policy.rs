//! The LQR tracking policy π_R (the seed's Algorithm 1, §3.3.4).

use super::{ControlError, JointTrajectory};
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

/// Per-caller state of policy queries: the index hint of the closest
/// waypoint and scratch space. One per control loop (or thread).
#[derive(Debug, Clone)]
pub struct PolicyWorkspace {
    hint: Option<usize>,
    error: Vec<f64>,
}

/// What one query found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolicyQuery {
    /// Index of the closest reference waypoint.
    pub index: usize,
    /// Joint-space distance to it (rad, Euclidean).
    pub distance: f64,
    /// Index of the waypoint tracked: the closest plus the look-ahead.
    pub target: usize,
}

/// An LQR policy that steers the arm back onto a reference from anywhere
/// nearby: `a = −K (x − x_d) + a_d` on the joint-space double integrator
/// with state `x = [q, q̇]`, integrated over one time step to a joint
/// velocity command. Immutable and `Send + Sync`; queries allocate nothing.
#[derive(Debug, Clone)]
pub struct TrackingPolicy {
    reference: JointTrajectory,
    /// One gain (n × 2n, column-major) or one per waypoint.
    gains: Vec<DMatrix<f64>>,
    /// Half-width of the windowed closest-waypoint search.
    window: usize,
    /// Waypoints between the closest one and the one tracked.
    lookahead: usize,
    feedforward: Feedforward,
}

impl TrackingPolicy {
    /// Builds the policy for `reference` with the given weights.
    ///
    /// # Errors
    /// A weight outside [`WEIGHT_RANGE`](super::WEIGHT_RANGE); a Riccati
    /// failure (not seen within the ranges of weights and time steps: the
    /// double integrator is controllable).
    pub fn new(
        reference: JointTrajectory,
        weights: TrackingWeights,
        schedule: GainSchedule,
    ) -> Result<Self, ControlError> {
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
        let window = (reference.len() / 20).clamp(4, 64);
        Ok(TrackingPolicy { reference, gains, window, lookahead: 1, feedforward: Feedforward::default() })
    }

    /// Chooses the feedforward terms (default [`Feedforward::Velocity`]).
    pub fn with_feedforward(mut self, feedforward: Feedforward) -> Self {
        self.feedforward = feedforward;
        self
    }

    /// Tracks the waypoint `steps` after the closest one (default 1): the
    /// reference segment starts at the closest waypoint (Algorithm 1), and
    /// aiming one step ahead keeps the arm moving along it.
    pub fn with_lookahead(mut self, steps: usize) -> Self {
        self.lookahead = steps;
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
        PolicyWorkspace { hint: None, error: vec![0.0; 2 * self.reference.dof()] }
    }

    /// The velocity command at configuration `q` with current joint velocity
    /// `velocity` (zero when `None`), written into `command` (rad/s or m/s).
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
        let mut found = self.closest(ws, q);
        found.target = (found.index + self.lookahead).min(self.reference.len() - 1);
        let t = found.target;
        let qd = self.reference.position(t);
        // The reference ends at rest on its goal.
        let at_goal = t + 1 == self.reference.len();
        let (vd, ad) = (self.reference.velocity(t), self.reference.acceleration(t));
        for j in 0..n {
            ws.error[j] = q[j] - qd[j];
            let vd = if at_goal { 0.0 } else { vd[j] };
            ws.error[n + j] = velocity.map_or(0.0, |v| v[j]) - vd;
        }
        let k = self.gain(t);
        let dt = self.reference.dt();
        for j in 0..n {
            // u_j = a_d,j − Σ_c K[j, c] e_c, then v⁺ = v + u·dt.
            let feedback: f64 = (0..2 * n).map(|c| k[(j, c)] * ws.error[c]).sum();
            let ad = if at_goal || self.feedforward == Feedforward::Velocity { 0.0 } else { ad[j] };
            let accel = ad - feedback;
            command[j] = velocity.map_or(0.0, |v| v[j]) + accel * dt;
        }
        Ok(found)
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

    /// Closest waypoint: a window around the hint, widened to the whole
    /// reference on the first call or when the best lies on the window edge
    /// (the hint is lost).
    fn closest(&self, ws: &mut PolicyWorkspace, q: &[f64]) -> PolicyQuery {
        let last = self.reference.len() - 1;
        // A hint past the end (a workspace made for another policy) is lost.
        if let Some(hint) = ws.hint.filter(|&h| h <= last) {
            let (lo, hi) = (hint.saturating_sub(self.window), (hint + self.window).min(last));
            let best = self.best_in(q, lo, hi);
            let on_edge = (best.index == lo && lo > 0) || (best.index == hi && hi < last);
            if !on_edge {
                ws.hint = Some(best.index);
                return best;
            }
        }
        let best = self.best_in(q, 0, last);
        ws.hint = Some(best.index);
        best
    }

    fn best_in(&self, q: &[f64], lo: usize, hi: usize) -> PolicyQuery {
        let mut best = PolicyQuery { index: lo, distance: f64::INFINITY, target: lo };
        for i in lo..=hi {
            let d2: f64 = self.reference.position(i).iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            // `<=` prefers the later waypoint on ties, so a resting arm advances.
            if d2 <= best.distance {
                best = PolicyQuery { index: i, distance: d2, target: i };
            }
        }
        best.distance = best.distance.sqrt();
        best
    }
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
