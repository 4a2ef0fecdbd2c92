//! The simulator's experiments from Python: `tandem.run_planar` (Table 4.1)
//! and `tandem.run_reach_grasp` (Table 5.1), one dict per episode.

use crate::errors::PyResultExt;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tandem::experiments::{PlanarSettings, ReachGraspSettings, run_planar, run_reach_grasp};
use tandem::sim::Arm;

/// The planar pick-and-place experiment (Table 4.1 of the dissertation, the users of
/// §6.5): ``tasks`` sampled tasks × every user × every method, in parallel
/// (the GIL released), deterministic per ``seed``. One dict per episode:
/// ``task``, ``user``, ``method``, ``outcome`` (success, collision, failed,
/// timeout), ``duration_s``, ``travel_cm``, ``proximity_cm`` (closest
/// approach to the pole), ``cosine_distance``, ``hard_violations``.
#[pyfunction]
#[pyo3(signature = (tasks=10, seed=0))]
pub fn run_planar_experiment(py: Python<'_>, tasks: usize, seed: u64) -> PyResult<Vec<Bound<'_, PyDict>>> {
    let settings = PlanarSettings { tasks, seed, ..PlanarSettings::default() };
    let results = py.detach(|| run_planar(&settings, &|| {})).py()?;
    let s = &results.settings;
    results
        .episodes
        .iter()
        .map(|e| {
            let d = PyDict::new(py);
            d.set_item("task", e.task)?;
            d.set_item("user", s.users[e.user].name())?;
            d.set_item("method", s.methods[e.method].as_str())?;
            d.set_item("outcome", e.outcome.as_str())?;
            d.set_item("duration_s", e.duration)?;
            d.set_item("travel_cm", e.travel_cm)?;
            d.set_item("proximity_cm", e.proximity_cm)?;
            d.set_item("cosine_distance", e.cosine_distance)?;
            d.set_item("hard_violations", e.hard_violations)?;
            Ok(d)
        })
        .collect()
}

/// The Panda reach-and-grasp experiment (Table 5.1 of the dissertation): ``tasks`` tasks
/// per arm (``arm``: ``"right"``, ``"left"`` or ``"both"``) × the seven
/// operators × the six methods, in parallel (the GIL released),
/// deterministic per ``seed``. One dict per episode: ``arm``, ``task``,
/// ``operator``, ``method``, ``outcome``, ``duration_s``, ``cos`` (the
/// gripper's axes against the box's at the end), ``hard_violations``,
/// ``min_clearance_m``, ``tick_us_median``.
#[pyfunction]
#[pyo3(signature = (tasks=5, seed=0, arm="right"))]
pub fn run_reach_grasp_experiment<'py>(
    py: Python<'py>,
    tasks: usize,
    seed: u64,
    arm: &str,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let arms = match arm {
        "right" => vec![Arm::Right],
        "left" => vec![Arm::Left],
        "both" => vec![Arm::Right, Arm::Left],
        other => {
            return Err(crate::errors::ArbitrationError::new_err(format!(
                "arm must be 'right', 'left' or 'both', got {other:?}"
            )));
        }
    };
    let settings = ReachGraspSettings { tasks, seed, arms, ..ReachGraspSettings::default() };
    let results = py.detach(|| run_reach_grasp(&settings, &|| {})).py()?;
    let s = &results.settings;
    results
        .episodes
        .iter()
        .map(|e| {
            let d = PyDict::new(py);
            d.set_item("arm", e.arm.as_str())?;
            d.set_item("task", e.task)?;
            d.set_item("operator", s.operators[e.operator].name())?;
            d.set_item("method", s.methods[e.method].name())?;
            d.set_item("outcome", e.outcome.as_str())?;
            d.set_item("duration_s", e.duration)?;
            d.set_item("cos", e.cos.to_vec())?;
            d.set_item("hard_violations", e.hard_violations)?;
            d.set_item("min_clearance_m", e.min_clearance)?;
            d.set_item("tick_us_median", tandem::sim::percentiles(&e.tick_us).0)?;
            Ok(d)
        })
        .collect()
}
