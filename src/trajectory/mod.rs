//! Joint trajectories: the one trajectory type every layer above uses — a
//! planner's path resampled, an optimizer's result, a tracking policy's
//! reference, a file written by `tandem solve` and read by `tandem policy`.
//!
//! A [`JointTrajectory`] is `q_0 … q_T` sampled every `dt` seconds, `q_0`
//! the start configuration at time 0 (as MoveIt trajectories begin at the
//! start state), with the velocities and accelerations a tracking
//! controller feeds forward (backward differences; both zero at the start).
//!
//! Its files (see [`files`](self#files)):
//! - **CSV**: a header `time,<joint>,…` (the active joint names, the order
//!   of every row), then one row per configuration: its time `k · dt` (s)
//!   and the joint values (rad or m). Times start at 0 and are evenly
//!   spaced. A joint name holding a comma, a quote or a line break, white
//!   space at either end, or reading as a number is quoted as RFC 4180
//!   says ([`files::csv`](crate::files::csv)). No header, duplicate joint names, rows of another length,
//!   non-numbers and non-finite values are errors naming the file, line
//!   and column.
//! - **Parquet** (with the `data` feature): columns `time` (f64) and one
//!   f64 column per joint, the same rows, Snappy-compressed.
//!
//! # Files
//! [`JointTrajectory::to_csv`], [`JointTrajectory::write_csv`],
//! [`JointTrajectory::read_csv`], [`JointTrajectory::from_csv_str`] and,
//! with the `data` feature, `JointTrajectory::write_parquet`.
//!
//! ```
//! use tandem::trajectory::JointTrajectory;
//! let joints = vec!["j1".to_string(), "j2".to_string()];
//! let t = JointTrajectory::new(joints, 0.1, &[vec![0.0, 0.0], vec![0.1, -0.2], vec![0.2, -0.3]])?;
//! assert!((t.velocity(1)[1] + 2.0).abs() < 1e-12);
//! let text = t.to_csv();
//! assert!(text.starts_with("time,j1,j2\n0,0,0\n"));
//! assert_eq!(JointTrajectory::from_csv_str(&text, "<example>")?, t);
//! # Ok::<(), tandem::trajectory::TrajectoryError>(())
//! ```

mod csv;

use crate::files::FileError;
use crate::settings::readable;
use thiserror::Error;

/// Most waypoints of a trajectory (`T + 1` for the largest horizon T a
/// problem may ask, [`MAX_HORIZON`](crate::problem::MAX_HORIZON)).
pub const MAX_WAYPOINTS: usize = 100_001;
/// Most joints of a trajectory: every robot tandem loads fits (the
/// largest tested has 100); a tracking policy allows fewer
/// ([`MAX_REFERENCE_JOINTS`](crate::control::MAX_REFERENCE_JOINTS)).
pub const MAX_JOINTS: usize = 1024;

/// Errors building, reading or writing a trajectory.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum TrajectoryError {
    /// A time step that is not finite and positive.
    #[error("time step {} s is not finite and positive", readable(*dt))]
    InvalidTimeStep {
        /// Time step (s).
        dt: f64,
    },
    /// A duration that is not positive and finite.
    #[error("duration {} s is not positive and finite", readable(*duration))]
    InvalidDuration {
        /// The duration (s).
        duration: f64,
    },
    /// A trajectory with no waypoint or no joint.
    #[error("the reference has no waypoint or no joint")]
    Empty,
    /// More than [`MAX_JOINTS`] joints.
    #[error("the reference has {count} joints, more than {MAX_JOINTS}")]
    TooManyJoints {
        /// How many joints it has.
        count: usize,
    },
    /// More than [`MAX_WAYPOINTS`] waypoints.
    #[error("the reference would have {count} waypoints, more than {MAX_WAYPOINTS}")]
    TooManyWaypoints {
        /// How many waypoints it would have.
        count: f64,
    },
    /// A waypoint with the wrong number of values.
    #[error("waypoint {index} has {got} values, expected {expected}")]
    WaypointLength {
        /// Index of the waypoint.
        index: usize,
        /// The length it should have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// A waypoint holding NaN or an infinity.
    #[error("waypoint {index}: joint '{joint}' has non-finite value {value}")]
    NonFiniteWaypoint {
        /// Index of the waypoint.
        index: usize,
        /// The joint's name.
        joint: String,
        /// The offending value.
        value: f64,
    },
    /// Waypoints so far apart that a velocity or acceleration overflows.
    #[error(
        "waypoint {index}: joint '{joint}' moves from {} to {} in {} s, a velocity or acceleration too large to represent",
        readable(*from),
        readable(*to),
        readable(*dt)
    )]
    Overflow {
        /// Index of the waypoint.
        index: usize,
        /// The joint's name.
        joint: String,
        /// Value at the waypoint before (rad or m).
        from: f64,
        /// Value at the waypoint (rad or m).
        to: f64,
        /// Time step (s).
        dt: f64,
    },
    /// A malformed trajectory CSV: the file (or `<string>`), its 1-based
    /// line, and what is wrong there.
    #[error("{origin}:{line}: {message}")]
    Csv {
        /// The file, or `<string>`.
        origin: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A file that cannot be read or written.
    #[error(transparent)]
    File(#[from] FileError),
}

/// A joint trajectory `q_0 … q_T` sampled every `dt` seconds, with
/// velocities and accelerations from backward differences (the first
/// velocity and acceleration are zero, as in the dissertation's
/// Algorithm 1, §3.3.4).
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
    /// A trajectory of `waypoints` (one slice of `joints.len()` values each,
    /// the start first), `dt` seconds apart.
    ///
    /// # Errors
    /// No waypoint or joint, more than [`MAX_WAYPOINTS`] or [`MAX_JOINTS`],
    /// a waypoint of the wrong length, a non-finite value, values so far
    /// apart that a velocity or acceleration overflows, or a `dt` that is
    /// not finite and positive.
    pub fn new(joints: Vec<String>, dt: f64, waypoints: &[Vec<f64>]) -> Result<Self, TrajectoryError> {
        let n = joints.len();
        check_time_step(dt)?;
        if waypoints.is_empty() || n == 0 {
            return Err(TrajectoryError::Empty);
        }
        if n > MAX_JOINTS {
            return Err(TrajectoryError::TooManyJoints { count: n });
        }
        if waypoints.len() > MAX_WAYPOINTS {
            return Err(TrajectoryError::TooManyWaypoints { count: waypoints.len() as f64 });
        }
        let mut q = Vec::with_capacity(waypoints.len() * n);
        for (i, w) in waypoints.iter().enumerate() {
            if w.len() != n {
                return Err(TrajectoryError::WaypointLength { index: i, expected: n, got: w.len() });
            }
            if let Some(k) = w.iter().position(|x| !x.is_finite()) {
                return Err(TrajectoryError::NonFiniteWaypoint { index: i, joint: joints[k].clone(), value: w[k] });
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
            return Err(TrajectoryError::Overflow { index, joint: joints[k].clone(), from, to, dt });
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
    ) -> Result<Self, TrajectoryError> {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(TrajectoryError::InvalidDuration { duration });
        }
        check_time_step(dt)?;
        let steps = (duration / dt).round().max(1.0);
        if steps + 1.0 > MAX_WAYPOINTS as f64 {
            return Err(TrajectoryError::TooManyWaypoints { count: steps + 1.0 });
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

    /// Joint names, in the order of every waypoint.
    pub fn joints(&self) -> &[String] {
        &self.joints
    }

    /// Number of joints `n`.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Number of waypoints `T + 1`.
    pub fn len(&self) -> usize {
        self.q.len() / self.dof()
    }

    /// Never true: a trajectory has at least one waypoint.
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

    /// The waypoints in order, the start first (rad or m).
    pub fn positions(&self) -> impl ExactSizeIterator<Item = &[f64]> {
        self.q.chunks(self.dof())
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

fn check_time_step(dt: f64) -> Result<(), TrajectoryError> {
    if dt.is_finite() && dt > 0.0 { Ok(()) } else { Err(TrajectoryError::InvalidTimeStep { dt }) }
}

/// `d[i] = (x[i] − x[i−1]) / dt`, `d[0] = 0`, per joint.
fn backward_difference(x: &[f64], n: usize, dt: f64) -> Vec<f64> {
    let mut d = vec![0.0; x.len()];
    for i in n..x.len() {
        d[i] = (x[i] - x[i - n]) / dt;
    }
    d
}
