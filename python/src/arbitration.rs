//! `tandem.Arbiter`: one shared-control tick from Python — the operator's
//! command blended with the robot policies under hard limits and distances
//! (the Rust `tandem::arbitration`).

use crate::arrays::{Vector, fill_out};
use crate::errors::{ArbitrationError, PyResultExt};
use crate::problem::PyProblem;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, Mutex};
use tandem::arbitration::{
    Arbiter, ArbiterSettings, ArbiterWorkspace, ArbitrationMode, GoalSettings, HumanCommand, TickInput, problem_goals,
};
use tandem::learn::ArbitrationActor;

/// The arbiter of a problem: one goal per graspable object (or the
/// problem's goal), each with an optimized reference and an LQR tracking
/// policy, blended with the operator's commands by ``mode`` (``direct``,
/// ``blend-timid``, ``blend-aggressive``, ``avoid``, ``natural-gradient``,
/// ``natural-gradient-joint``, ``constrained``, ``sos``, ``learned`` with
/// ``actor``) every ``period``
/// seconds, under joint position and velocity limits and distances of at
/// least ``margin`` metres.
///
/// A tick never raises for bad numbers: a NaN or wrongly sized command
/// returns zero velocity and a status saying why (``invalid_command``, …).
#[pyclass(module = "tandem", name = "Arbiter", frozen)]
pub struct PyArbiter {
    arbiter: Arbiter,
    workspace: Mutex<ArbiterWorkspace>,
}

/// What a tick returns to Python: the joint velocity, the status, the diagnostics.
type TickResult<'py> = (Bound<'py, PyArray1<f64>>, &'static str, Bound<'py, PyDict>);

fn mode(name: &str) -> PyResult<ArbitrationMode> {
    name.parse::<ArbitrationMode>().map_err(|e| ArbitrationError::new_err(e.to_string()))
}

#[pymethods]
impl PyArbiter {
    /// Prepares the goals of ``problem`` (optimizing their references:
    /// milliseconds each; the GIL is released) and the arbiter.
    /// ``actor``: a trained arbitration actor file (``tandem learn
    /// arbitration``), needed by ``mode="learned"``. ``sos_center`` and
    /// ``constrained_center``: κ of sum-of-squares' preferred step and of
    /// the constrained trust region's centre, κ times the robot's action
    /// (default 0, the dissertation's eq. 5.4 and 5.3).
    #[new]
    #[pyo3(signature = (
        problem, *, mode="sos", period=1.0 / 15.0, margin=0.005, seed=None, actor=None, sos_center=0.0,
        constrained_center=0.0
    ))]
    #[allow(clippy::too_many_arguments)]
    fn py_new(
        py: Python<'_>,
        problem: &PyProblem,
        mode: &str,
        period: f64,
        margin: f64,
        seed: Option<u64>,
        actor: Option<std::path::PathBuf>,
        sos_center: f64,
        constrained_center: f64,
    ) -> PyResult<Self> {
        let mode = self::mode(mode)?;
        let mut settings = ArbiterSettings { period, ..ArbiterSettings::default() };
        settings.safety.margin = margin;
        settings.modes.sum_of_squares_center = sos_center;
        settings.modes.constrained_center = constrained_center;
        let p = &problem.problem;
        let actor = match actor {
            Some(path) => {
                Some(Arc::new(ArbitrationActor::load(&path).map_err(|e| ArbitrationError::new_err(e.to_string()))?))
            }
            None => None,
        };
        let arbiter = py
            .detach(|| {
                let goals = problem_goals(p, &GoalSettings { seed, ..GoalSettings::default() })?;
                let mut arbiter = Arbiter::for_problem(p, &goals, settings)?;
                if let Some(actor) = actor {
                    arbiter = arbiter.with_arbitration_policy(actor)?;
                }
                arbiter.with_settings(ArbiterSettings { mode, ..settings })
            })
            .py()?;
        let workspace = Mutex::new(arbiter.workspace());
        Ok(PyArbiter { arbiter, workspace })
    }

    /// One tick: the joint velocity (rad/s or m/s) to apply for one
    /// period, its status and diagnostics. ``command`` is the gripper's
    /// linear velocity (``kind="linear"``, 3 values, m/s, world axes), its
    /// twist (``"twist"``, 6 values, linear first, rad/s) or joint
    /// velocities (``"joint"``). ``velocity`` is the arm's current joint
    /// velocity (default: the last command); ``beliefs`` overrides the
    /// intent estimate (one per goal). ``out`` receives the velocity
    /// without allocating.
    #[pyo3(signature = (q, command, *, kind="linear", velocity=None, beliefs=None, out=None))]
    #[allow(clippy::too_many_arguments)]
    fn tick<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        command: Vector<'_>,
        kind: &str,
        velocity: Option<Vector<'_>>,
        beliefs: Option<Vector<'_>>,
        out: Option<Bound<'py, PyArray1<f64>>>,
    ) -> PyResult<TickResult<'py>> {
        let values = command.as_slice();
        let human = match kind {
            "linear" => HumanCommand::Linear(values),
            "twist" => HumanCommand::Twist(values),
            "joint" => HumanCommand::Joint(values),
            other => {
                return Err(ArbitrationError::new_err(format!(
                    "kind must be 'linear', 'twist' or 'joint', got {other:?}"
                )));
            }
        };
        let input = TickInput {
            q: q.as_slice(),
            velocity: velocity.as_ref().map(Vector::as_slice),
            command: human,
            beliefs: beliefs.as_ref().map(Vector::as_slice),
        };
        let mut ws =
            self.workspace.lock().map_err(|_| ArbitrationError::new_err("the arbiter's workspace is poisoned"))?;
        let result = self.arbiter.tick(&mut ws, &input);
        let (status, d) = (result.status, result.diagnostics);
        let n = self.arbiter.robot().nq();
        let out = match out {
            Some(out) => out,
            None => PyArray1::zeros(py, n, false),
        };
        fill_out(&out, &[n], |o| {
            o.copy_from_slice(result.qdot);
            Ok(())
        })?;
        let diagnostics = PyDict::new(py);
        diagnostics.set_item("mode", d.mode.as_str())?;
        diagnostics.set_item("goal", d.goal)?;
        diagnostics.set_item("confidence", d.confidence)?;
        diagnostics.set_item("alpha", d.alpha)?;
        diagnostics.set_item("active_rows", d.active_rows)?;
        diagnostics.set_item("metric_condition", d.metric_condition)?;
        diagnostics.set_item("solves", d.solves)?;
        diagnostics.set_item("solver_iterations", d.solver_iterations)?;
        diagnostics.set_item("rows", d.rows)?;
        diagnostics.set_item("distance_pairs", d.distance_pairs)?;
        diagnostics.set_item("min_distance", d.min_distance)?;
        diagnostics.set_item("step_fraction", d.step_fraction)?;
        diagnostics.set_item("beliefs", ws.beliefs().to_vec())?;
        Ok((out, status.as_str(), diagnostics))
    }

    /// Forgets the episode: intent, policy progress, the last command.
    fn reset(&self) -> PyResult<()> {
        let mut ws =
            self.workspace.lock().map_err(|_| ArbitrationError::new_err("the arbiter's workspace is poisoned"))?;
        self.arbiter.reset(&mut ws);
        Ok(())
    }

    /// The blending mode of the next ticks.
    #[getter]
    fn get_mode(&self) -> PyResult<&'static str> {
        let ws = self.workspace.lock().map_err(|_| ArbitrationError::new_err("the arbiter's workspace is poisoned"))?;
        Ok(ws.mode().as_str())
    }

    #[setter]
    fn set_mode(&self, name: &str) -> PyResult<()> {
        let mode = mode(name)?;
        let mut ws =
            self.workspace.lock().map_err(|_| ArbitrationError::new_err("the arbiter's workspace is poisoned"))?;
        ws.set_mode(mode);
        Ok(())
    }

    /// The goals' names, in belief order.
    #[getter]
    fn goals(&self) -> Vec<String> {
        self.arbiter.goals().iter().map(|g| g.name.clone()).collect()
    }

    /// The goals' grasp or target points (m, world), one row per goal.
    #[getter]
    fn goal_positions(&self) -> Vec<[f64; 3]> {
        self.arbiter.goals().iter().map(|g| g.position).collect()
    }

    /// Seconds per tick.
    #[getter]
    fn period(&self) -> f64 {
        self.arbiter.settings().period
    }

    /// Joints commanded.
    #[getter]
    fn nq(&self) -> usize {
        self.arbiter.robot().nq()
    }

    fn __repr__(&self) -> String {
        format!("Arbiter(goals={:?}, period={:.4})", self.goals(), self.period())
    }
}
