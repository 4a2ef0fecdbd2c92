//! `tandem.Problem` and `tandem.ProblemFamily`: problem files (TOML),
//! the shipped problems, MoveIt inputs, and families sampled by id.

use crate::arrays::{Matrix, Vector, pose_matrix, vector};
use crate::collision::PyCollisionModel;
use crate::errors::PyResultExt;
use crate::robot::PyRobotModel;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;
use tandem::problem::{BUILTIN_PROBLEMS, Goal, Problem, ProblemFamily};
use tandem::scene::Shape;

/// A loaded, validated motion problem: robot, scene (obstacles, graspable
/// objects), start configuration, goal, and planner and optimizer
/// settings. Immutable.
#[pyclass(module = "tandem", name = "Problem", frozen)]
pub struct PyProblem {
    pub(crate) problem: Arc<Problem>,
}

impl PyProblem {
    pub(crate) fn new(problem: Problem) -> PyProblem {
        PyProblem { problem: Arc::new(problem) }
    }
}

/// A shape as a dict: name, kind, bounding-box edge lengths (m), world pose.
fn shape_dict<'py>(
    py: Python<'py>,
    name: &str,
    shape: &Shape,
    pose: &nalgebra::IsometryMatrix3<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", name)?;
    d.set_item("shape", shape.kind_name())?;
    d.set_item("size", vector(py, shape.extents().as_slice()))?;
    d.set_item("pose", pose_matrix(py, pose))?;
    Ok(d)
}

#[pymethods]
impl PyProblem {
    /// Loads a problem file (TOML; format in problems/README.md). Relative
    /// paths in it resolve against its folder.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<PyProblem> {
        Ok(PyProblem::new(py.detach(|| Problem::from_file(&path)).py()?))
    }

    /// One of the shipped problems (see :meth:`builtin_names`), embedded
    /// in the package with the Panda: it loads anywhere.
    #[staticmethod]
    fn builtin(name: &str) -> PyResult<PyProblem> {
        Ok(PyProblem::new(Problem::builtin(name).py()?))
    }

    /// Names accepted by :meth:`builtin`.
    #[staticmethod]
    fn builtin_names() -> Vec<&'static str> {
        BUILTIN_PROBLEMS.iter().map(|(name, _)| *name).collect()
    }

    /// Parses problem text as if read from ``origin`` (used in error
    /// messages); relative paths resolve against ``base_dir``, or, without
    /// one, the shipped Panda paths map to the embedded robot.
    #[staticmethod]
    #[pyo3(signature = (text, *, origin="<string>", base_dir=None))]
    fn from_toml(text: &str, origin: &str, base_dir: Option<PathBuf>) -> PyResult<PyProblem> {
        Ok(PyProblem::new(Problem::from_str_with(text, origin, base_dir.as_deref()).py()?))
    }

    /// A problem from MoveIt inputs: URDF + SRDF, a planning scene YAML and
    /// a motion plan request YAML with a joint goal (MotionBenchMaker's
    /// format).
    #[staticmethod]
    fn from_moveit(
        py: Python<'_>,
        urdf: PathBuf,
        srdf: PathBuf,
        scene: PathBuf,
        request: PathBuf,
    ) -> PyResult<PyProblem> {
        Ok(PyProblem::new(py.detach(|| Problem::from_moveit(&urdf, &srdf, &scene, &request)).py()?))
    }

    /// The same problem starting from ``q`` (checked: one finite value per
    /// joint, within the limits).
    fn with_start(&self, q: Vector<'_>) -> PyResult<PyProblem> {
        let q = q.as_slice();
        self.problem.robot.check_configuration(q).py()?;
        if !self.problem.robot.within_limits(q) {
            return Err(crate::errors::ConfigurationError::new_err(format!(
                "start {q:?} is outside the joint limits of {}",
                self.problem.robot.joint_names().join(", ")
            )));
        }
        let mut problem = (*self.problem).clone();
        problem.start = q.to_vec();
        Ok(PyProblem::new(problem))
    }

    /// The same problem with ``points`` (an N × 3 array of float64, m) as
    /// an obstacle named ``name``: a ball of ``point_radius`` (m) at each
    /// point. The points are in the frame ``pose`` (a 4 × 4 homogeneous
    /// matrix, world frame; the identity by default: world points) places,
    /// a depth camera's for instance. Rows with a NaN or infinite value are
    /// dropped. With ``spacing`` (m) the cloud is thinned first by the
    /// minimum-distance filter and the balls grow by the spacing, so that
    /// they still cover every point (docs/point_clouds.md).
    #[pyo3(signature = (points, point_radius, *, name="point_cloud", spacing=None, pose=None))]
    fn with_point_cloud(
        &self,
        py: Python<'_>,
        points: Matrix<'_>,
        point_radius: f64,
        name: &str,
        spacing: Option<f64>,
        pose: Option<Matrix<'_>>,
    ) -> PyResult<PyProblem> {
        use pyo3::exceptions::PyValueError;
        if points.cols != 3 && points.rows > 0 {
            return Err(PyValueError::new_err(format!("points must be N × 3 (x, y, z), got {} columns", points.cols)));
        }
        if !(point_radius.is_finite() && point_radius > 0.0) {
            return Err(PyValueError::new_err(format!("point_radius must be finite and positive, got {point_radius}")));
        }
        let pose = match pose {
            None => nalgebra::IsometryMatrix3::identity(),
            Some(m) => crate::arrays::pose_from_matrix("pose", &m)?,
        };
        let cloud = tandem::point_cloud::PointCloud::from_points(
            (0..points.rows).map(|i| <[f64; 3]>::try_from(points.row(i)).unwrap_or([f64::NAN; 3])),
        );
        let mut problem = (*self.problem).clone();
        py.detach(|| {
            let (cloud, margin) = match spacing {
                Some(spacing) => {
                    let settings = tandem::point_cloud::FilterSettings { spacing, ..Default::default() };
                    let (kept, report) = cloud.filtered(&settings).map_err(|e| PyValueError::new_err(e.message))?;
                    (kept, report.radius_margin)
                }
                None => (cloud, 0.0),
            };
            let obstacle = tandem::scene::Obstacle::point_cloud(name, &cloud, point_radius + margin, pose)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            problem.scene.add_obstacle(obstacle).py()
        })?;
        Ok(PyProblem::new(problem))
    }

    #[getter]
    fn name(&self) -> &str {
        &self.problem.name
    }

    #[getter]
    fn description(&self) -> &str {
        &self.problem.description
    }

    /// Where the problem came from (file path, ``<builtin:NAME>``, …).
    #[getter]
    fn origin(&self) -> &str {
        &self.problem.origin
    }

    /// The robot model (active joints as the problem chose them).
    #[getter]
    fn robot(&self) -> PyRobotModel {
        PyRobotModel::new(self.problem.robot.clone())
    }

    /// Active joint names: the column order of every configuration.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.problem.robot.joint_names().to_vec()
    }

    /// The gripper frame, if the problem names one.
    #[getter]
    fn gripper(&self) -> Option<&str> {
        self.problem.robot_spec.gripper.as_deref()
    }

    /// Start configuration (at rest).
    #[getter]
    fn start<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        vector(py, &self.problem.start)
    }

    /// The goal as a dict: ``{"kind": "joints", "q"}``, ``{"kind": "pose",
    /// "frame", "position", "orientation" (3 × 3 or None), "axis" (0/1/2 or
    /// None), "direction"}``, or ``{"kind": "grasp", "object", "grasp",
    /// "pose"}`` (the grasp frame's world pose, 4 × 4).
    #[getter]
    fn goal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match &self.problem.goal {
            Goal::Joints(q) => {
                d.set_item("kind", "joints")?;
                d.set_item("q", vector(py, q))?;
            }
            Goal::Pose { frame, position, orientation, axis_alignment } => {
                d.set_item("kind", "pose")?;
                d.set_item("frame", frame)?;
                d.set_item("position", vector(py, position.as_slice()))?;
                let rotation = orientation.map(|r| {
                    crate::arrays::matrix_with(py, 3, 3, |o| {
                        (0..9).for_each(|k| o[k] = r.matrix()[(k / 3, k % 3)]);
                    })
                });
                d.set_item("orientation", rotation)?;
                d.set_item("axis", axis_alignment.map(|(axis, _)| axis))?;
                d.set_item("direction", axis_alignment.map(|(_, dir)| vector(py, dir.as_slice())))?;
            }
            Goal::Grasp { object, grasp } => {
                d.set_item("kind", "grasp")?;
                d.set_item("object", object)?;
                d.set_item("grasp", grasp)?;
                d.set_item("pose", self.problem.grasp_target().map(|p| pose_matrix(py, &p)))?;
            }
        }
        Ok(d)
    }

    /// Number of optimized configurations T.
    #[getter]
    fn horizon(&self) -> usize {
        self.problem.optimizer.horizon
    }

    /// Duration of the optimized motion (s).
    #[getter]
    fn duration(&self) -> f64 {
        self.problem.optimizer.duration
    }

    /// The planner's seed (the default of :func:`plan` and :func:`solve`).
    #[getter]
    fn planner_seed(&self) -> u64 {
        self.problem.planner.seed
    }

    /// Fixed obstacles: dicts with ``name``, ``shape`` (box, sphere,
    /// cylinder, capsule, convex), ``size`` (bounding-box edges, m) and
    /// ``pose`` (world, 4 × 4).
    #[getter]
    fn obstacles<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let obstacles = self.problem.scene.obstacles();
        obstacles.iter().map(|o| shape_dict(py, &o.name, &o.shape, &o.pose)).collect()
    }

    /// Graspable objects: as :attr:`obstacles`, plus ``grasps`` (name →
    /// pose in the object frame) and ``attached_to`` (robot frame or None).
    #[getter]
    fn objects<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let objects = self.problem.scene.objects();
        objects
            .iter()
            .map(|o| {
                let d = shape_dict(py, &o.name, &o.shape, &o.pose)?;
                let grasps = PyDict::new(py);
                for g in &o.grasps {
                    grasps.set_item(&g.name, pose_matrix(py, &g.pose))?;
                }
                d.set_item("grasps", grasps)?;
                d.set_item("attached_to", o.attachment.as_ref().map(|a| a.frame.clone()))?;
                Ok(d)
            })
            .collect()
    }

    /// The collision model of the robot in this scene (SRDF pairs disabled,
    /// the problem's padding plus ``padding`` m, contact between the gripper
    /// and a grasp target allowed).
    #[pyo3(signature = (padding=0.0))]
    fn collision_model(&self, py: Python<'_>, padding: f64) -> PyResult<PyCollisionModel> {
        let model = py.detach(|| self.problem.collision_model_padded(padding)).py()?;
        Ok(PyCollisionModel::new(model))
    }

    fn __repr__(&self) -> String {
        format!("Problem(name={:?}, origin={:?})", self.problem.name, self.problem.origin)
    }
}

/// A family of problems around a base problem (random starts, object
/// poses, obstacles): member ``i`` of a run seeded ``seed`` depends on
/// ``(seed, i)`` only.
#[pyclass(module = "tandem", name = "ProblemFamily", frozen)]
pub struct PyProblemFamily {
    family: Arc<ProblemFamily>,
}

#[pymethods]
impl PyProblemFamily {
    /// Loads a family file; its ``base`` problem resolves against the
    /// family file's folder.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<PyProblemFamily> {
        let family = py.detach(|| ProblemFamily::from_file(&path)).py()?;
        Ok(PyProblemFamily { family: Arc::new(family) })
    }

    #[getter]
    fn name(&self) -> &str {
        &self.family.name
    }

    #[getter]
    fn description(&self) -> &str {
        &self.family.description
    }

    /// The base problem the members vary.
    #[getter]
    fn base(&self) -> PyProblem {
        PyProblem::new(self.family.base.clone())
    }

    /// Member ``i`` for run seed ``seed``: the problem ``tandem generate
    /// --seed SEED`` samples as id ``i`` (generation then solves it with its
    /// own seeds and budgets). Its name is ``"{family}#{i}"``.
    #[pyo3(signature = (i, seed=0))]
    fn sample(&self, py: Python<'_>, i: u64, seed: u64) -> PyResult<PyProblem> {
        let sample = py.detach(|| self.family.sample(seed, i)).py()?;
        Ok(PyProblem::new(sample.problem))
    }

    fn __repr__(&self) -> String {
        format!("ProblemFamily(name={:?})", self.family.name)
    }
}
