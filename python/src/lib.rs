//! Python bindings of tandem: the extension module `tandem._native`,
//! re-exported by the `tandem` package (python/tandem/).
//!
//! One Rust module per box of the pipeline, mirroring the library:
//! `robot` (models, kinematics), `collision`, `problem` (problems,
//! families), `plan` (IK, planning, optimization), `control` (tracking
//! policies), `arbitration` (the per-tick arbiter), `env` (the
//! arbitration-learning environment of `tandem.gym`), `data` (bulk
//! generation); `errors` maps every Rust error
//! to an exception class, `arrays` moves numpy data in and out. Long
//! calls release the GIL; sub-microsecond queries keep it.

mod arbitration;
mod arrays;
mod collision;
mod control;
mod data;
mod env;
mod errors;
mod experiments;
mod plan;
mod problem;
mod robot;

use pyo3::prelude::*;

/// tandem's native module; import ``tandem`` instead.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<robot::PyRobotModel>()?;
    m.add_class::<collision::PyCollisionModel>()?;
    m.add_class::<collision::PyDistance>()?;
    m.add_class::<problem::PyProblem>()?;
    m.add_class::<problem::PyProblemFamily>()?;
    m.add_class::<plan::PyPlanResult>()?;
    m.add_class::<plan::PySolution>()?;
    m.add_class::<control::PyTrackingPolicy>()?;
    m.add_class::<arbitration::PyArbiter>()?;
    m.add_class::<env::PyArbitrationEnv>()?;
    m.add_function(wrap_pyfunction!(experiments::run_planar_experiment, m)?)?;
    m.add_function(wrap_pyfunction!(experiments::run_reach_grasp_experiment, m)?)?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(plan::solve, m)?)?;
    m.add_function(wrap_pyfunction!(plan::goal_configurations, m)?)?;
    m.add_function(wrap_pyfunction!(plan::solve_ik, m)?)?;
    m.add_function(wrap_pyfunction!(data::generate, m)?)?;
    m.add_function(wrap_pyfunction!(data::missing_parts, m)?)?;
    m.add_function(wrap_pyfunction!(data::py_part_count, m)?)?;
    m.add_function(wrap_pyfunction!(data::py_part_ids, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
