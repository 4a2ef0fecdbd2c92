//! `tandem._native.ArbitrationEnv`: the arbitration-learning environment
//! (the Rust `tandem::sim::ArbitrationEnv`), wrapped by the Gymnasium
//! environments of `tandem.gym`.

use crate::arrays::Vector;
use crate::errors::{ArbitrationError, PyResultExt};
use numpy::{PyArray1, ToPyArray};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;
use tandem::arbitration::decision::DecisionSettings;
use tandem::sim::{ArbitrationEnv, ArbitrationEnvSettings, EnvOutcome, EnvTask, RewardKind, reward};

/// The arbitration-learning environment of §6.5 of the dissertation: a simulated
/// user drives the gripper toward one of the goals; the agent sees the
/// arbitration state (gripper, goals, the nearest obstacle, every
/// sub-policy's action and belief, the user's command; 17 values) and
/// chooses the arbitrated gripper velocity (``task_dims`` values, units of
/// the user speed), executed under the hard constraints.
///
/// ``task``: ``"planar"`` (two cylinders past a pole, users straight,
/// noisy-0.5, noisy-1, biased; 5 cm/s) or ``"panda"`` (the Panda
/// reach-and-grasp of Table 5.1, its seven operators; 10 cm/s).
/// ``reward``: ``"combined"`` (Algorithm 5) or ``"environment"``.
#[pyclass(module = "tandem", name = "ArbitrationEnv", frozen)]
pub struct PyArbitrationEnv {
    inner: Mutex<Inner>,
    kind: RewardKind,
    decision: DecisionSettings,
}

struct Inner {
    env: ArbitrationEnv,
    state: Vec<f64>,
    started: bool,
}

fn env_error(e: impl std::fmt::Display) -> PyErr {
    ArbitrationError::new_err(e.to_string())
}

#[pymethods]
impl PyArbitrationEnv {
    #[new]
    #[pyo3(signature = (task="planar", *, reward="combined", max_time=None, hard_collisions=true, physics=false))]
    fn py_new(
        py: Python<'_>,
        task: &str,
        reward: &str,
        max_time: Option<f64>,
        hard_collisions: bool,
        physics: bool,
    ) -> PyResult<Self> {
        let kind = match reward {
            "combined" => RewardKind::Combined,
            "environment" => RewardKind::Environment,
            other => return Err(env_error(format!("reward must be 'combined' or 'environment', got {other:?}"))),
        };
        let mut settings = ArbitrationEnvSettings { hard_collisions, ..ArbitrationEnvSettings::default() };
        match task {
            "planar" => {}
            "panda" => {
                settings.task = EnvTask::PandaGrasp;
                settings.speed = 0.1;
            }
            other => return Err(env_error(format!("task must be 'planar' or 'panda', got {other:?}"))),
        }
        if let Some(t) = max_time {
            settings.max_time = t;
        }
        if physics {
            settings.physics = Some(tandem::sim::PhysicsSettings::default());
        }
        let decision = settings.decision;
        let env = py.detach(|| ArbitrationEnv::new(settings)).py()?;
        let state = vec![0.0; env.layout().width()];
        Ok(PyArbitrationEnv { inner: Mutex::new(Inner { env, state, started: false }), kind, decision })
    }

    /// Starts episode ``seed`` (its task and user come from the seed alone)
    /// and returns the first state.
    fn reset<'py>(&self, py: Python<'py>, seed: u64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let mut inner = self.lock()?;
        let Inner { env, state, started } = &mut *inner;
        let first = py.detach(|| env.reset(seed).map(<[f64]>::to_vec)).py()?;
        state.copy_from_slice(&first);
        *started = true;
        Ok(first.to_pyarray(py))
    }

    /// Executes ``action``; returns ``(state, reward, terminated,
    /// truncated, info)`` as Gymnasium's ``step``. ``info``: ``outcome``
    /// (success, collision, failed, timeout, running), ``env_reward``,
    /// ``user``, ``true_goal``, ``executed`` (gripper velocity, m/s).
    fn step<'py>(&self, py: Python<'py>, action: Vector<'_>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        let mut inner = self.lock()?;
        let Inner { env, state, started } = &mut *inner;
        if !*started {
            return Err(env_error("step before reset"));
        }
        let layout = env.layout();
        let action = action.as_slice().to_vec();
        let step = env.step(&action).map_err(env_error)?;
        let (outcome, env_reward, executed) = (step.outcome, step.env_reward, step.executed);
        let next = step.state.to_vec();
        let r = reward(&layout, state, &action, env.true_goal(), env_reward, self.kind, &self.decision);
        state.copy_from_slice(&next);
        let info = PyDict::new(py);
        info.set_item("outcome", outcome.as_str())?;
        info.set_item("env_reward", env_reward)?;
        info.set_item("user", env.user().unwrap_or_default())?;
        info.set_item("true_goal", env.true_goal())?;
        info.set_item("executed", executed.to_vec())?;
        let terminated = matches!(outcome, EnvOutcome::Success | EnvOutcome::Collision | EnvOutcome::Failed);
        let truncated = outcome == EnvOutcome::Timeout;
        if terminated || truncated {
            *started = false;
        }
        let values = (next.to_pyarray(py), r, terminated, truncated, info);
        values.into_pyobject(py)
    }

    /// Width of the state.
    #[getter]
    fn state_width(&self) -> PyResult<usize> {
        Ok(self.lock()?.env.layout().width())
    }

    /// Values of an action (2 on the plane, 3 for the Panda).
    #[getter]
    fn action_width(&self) -> PyResult<usize> {
        Ok(self.lock()?.env.layout().task_dims)
    }

    /// Largest action component (units of the user speed).
    #[getter]
    fn max_action(&self) -> PyResult<f64> {
        Ok(self.lock()?.env.settings().max_action)
    }

    /// Index of the user's command in the state (the last ``action_width`` values).
    #[getter]
    fn human_offset(&self) -> PyResult<usize> {
        Ok(self.lock()?.env.layout().human_offset())
    }

    /// Gripper position (m, world).
    #[getter]
    fn gripper(&self) -> PyResult<[f64; 3]> {
        Ok(self.lock()?.env.gripper())
    }
}

impl PyArbitrationEnv {
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, Inner>> {
        self.inner.lock().map_err(|_| env_error("the environment is poisoned (a panic in an earlier call)"))
    }
}
