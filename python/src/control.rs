//! `tandem.TrackingPolicy`: LQR tracking policies (the dissertation's
//! Algorithm 1) built from a reference trajectory and queried from Python.

use crate::arrays::{Matrix, Vector, fill_out, matrix_with, rows_matrix};
use crate::errors::PyResultExt;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::Mutex;
use tandem::control::{Feedforward, GainSchedule, PolicyQuery, PolicyWorkspace, TrackingPolicy, TrackingWeights};

/// An LQR policy steering the arm back onto a joint-space reference from
/// anywhere nearby: ``a = −K (x − x_d)`` on the joint-space double
/// integrator with state ``x = [q, q̇]``, integrated over one time step to
/// a joint-velocity command (rad/s or m/s).
///
/// Queries remember the closest waypoint of the previous query (the
/// search is windowed around it); :meth:`reset` forgets it, e.g. between
/// episodes.
#[pyclass(module = "tandem", name = "TrackingPolicy", frozen)]
pub struct PyTrackingPolicy {
    policy: TrackingPolicy,
    workspace: Mutex<PolicyWorkspace>,
}

fn schedule(name: &str) -> PyResult<GainSchedule> {
    match name {
        "constant" => Ok(GainSchedule::Constant),
        "time_varying" => Ok(GainSchedule::TimeVarying),
        other => Err(PyValueError::new_err(format!("schedule must be 'constant' or 'time_varying', got {other:?}"))),
    }
}

fn feedforward(name: &str) -> PyResult<Feedforward> {
    match name {
        "velocity" => Ok(Feedforward::Velocity),
        "acceleration" => Ok(Feedforward::Acceleration),
        other => Err(PyValueError::new_err(format!("feedforward must be 'velocity' or 'acceleration', got {other:?}"))),
    }
}

impl PyTrackingPolicy {
    fn with_workspace<R>(&self, f: impl FnOnce(&mut PolicyWorkspace) -> R) -> R {
        match self.workspace.try_lock() {
            Ok(mut ws) => f(&mut ws),
            Err(_) => f(&mut self.policy.workspace()),
        }
    }

    /// One query into `command`.
    fn query_into(&self, q: &[f64], velocity: Option<&[f64]>, command: &mut [f64]) -> PyResult<PolicyQuery> {
        self.with_workspace(|ws| self.policy.query(ws, q, velocity, command)).py()
    }
}

#[pymethods]
impl PyTrackingPolicy {
    /// Builds the policy for ``reference`` (N × n waypoints, ``dt``
    /// seconds apart, ending at rest on the goal). Weights of the tracking
    /// cost per joint: ``position_weight`` (1/rad²), ``velocity_weight``
    /// (s²/rad²), ``control_weight`` (s⁴/rad²). ``schedule``: one DARE gain
    /// (``"constant"``) or finite-horizon gains along the reference
    /// (``"time_varying"``). ``feedforward``: ``"velocity"`` or
    /// ``"acceleration"``. ``lookahead``: waypoints tracked ahead of the
    /// closest one.
    #[new]
    #[pyo3(signature = (
        reference, dt, *, joints=None, position_weight=100.0, velocity_weight=1.0, control_weight=0.1,
        schedule="constant", feedforward="velocity", lookahead=1
    ))]
    #[allow(clippy::too_many_arguments)]
    fn py_new(
        py: Python<'_>,
        reference: Matrix<'_>,
        dt: f64,
        joints: Option<Vec<String>>,
        position_weight: f64,
        velocity_weight: f64,
        control_weight: f64,
        schedule: &str,
        feedforward: &str,
        lookahead: usize,
    ) -> PyResult<PyTrackingPolicy> {
        let joints = joints.unwrap_or_else(|| (0..reference.cols).map(|j| format!("joint{j}")).collect());
        if joints.len() != reference.cols {
            let (names, cols) = (joints.len(), reference.cols);
            return Err(PyValueError::new_err(format!("{names} joint names for a reference of {cols} columns")));
        }
        let (schedule, feedforward) = (self::schedule(schedule)?, self::feedforward(feedforward)?);
        let weights = TrackingWeights { position: position_weight, velocity: velocity_weight, control: control_weight };
        let waypoints = reference.to_rows();
        let policy = py
            .detach(|| TrackingPolicy::from_waypoints(joints, dt, &waypoints, weights, schedule))
            .py()?
            .with_feedforward(feedforward)
            .with_lookahead(lookahead);
        let workspace = Mutex::new(policy.workspace());
        Ok(PyTrackingPolicy { policy, workspace })
    }

    /// Number of joints.
    #[getter]
    fn dof(&self) -> usize {
        self.policy.reference().dof()
    }

    /// Seconds between waypoints (and the integration step of a command).
    #[getter]
    fn dt(&self) -> f64 {
        self.policy.reference().dt()
    }

    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.policy.reference().joints().to_vec()
    }

    /// The reference waypoints (N × n).
    #[getter]
    fn reference<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let r = self.policy.reference();
        let rows: Vec<Vec<f64>> = (0..r.len()).map(|i| r.position(i).to_vec()).collect();
        rows_matrix(py, &rows, r.dof())
    }

    /// The gain applied at waypoint ``index``: n × 2n (position columns,
    /// then velocity columns).
    #[pyo3(signature = (index=0))]
    fn gain<'py>(&self, py: Python<'py>, index: usize) -> Bound<'py, PyArray2<f64>> {
        let k = self.policy.gain(index);
        matrix_with(py, k.nrows(), k.ncols(), |o| {
            for (i, row) in o.chunks_exact_mut(k.ncols().max(1)).enumerate() {
                row.iter_mut().enumerate().for_each(|(j, v)| *v = k[(i, j)]);
            }
        })
    }

    /// The velocity command (n) at configuration ``q`` with joint velocity
    /// ``velocity`` (zero when None). ``out``: a float64 array of n values
    /// to write into instead of allocating.
    #[pyo3(signature = (q, velocity=None, *, out=None))]
    fn query<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        velocity: Option<Vector<'_>>,
        out: Option<Bound<'py, PyArray1<f64>>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let n = self.dof();
        let velocity = velocity.as_ref().map(Vector::as_slice);
        let Some(out) = out else {
            let mut command = vec![0.0; n];
            self.query_into(q.as_slice(), velocity, &mut command)?;
            return Ok(PyArray1::from_vec(py, command));
        };
        fill_out(&out, &[n], |command| self.query_into(q.as_slice(), velocity, command))?;
        Ok(out)
    }

    /// Like :meth:`query`, also returning what the query found: the
    /// closest point of the reference as a waypoint coordinate (waypoint
    /// ``floor(s)`` plus the fraction ``s - floor(s)`` of the segment to the
    /// next), the joint-space distance to it (rad) and the coordinate of the
    /// point tracked.
    #[pyo3(signature = (q, velocity=None))]
    fn query_with_info<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        velocity: Option<Vector<'_>>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, f64, f64, f64)> {
        let mut command = vec![0.0; self.dof()];
        let found = self.query_into(q.as_slice(), velocity.as_ref().map(Vector::as_slice), &mut command)?;
        Ok((PyArray1::from_vec(py, command), found.progress, found.distance, found.target))
    }

    /// Forgets the closest waypoint remembered from earlier queries.
    fn reset(&self) {
        self.with_workspace(|ws| *ws = self.policy.workspace());
    }

    /// Closed-loop rollout of a kinematic arm (``q ← q + q̇·dt``, ``q̇`` the
    /// policy's command) from rest at ``start`` for ``steps`` ticks: the
    /// visited configurations, ``start`` first ((steps + 1) × n). Releases
    /// the GIL.
    fn rollout<'py>(&self, py: Python<'py>, start: Vector<'_>, steps: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let start = start.as_slice().to_vec(); // read while the GIL is held
        let path = py.detach(|| self.policy.rollout(&start, steps)).py()?;
        Ok(rows_matrix(py, &path, self.dof()))
    }

    fn __repr__(&self) -> String {
        let r = self.policy.reference();
        format!("TrackingPolicy(dof={}, waypoints={}, dt={})", r.dof(), r.len(), r.dt())
    }
}
