//! tandem's Rust errors as Python exceptions: one class per kind of
//! failure under `TandemError`, the message the Rust error's own (it names
//! the file, line, key, joint or value at fault).
//!
//! ```text
//! TandemError
//! ├── RobotError            unknown frame or joint, bad joint selection
//! │   ├── UrdfError         URDF, SRDF or mesh files that cannot be loaded
//! │   └── ConfigurationError  q of the wrong length, NaN or infinite values
//! ├── CollisionError        collision shapes and models
//! ├── ProblemError          problem and family files, MoveIt inputs, scenes
//! ├── PlanningError         planning setup; unreachable goals:
//! │   └── IkError           no (collision-free) configuration reaches the target
//! ├── OptimizationError     trajectory optimization setup
//! ├── ControlError          tracking policies
//! ├── ArbitrationError      arbiter setup: goals, settings, modes
//! └── DatasetError          bulk generation and dataset files
//! ```

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use tandem::collision::CollisionError as RustCollisionError;
use tandem::control::ControlError as RustControlError;
use tandem::data::GenerateError;
use tandem::files::FileError;
use tandem::komo::KomoError;
use tandem::pipeline::PipelineError;
use tandem::plan::{IkError as RustIkError, PlanError};
use tandem::problem::ProblemError as RustProblemError;
use tandem::robot::RobotError as RustRobotError;
use tandem::scene::SceneError;

create_exception!(tandem, TandemError, PyException, "Base class of every error tandem raises.");
create_exception!(tandem, RobotError, TandemError, "Robot model errors: unknown frame or joint, bad joint selection.");
create_exception!(
    tandem,
    UrdfError,
    RobotError,
    "A URDF, SRDF or mesh file that cannot be loaded (file, line, element)."
);
create_exception!(
    tandem,
    ConfigurationError,
    RobotError,
    "A joint configuration of the wrong length or with NaN/inf values."
);
create_exception!(tandem, CollisionError, TandemError, "Collision shapes and models that cannot be built.");
create_exception!(
    tandem,
    ProblemError,
    TandemError,
    "Problem and family files, MoveIt inputs and scenes (file, key, line)."
);
create_exception!(
    tandem,
    PlanningError,
    TandemError,
    "Planning that cannot start (a failed search is a status, not an error)."
);
create_exception!(tandem, IkError, PlanningError, "No configuration (or no collision-free one) reaches the target.");
create_exception!(tandem, OptimizationError, TandemError, "Trajectory optimization that cannot be set up.");
create_exception!(tandem, ControlError, TandemError, "Tracking policies: bad references, weights or query inputs.");
create_exception!(tandem, DatasetError, TandemError, "Bulk generation and dataset files.");
create_exception!(
    tandem,
    ArbitrationError,
    TandemError,
    "Arbiter setup: goal references that cannot be prepared, settings out of range, unknown modes."
);

/// Registers the exception classes in the module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("TandemError", py.get_type::<TandemError>())?;
    m.add("RobotError", py.get_type::<RobotError>())?;
    m.add("UrdfError", py.get_type::<UrdfError>())?;
    m.add("ConfigurationError", py.get_type::<ConfigurationError>())?;
    m.add("CollisionError", py.get_type::<CollisionError>())?;
    m.add("ProblemError", py.get_type::<ProblemError>())?;
    m.add("PlanningError", py.get_type::<PlanningError>())?;
    m.add("IkError", py.get_type::<IkError>())?;
    m.add("OptimizationError", py.get_type::<OptimizationError>())?;
    m.add("ControlError", py.get_type::<ControlError>())?;
    m.add("DatasetError", py.get_type::<DatasetError>())?;
    m.add("ArbitrationError", py.get_type::<ArbitrationError>())?;
    Ok(())
}

/// A tandem error turned into the matching Python exception.
pub(crate) trait ToPyErr {
    fn to_py(self) -> PyErr;
}

/// `result.py()?`: a tandem result with its error as a Python exception.
pub(crate) trait PyResultExt<T> {
    fn py(self) -> PyResult<T>;
}

impl<T, E: ToPyErr> PyResultExt<T> for Result<T, E> {
    fn py(self) -> PyResult<T> {
        self.map_err(ToPyErr::to_py)
    }
}

impl ToPyErr for RustRobotError {
    fn to_py(self) -> PyErr {
        use RustRobotError as E;
        let message = self.to_string();
        match self {
            E::WrongDof { .. } | E::NonFinite { .. } | E::OutputShape { .. } => ConfigurationError::new_err(message),
            E::UnknownFrame { .. }
            | E::UnknownJoint { .. }
            | E::NotActuable { .. }
            | E::NotAChain { .. }
            | E::HeldValueOutOfRange { .. } => RobotError::new_err(message),
            // Everything else is about the files: XML, URDF, SRDF, meshes.
            _ => UrdfError::new_err(message),
        }
    }
}

impl ToPyErr for RustCollisionError {
    fn to_py(self) -> PyErr {
        match self {
            RustCollisionError::Robot(e) => e.to_py(),
            e => CollisionError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for RustProblemError {
    fn to_py(self) -> PyErr {
        ProblemError::new_err(self.to_string())
    }
}

impl ToPyErr for SceneError {
    fn to_py(self) -> PyErr {
        ProblemError::new_err(self.to_string())
    }
}

impl ToPyErr for RustIkError {
    fn to_py(self) -> PyErr {
        match self {
            RustIkError::Robot(e) => e.to_py(),
            e => IkError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for PlanError {
    fn to_py(self) -> PyErr {
        match self {
            PlanError::Collision(e) => e.to_py(),
            PlanError::Ik(e) => e.to_py(),
            PlanError::Robot(e) => e.to_py(),
            e => PlanningError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for KomoError {
    fn to_py(self) -> PyErr {
        match self {
            KomoError::Robot(e) => e.to_py(),
            KomoError::Collision(e) => e.to_py(),
            e => OptimizationError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for PipelineError {
    fn to_py(self) -> PyErr {
        match self {
            PipelineError::Optimizer(e) => e.to_py(),
            PipelineError::Plan(e) => (*e).to_py(),
            PipelineError::Robot(e) => e.to_py(),
            e => OptimizationError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for RustControlError {
    fn to_py(self) -> PyErr {
        ControlError::new_err(self.to_string())
    }
}

impl ToPyErr for GenerateError {
    fn to_py(self) -> PyErr {
        match self {
            GenerateError::Family(e) => e.to_py(),
            e => DatasetError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for FileError {
    fn to_py(self) -> PyErr {
        DatasetError::new_err(self.to_string())
    }
}

impl ToPyErr for tandem::arbitration::ArbitrationError {
    fn to_py(self) -> PyErr {
        use tandem::arbitration::ArbitrationError as E;
        match self {
            E::Robot(e) => e.to_py(),
            e => ArbitrationError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for tandem::experiments::ExperimentError {
    fn to_py(self) -> PyErr {
        use tandem::experiments::ExperimentError as E;
        match self {
            E::Arbitration(e) => (*e).to_py(),
            E::Problem(e) => e.to_py(),
            E::Robot(e) => e.to_py(),
            e => ArbitrationError::new_err(e.to_string()),
        }
    }
}

impl ToPyErr for tandem::sim::EnvError {
    fn to_py(self) -> PyErr {
        match self {
            tandem::sim::EnvError::Arbitration(e) => e.to_py(),
            e => ArbitrationError::new_err(e.to_string()),
        }
    }
}
