//! Robot models from URDF: description, compiled kinematic model, forward
//! kinematics and Jacobians.
//!
//! Load a [`RobotDescription`] from a URDF, compile it into a [`RobotModel`]
//! with a choice of active joints, and evaluate it with a
//! [`KinematicsWorkspace`] — the model/workspace split of Pinocchio's
//! `Model`/`Data`: the model is immutable and shared, the workspace is
//! per-thread and makes every query allocation-free.
//!
//! ```
//! use tandem::robot::{KinematicsWorkspace, RobotModel};
//! let panda = RobotModel::panda();
//! let mut ws = KinematicsWorkspace::new(&panda);
//! panda.forward_kinematics(&mut ws, &[0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8]).unwrap();
//! let hand = panda.frame_pose(&ws, panda.frame_id("panda_hand").unwrap());
//! println!("hand at {}", hand.translation.vector);
//! ```

mod collada;
mod description;
mod error;
mod kinematics;
mod mesh;
mod model;
mod motion_limits;
mod placement;
mod rotation;
mod srdf;
mod urdf;
mod xml_checks;

pub use description::{CollisionElement, Geometry, Joint, JointKind, JointLimits, Link, Mimic, RobotDescription};
pub use error::{RobotError, SourceLocation};
pub(crate) use error::{did_you_mean, suggest as suggest_names};
pub use kinematics::{KinematicsWorkspace, ReferenceFrame};
pub use mesh::TriMesh;
pub(crate) use model::Motion;
pub use model::{Frame, FrameId, FrameKind, JointSelection, RobotModel, RobotModelBuilder};
pub use motion_limits::{
    BUILTIN_LIMITS, FRANKA_FR3, FRANKA_PANDA, JointMotionLimits, LimitSource, MotionLimitOverride,
    PositionVelocityLimit, builtin_limits,
};
pub(crate) use placement::signed_permutation_near;
pub use rotation::rotation_log;
pub use srdf::{DisabledPair, Group, GroupState, Srdf, SrdfWarning, VirtualJoint};
pub use urdf::MeshSearchPath;
