//! `tandem.CollisionModel`: collision checks, signed distances with their
//! gradients, and motion validation from Python.

use crate::arrays::{Matrix, Vector, check_columns, vector};
use crate::errors::PyResultExt;
use crate::robot::PyRobotModel;
use numpy::PyArray1;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use tandem::collision::{CollisionModel, CollisionWorkspace, PairDistance};
use tandem::robot::{RobotError, Srdf};

/// The robot (and its scene, for a problem's model) as collision geometry
/// with the pairs to check. Distances are signed (m, negative when
/// penetrating) between padded shapes. Immutable; safe to share between
/// threads. Build one with ``problem.collision_model()`` (robot + scene)
/// or ``CollisionModel(robot)`` (self-collision only).
#[pyclass(module = "tandem", name = "CollisionModel", frozen)]
pub struct PyCollisionModel {
    pub(crate) model: Arc<CollisionModel>,
    scratch: Mutex<CollisionWorkspace>,
}

/// The signed distance of one pair: witness points on each body, the unit
/// normal from ``point_a`` to ``point_b`` (world, m), and — when asked —
/// the gradient of the distance with respect to ``q`` (1/rad or 1/m).
#[pyclass(module = "tandem", name = "Distance", frozen, get_all)]
pub struct PyDistance {
    /// Index of the pair in ``CollisionModel.pairs``.
    pair: usize,
    /// Names of the two bodies (link, obstacle or object), robot side first.
    bodies: (String, String),
    /// Signed distance (m): positive apart, negative penetrating.
    distance: f64,
    point_a: Py<PyArray1<f64>>,
    point_b: Py<PyArray1<f64>>,
    normal: Py<PyArray1<f64>>,
    gradient: Option<Py<PyArray1<f64>>>,
}

#[pymethods]
impl PyDistance {
    fn __repr__(&self) -> String {
        format!("Distance({} – {}: {:.6} m)", self.bodies.0, self.bodies.1, self.distance)
    }
}

impl PyCollisionModel {
    pub(crate) fn new(model: CollisionModel) -> PyCollisionModel {
        let scratch = Mutex::new(CollisionWorkspace::new(&model));
        PyCollisionModel { model: Arc::new(model), scratch }
    }

    fn with_scratch<R>(&self, f: impl FnOnce(&mut CollisionWorkspace) -> R) -> R {
        match self.scratch.try_lock() {
            Ok(mut ws) => f(&mut ws),
            Err(_) => f(&mut CollisionWorkspace::new(&self.model)),
        }
    }

    /// A distance as a Python object, its gradient from `ws` (the workspace
    /// of the query that found it) when `gradient` is set.
    fn distance(
        &self,
        py: Python<'_>,
        ws: &CollisionWorkspace,
        d: &PairDistance,
        gradient: bool,
    ) -> PyResult<PyDistance> {
        let (a, b) = self.model.pair_names(d.pair);
        let gradient = if gradient {
            let mut g = vec![0.0; self.model.robot().nq()];
            self.model.distance_gradient(ws, d, &mut g).py()?;
            Some(PyArray1::from_vec(py, g).unbind())
        } else {
            None
        };
        let s = &d.signed;
        Ok(PyDistance {
            pair: d.pair,
            bodies: (a.to_string(), b.to_string()),
            distance: s.distance,
            point_a: vector(py, s.point_a.coords.as_slice()).unbind(),
            point_b: vector(py, s.point_b.coords.as_slice()).unbind(),
            normal: vector(py, s.normal.as_slice()).unbind(),
            gradient,
        })
    }
}

#[pymethods]
impl PyCollisionModel {
    /// Self-collision model of ``robot`` with its own URDF collision
    /// geometry: every pair of links on different bodies that are not
    /// parent and child, minus the pairs an SRDF file disables; robot
    /// shapes inflated by ``padding`` (m).
    #[new]
    #[pyo3(signature = (robot, *, srdf=None, padding=0.0))]
    fn py_new(robot: &PyRobotModel, srdf: Option<PathBuf>, padding: f64) -> PyResult<PyCollisionModel> {
        let mut builder = CollisionModel::builder(robot.model.clone()).padding(padding);
        if let Some(path) = srdf {
            let srdf = Srdf::from_srdf_file(path).py()?;
            srdf.check_against(robot.model.description()).py()?;
            builder = builder.srdf(&srdf);
        }
        Ok(PyCollisionModel::new(builder.build().py()?))
    }

    /// The robot model the configurations refer to.
    #[getter]
    fn robot(&self) -> PyRobotModel {
        PyRobotModel::new(self.model.robot().clone())
    }

    /// Padding of the robot shapes (m).
    #[getter]
    fn padding(&self) -> f64 {
        self.model.padding()
    }

    /// The checked pairs as (body a, body b) names, in pair index order.
    #[getter]
    fn pairs(&self) -> Vec<(String, String)> {
        (0..self.model.pair_count())
            .map(|i| {
                let (a, b) = self.model.pair_names(i);
                (a.to_string(), b.to_string())
            })
            .collect()
    }

    /// True when no checked pair touches at ``q``.
    fn collision_free(&self, q: Vector<'_>) -> PyResult<bool> {
        self.with_scratch(|ws| self.model.collision_free(ws, q.as_slice())).py()
    }

    /// The closest pair at ``q`` (the deepest when penetrating), or None
    /// when the model checks no pair; with its gradient if ``gradient``.
    #[pyo3(signature = (q, *, gradient=false))]
    fn min_distance(&self, py: Python<'_>, q: Vector<'_>, gradient: bool) -> PyResult<Option<PyDistance>> {
        self.with_scratch(|ws| {
            let closest = self.model.min_distance(ws, q.as_slice()).py()?;
            closest.map(|d| self.distance(py, ws, &d, gradient)).transpose()
        })
    }

    /// Every pair closer than ``cutoff`` (m; all pairs by default) at
    /// ``q``, in pair order, with gradients if ``gradients``.
    #[pyo3(signature = (q, cutoff=f64::INFINITY, *, gradients=false))]
    fn distances(&self, py: Python<'_>, q: Vector<'_>, cutoff: f64, gradients: bool) -> PyResult<Vec<PyDistance>> {
        self.with_scratch(|ws| {
            let found = self.model.distances(ws, q.as_slice(), cutoff).py()?.to_vec();
            found.iter().map(|d| self.distance(py, ws, d, gradients)).collect()
        })
    }

    /// True when the straight joint-space motion from ``q0`` to ``q1`` is
    /// collision-free, checked so that no joint moves more than
    /// ``resolution`` (rad or m) between checks.
    #[pyo3(signature = (q0, q1, resolution=0.005))]
    fn motion_free(&self, q0: Vector<'_>, q1: Vector<'_>, resolution: f64) -> PyResult<bool> {
        self.with_scratch(|ws| self.model.motion_free(ws, q0.as_slice(), q1.as_slice(), resolution)).py()
    }

    /// Certified check of the motion from ``q0`` to ``q1``: True only if
    /// every configuration on it keeps every pair ``clearance / 2`` (m) apart.
    fn motion_free_certified(&self, q0: Vector<'_>, q1: Vector<'_>, clearance: f64) -> PyResult<bool> {
        self.with_scratch(|ws| self.model.motion_free_certified(ws, q0.as_slice(), q1.as_slice(), clearance)).py()
    }

    /// True when every edge of ``path`` (N × nq) is collision-free at
    /// ``resolution``. Releases the GIL.
    #[pyo3(signature = (path, resolution=0.005))]
    fn path_free(&self, py: Python<'_>, path: Matrix<'_>, resolution: f64) -> PyResult<bool> {
        check_columns("path", &path, self.model.robot().nq())?;
        let (model, rows) = (&self.model, path.to_rows());
        py.detach(|| {
            let mut ws = CollisionWorkspace::new(model);
            if rows.len() == 1 {
                return model.collision_free(&mut ws, &rows[0]);
            }
            for edge in rows.windows(2) {
                if !model.motion_free(&mut ws, &edge[0], &edge[1], resolution)? {
                    return Ok(false);
                }
            }
            Ok(true)
        })
        .py()
    }

    /// ``collision_free`` of each row of ``qs`` (N × nq): a bool array.
    /// Releases the GIL.
    fn collision_free_many<'py>(&self, py: Python<'py>, qs: Matrix<'_>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let n = self.model.robot().nq();
        check_columns("qs", &qs, n)?;
        let (model, data) = (&self.model, qs.as_slice());
        let free = py.detach(|| {
            let mut ws = CollisionWorkspace::new(model);
            data.chunks_exact(n.max(1)).map(|q| model.collision_free(&mut ws, q)).collect::<Result<Vec<bool>, _>>()
        });
        Ok(PyArray1::from_vec(py, free.py()?))
    }

    /// Smallest signed distance (m) at each row of ``qs`` (N × nq); inf
    /// when the model checks no pair. Releases the GIL.
    fn min_distances<'py>(&self, py: Python<'py>, qs: Matrix<'_>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let n = self.model.robot().nq();
        check_columns("qs", &qs, n)?;
        let (model, data) = (&self.model, qs.as_slice());
        let distances = py.detach(|| {
            let mut ws = CollisionWorkspace::new(model);
            data.chunks_exact(n.max(1))
                .map(|q| Ok(model.min_distance(&mut ws, q)?.map_or(f64::INFINITY, |d| d.signed.distance)))
                .collect::<Result<Vec<f64>, RobotError>>()
        });
        Ok(PyArray1::from_vec(py, distances.py()?))
    }

    fn __repr__(&self) -> String {
        format!(
            "CollisionModel(robot={:?}, pairs={})",
            self.model.robot().description().name(),
            self.model.pair_count()
        )
    }
}
