//! Inverse kinematics, RRT-Connect planning and trajectory optimization
//! from Python. Every call here releases the GIL while it computes.

use crate::arrays::{Vector, rows_matrix};
use crate::collision::PyCollisionModel;
use crate::errors::PyResultExt;
use crate::problem::PyProblem;
use crate::robot::{FrameArg, frame_id};
use nalgebra::{Rotation3, Vector3};
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tandem::collision::CollisionWorkspace;
use tandem::pipeline::{ProblemSolution, SolveSettings, solve_problem};
use tandem::plan::{
    IkSettings, IkTarget, PlanReport, PlanStatus, goal_configurations as rust_goal_configurations, plan_problem,
    solve_ik as rust_solve_ik,
};

/// The outcome of planning a problem with RRT-Connect (+ shortcutting).
#[pyclass(module = "tandem", name = "PlanResult", frozen)]
pub struct PyPlanResult {
    report: PlanReport,
    nq: usize,
}

#[pymethods]
impl PyPlanResult {
    /// ``solved``, ``time_limit``, ``iteration_limit``, ``start_invalid`` or ``goal_invalid``.
    #[getter]
    fn status(&self) -> &'static str {
        self.report.result.status.name()
    }

    #[getter]
    fn solved(&self) -> bool {
        self.report.result.status == PlanStatus::Solved
    }

    /// The shortcut path, start first (M × nq; empty unless solved).
    #[getter]
    fn path<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows_matrix(py, &self.report.path, self.nq)
    }

    /// The raw RRT-Connect path before shortcutting (empty unless solved).
    #[getter]
    fn raw_path<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows_matrix(py, &self.report.result.path, self.nq)
    }

    /// The goal configurations the planner aimed at (K × nq).
    #[getter]
    fn goals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows_matrix(py, &self.report.goals, self.nq)
    }

    /// Whether every edge of ``path`` passed the certified motion check.
    #[getter]
    fn certified(&self) -> bool {
        self.report.certified
    }

    /// RRT-Connect extension rounds.
    #[getter]
    fn iterations(&self) -> usize {
        self.report.result.iterations
    }

    /// Nodes in both trees.
    #[getter]
    fn nodes(&self) -> usize {
        self.report.result.nodes
    }

    /// Planner runs (seeds) it took.
    #[getter]
    fn attempts(&self) -> usize {
        self.report.attempts
    }

    /// Seconds spent on IK and planning, and on shortcutting and certification.
    #[getter]
    fn planning_time(&self) -> f64 {
        self.report.planning_time.as_secs_f64()
    }

    #[getter]
    fn simplify_time(&self) -> f64 {
        self.report.simplify_time.as_secs_f64()
    }

    fn __repr__(&self) -> String {
        format!("PlanResult(status={:?}, waypoints={})", self.status(), self.report.path.len())
    }
}

/// An optimized trajectory and how its solve went.
#[pyclass(module = "tandem", name = "Solution", frozen)]
pub struct PySolution {
    solution: ProblemSolution,
    /// The problem's start configuration: row 0 of ``trajectory``.
    start: Vec<f64>,
}

#[pymethods]
impl PySolution {
    /// ``converged``, ``in_collision``, ``outside_limits``, ``plan_failed``
    /// or the optimizer's termination (``infeasible``, ``iteration_limit``, …).
    #[getter]
    fn status(&self) -> &'static str {
        self.solution.status()
    }

    /// Converged within tolerances, collision-free between slices, within limits.
    #[getter]
    fn converged(&self) -> bool {
        self.solution.converged()
    }

    /// The trajectory ((T + 1) × nq): the start configuration, then the
    /// optimized slices q_1 … q_T, as ``tandem solve`` writes it (see
    /// ``joint_names`` for the columns, ``time_step`` for the spacing).
    #[getter]
    fn trajectory<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows: Vec<Vec<f64>> =
            std::iter::once(self.start.clone()).chain(self.solution.trajectory.iter().cloned()).collect();
        rows_matrix(py, &rows, self.solution.joints.len())
    }

    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.solution.joints.clone()
    }

    /// Seconds between slices.
    #[getter]
    fn time_step(&self) -> f64 {
        self.solution.time_step
    }

    /// ``Σ r²`` of the cost rows at the solution.
    #[getter]
    fn cost(&self) -> f64 {
        self.solution.report.cost
    }

    /// Largest equality violation, and largest inequality violation (≥ 0).
    #[getter]
    fn eq_violation(&self) -> f64 {
        self.solution.report.equality_violation
    }

    #[getter]
    fn ineq_violation(&self) -> f64 {
        self.solution.report.inequality_violation
    }

    /// Collision-free on the motions between slices at the validation resolution.
    #[getter]
    fn collision_free(&self) -> bool {
        self.solution.validation.collision_free
    }

    #[getter]
    fn within_limits(&self) -> bool {
        self.solution.validation.within_limits
    }

    /// Smallest signed distance over the slices (m), None without a collision model.
    #[getter]
    fn min_distance(&self) -> Option<f64> {
        self.solution.validation.min_distance
    }

    /// Optimizer counts: outer iterations, accepted steps, evaluations.
    #[getter]
    fn iterations(&self) -> (usize, usize, usize) {
        let r = &self.solution.report;
        (r.outer_iterations, r.inner_steps, r.evaluations)
    }

    /// Seconds in the optimizer, and in total (preparation, planning,
    /// optimization, validation).
    #[getter]
    fn solve_time(&self) -> f64 {
        self.solution.report.time.as_secs_f64()
    }

    #[getter]
    fn total_time(&self) -> f64 {
        self.solution.total_time.as_secs_f64()
    }

    /// The RRT-Connect run that seeded the optimizer.
    #[getter]
    fn plan(&self) -> PyPlanResult {
        PyPlanResult { report: self.solution.plan.clone(), nq: self.solution.joints.len() }
    }

    /// The report as a dict (the fields of ``tandem solve --json`` but the trajectory).
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let r = &self.solution.report;
        d.set_item("status", self.status())?;
        d.set_item("converged", self.converged())?;
        d.set_item("cost", r.cost)?;
        d.set_item("eq_violation", r.equality_violation)?;
        d.set_item("ineq_violation", r.inequality_violation)?;
        d.set_item("outer_iterations", r.outer_iterations)?;
        d.set_item("inner_steps", r.inner_steps)?;
        d.set_item("evaluations", r.evaluations)?;
        d.set_item("collision_free", self.collision_free())?;
        d.set_item("within_limits", self.within_limits())?;
        d.set_item("min_distance", self.min_distance())?;
        d.set_item("time_step", self.solution.time_step)?;
        d.set_item("solve_time", self.solve_time())?;
        d.set_item("total_time", self.total_time())?;
        d.set_item("plan_status", self.solution.plan.result.status.name())?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Solution(status={:?}, T={}, cost={:.4})",
            self.status(),
            self.solution.trajectory.len(),
            self.solution.report.cost
        )
    }
}

/// Plans ``problem`` with RRT-Connect and shortcutting, as ``tandem plan``:
/// IK for pose and grasp goals, certified edges. ``seed`` defaults to the
/// problem's planner seed. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (problem, seed=None))]
pub(crate) fn plan(py: Python<'_>, problem: &PyProblem, seed: Option<u64>) -> PyResult<PyPlanResult> {
    let p = &problem.problem;
    let report = py.detach(|| plan_problem(p, seed)).py()?;
    Ok(PyPlanResult { report, nq: p.robot.nq() })
}

/// Plans and optimizes ``problem`` as ``tandem solve``: RRT-Connect seeds
/// the KOMO-style optimizer, the result is validated between slices at
/// ``validation_resolution`` (rad). ``horizon`` overrides T.
/// ``initial_guess``: ``"planned"`` (RRT-Connect's path) or ``"straight"``
/// (the straight line to the goal configuration nearest the start, the
/// planned path when that fails), as ``--initial-guess``. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (problem, seed=None, horizon=None, validation_resolution=0.002, initial_guess="planned"))]
pub(crate) fn solve(
    py: Python<'_>,
    problem: &PyProblem,
    seed: Option<u64>,
    horizon: Option<usize>,
    validation_resolution: f64,
    initial_guess: &str,
) -> PyResult<PySolution> {
    let initial_guess = crate::data::parse_initial_guess(initial_guess)?;
    let options = SolveSettings { seed, horizon, validation_resolution, initial_guess };
    let p = &problem.problem;
    let solution = py.detach(|| solve_problem(p, &options)).py()?;
    Ok(PySolution { solution, start: p.start.clone() })
}

/// The configurations ``problem``'s goal asks for: its joint goal, or up
/// to 4 collision-free IK solutions of a pose or grasp goal (K × nq), as
/// the planner aims at them. Raises ``IkError`` when none exists.
#[pyfunction]
#[pyo3(signature = (problem, seed=None))]
pub(crate) fn goal_configurations<'py>(
    py: Python<'py>,
    problem: &PyProblem,
    seed: Option<u64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let p = &problem.problem;
    let goals = py
        .detach(|| {
            let model = p.collision_model()?;
            let mut ws = CollisionWorkspace::new(&model);
            rust_goal_configurations(p, &model, &mut ws, seed.unwrap_or(p.planner.seed))
        })
        .py()?;
    Ok(rows_matrix(py, &goals, p.robot.nq()))
}

/// Inverse kinematics: up to ``count`` distinct collision-free
/// configurations (K × nq) placing ``frame`` at ``position`` (world, m),
/// with ``orientation`` (3 × 3 rotation, world) or its ``axis`` (0, 1, 2
/// for x, y, z) along ``direction`` when given. Damped least squares from
/// ``seed_q`` (default: the neutral configuration), then random restarts
/// drawn from ``seed``. Raises ``IkError`` when no attempt reaches the
/// target, or every one that does collides. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (
    model, frame, position, *, orientation=None, axis=None, direction=None, seed_q=None, count=1,
    seed=0, restarts=50, iterations=150, position_tolerance=1e-5, angle_tolerance=1e-4, damping=1e-3
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_ik<'py>(
    py: Python<'py>,
    model: &PyCollisionModel,
    frame: FrameArg<'_>,
    position: [f64; 3],
    orientation: Option<[[f64; 3]; 3]>,
    axis: Option<usize>,
    direction: Option<[f64; 3]>,
    seed_q: Option<Vector<'_>>,
    count: usize,
    seed: u64,
    restarts: usize,
    iterations: usize,
    position_tolerance: f64,
    angle_tolerance: f64,
    damping: f64,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let robot = model.model.robot().clone();
    let frame = frame_id(&robot, &frame)?;
    let orientation = orientation.map(rotation).transpose()?;
    let axis_alignment = match (axis, direction) {
        (None, None) => None,
        (Some(axis), Some(d)) if axis < 3 => {
            let d = Vector3::from(d);
            if !(d.norm() > 1e-12 && d.iter().all(|v| v.is_finite())) {
                return Err(PyValueError::new_err("direction must be a finite, non-zero 3-vector"));
            }
            Some((axis, d.normalize()))
        }
        _ => return Err(PyValueError::new_err("give axis (0, 1 or 2) and direction together")),
    };
    if position.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("position {position:?} is not finite")));
    }
    let target = IkTarget { frame, position: Vector3::from(position), orientation, axis_alignment };
    let settings = IkSettings { restarts, iterations, position_tolerance, angle_tolerance, damping, seed };
    let start = seed_q.map_or_else(|| robot.neutral_configuration(), |q| q.as_slice().to_vec());
    let collision = &model.model;
    let found = py
        .detach(|| {
            let mut ws = CollisionWorkspace::new(collision);
            rust_solve_ik(collision, &mut ws, &target, &start, count.max(1), &settings)
        })
        .py()?;
    Ok(rows_matrix(py, &found, robot.nq()))
}

/// A rotation from a 3 × 3 matrix (orthonormal with determinant 1, within 1e-6).
fn rotation(m: [[f64; 3]; 3]) -> PyResult<Rotation3<f64>> {
    let r = nalgebra::Matrix3::from_fn(|i, j| m[i][j]);
    let orthonormal = (r.transpose() * r - nalgebra::Matrix3::identity()).norm() < 1e-6;
    if !(orthonormal && r.determinant() > 0.0) {
        return Err(PyValueError::new_err("orientation must be a 3 × 3 rotation matrix"));
    }
    Ok(Rotation3::from_matrix_unchecked(r))
}
