//! Joint-space reference trajectories: waypoints at a fixed time step, with
//! the velocities and accelerations a tracking controller feeds forward.

use super::ControlError;
use std::path::Path;

/// A reference `ξ_ref = (q_0 … q_{T−1})` sampled every `dt` seconds, with
/// velocities and accelerations from backward differences (the first
/// velocity and acceleration are zero, as in the seed's Algorithm 1).
///
/// Stored row-major: waypoint `i` is `q[i·n .. (i+1)·n]` (rad or m).
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    joints: Vec<String>,
    dt: f64,
    q: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
}

impl JointTrajectory {
    /// Builds a reference from waypoints (one slice of `joints.len()` values each).
    ///
    /// # Errors
    /// No waypoint or joint, more than [`MAX_WAYPOINTS`](super::MAX_WAYPOINTS)
    /// or [`MAX_REFERENCE_JOINTS`](super::MAX_REFERENCE_JOINTS),
    /// a waypoint of the wrong length, a non-finite value, values so far
    /// apart that a velocity or acceleration overflows, or `dt` outside
    /// [`MIN_TIME_STEP`](super::MIN_TIME_STEP) ..= [`MAX_TIME_STEP`](super::MAX_TIME_STEP).
    pub fn new(joints: Vec<String>, dt: f64, waypoints: &[Vec<f64>]) -> Result<Self, ControlError> {
        let n = joints.len();
        check_time_step(dt)?;
        if waypoints.is_empty() || n == 0 {
            return Err(ControlError::EmptyReference);
        }
        if n > super::MAX_REFERENCE_JOINTS {
            return Err(ControlError::TooManyJoints { count: n });
        }
        if waypoints.len() > super::MAX_WAYPOINTS {
            return Err(ControlError::TooManyWaypoints { count: waypoints.len() as f64 });
        }
        let mut q = Vec::with_capacity(waypoints.len() * n);
        for (i, w) in waypoints.iter().enumerate() {
            if w.len() != n {
                return Err(ControlError::WaypointLength { index: i, expected: n, got: w.len() });
            }
            if let Some(k) = w.iter().position(|x| !x.is_finite()) {
                return Err(ControlError::NonFiniteWaypoint { index: i, joint: joints[k].clone(), value: w[k] });
            }
            q.extend_from_slice(w);
        }
        let v = backward_difference(&q, n, dt);
        let a = backward_difference(&v, n, dt);
        // The first waypoint whose velocity or acceleration overflowed.
        if let Some(at) = v.iter().zip(&a).position(|(v, a)| !(v.is_finite() && a.is_finite())) {
            // Entries of waypoint 0 are 0: `index` ≥ 1.
            let (index, k) = (at / n, at % n);
            let (from, to) = (q[(index - 1) * n + k], q[index * n + k]);
            return Err(ControlError::Overflow { index, joint: joints[k].clone(), from, to, dt });
        }
        Ok(JointTrajectory { joints, dt, q, v, a })
    }

    /// A minimum-jerk motion from `start` to `goal` over `duration` seconds,
    /// sampled every `dt` (both ends included): a smooth stand-in reference
    /// until an optimized one is available.
    ///
    /// # Errors
    /// As [`new`](Self::new); a duration that is not positive and finite.
    pub fn minimum_jerk(
        joints: Vec<String>,
        start: &[f64],
        goal: &[f64],
        duration: f64,
        dt: f64,
    ) -> Result<Self, ControlError> {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(ControlError::InvalidDuration { duration });
        }
        check_time_step(dt)?;
        let steps = (duration / dt).round().max(1.0);
        if steps + 1.0 > super::MAX_WAYPOINTS as f64 {
            return Err(ControlError::TooManyWaypoints { count: steps + 1.0 });
        }
        let steps = steps as usize;
        let waypoints: Vec<Vec<f64>> = (0..=steps)
            .map(|i| {
                let s = i as f64 / steps as f64;
                let blend = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
                start.iter().zip(goal).map(|(a, b)| a + (b - a) * blend).collect()
            })
            .collect();
        Self::new(joints, dt, &waypoints)
    }

    /// Reads a trajectory CSV file (the format of
    /// [`TrajectoryTable`](crate::data::TrajectoryTable): a `time` column
    /// then one column per joint, the start first); the time step is the
    /// spacing of its `time` column.
    ///
    /// # Errors
    /// A file that cannot be read or parsed (naming the line), or any
    /// error of [`new`](Self::new).
    pub fn from_csv(path: &Path) -> Result<Self, ControlError> {
        let table = crate::data::TrajectoryTable::read_csv(path)?;
        Self::new(table.joints, table.time_step, &table.configurations)
    }

    /// Joint names, in the order of every waypoint.
    pub fn joints(&self) -> &[String] {
        &self.joints
    }

    /// Number of joints `n`.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Number of waypoints `T`.
    pub fn len(&self) -> usize {
        self.q.len() / self.dof()
    }

    /// Never true: a reference has at least one waypoint.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// Time step between waypoints (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Waypoint `i` (rad or m).
    pub fn position(&self, i: usize) -> &[f64] {
        &self.q[i * self.dof()..(i + 1) * self.dof()]
    }

    /// Velocity at waypoint `i` (rad/s or m/s).
    pub fn velocity(&self, i: usize) -> &[f64] {
        &self.v[i * self.dof()..(i + 1) * self.dof()]
    }

    /// Acceleration at waypoint `i` (rad/s² or m/s²).
    pub fn acceleration(&self, i: usize) -> &[f64] {
        &self.a[i * self.dof()..(i + 1) * self.dof()]
    }

    /// The last waypoint: the goal.
    pub fn goal(&self) -> &[f64] {
        self.position(self.len() - 1)
    }
}

fn check_time_step(dt: f64) -> Result<(), ControlError> {
    if (super::MIN_TIME_STEP..=super::MAX_TIME_STEP).contains(&dt) {
        Ok(())
    } else {
        Err(ControlError::InvalidTimeStep { dt })
    }
}

/// `d[i] = (x[i] − x[i−1]) / dt`, `d[0] = 0`, per joint.
fn backward_difference(x: &[f64], n: usize, dt: f64) -> Vec<f64> {
    let mut d = vec![0.0; x.len()];
    for i in n..x.len() {
        d[i] = (x[i] - x[i - n]) / dt;
    }
    d
}
