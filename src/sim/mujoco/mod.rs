//! MuJoCo physics beside the kinematic simulator (feature `mujoco`).
//!
//! - [`MujocoArm`]: the robot alone, loaded by MuJoCo's own URDF compiler
//!   from the same URDF tandem's model reads, so that the arbiter and the
//!   physics see the same arm — a claim the test suite checks (the gripper
//!   frame's pose over 1,000 configurations, against tandem's forward
//!   kinematics).
//! - [`PhysicsScene`]: a problem's world (robot, obstacles, free objects,
//!   servos, grasp contact settings) compiled once and shared by threads.
//! - [`PhysicsEpisode`]: a shared-control episode on it — approach under
//!   the arbiter, close, lift 10 cm, hold 1 s; success is the object lifted
//!   (see [`PhysicsSettings`](crate::sim::PhysicsSettings)).
//!
//! MuJoCo comes from PyPI's `mujoco` wheel (3.17, the version `mujoco-rs`
//! 7 wraps): the build links its `libmujoco.so` through
//! `MUJOCO_DYNAMIC_LINK_DIR` (`scripts/test.sh` prepares the folder), with
//! no download at build or run time. Why this and not Python driving
//! MuJoCo: the arbiter and the physics in one process, one step a few
//! microseconds of Rust away from the next, no interpreter in the loop, and
//! the same library a Rust user links.

mod arm;
mod camera;
#[cfg(feature = "experiments")]
mod env;
mod episode;
mod scene;

pub use camera::{RayCastCamera, RayCastFrame};
#[cfg(feature = "experiments")]
pub(crate) use env::EnvPhysics;
pub use episode::{PhysicsEpisode, PhysicsRecord, PhysicsWorkspace, lift_arbiter};
pub use scene::{GeomRole, PhysicsScene, SceneMesh};

use crate::robot::RobotModel;
use mujoco_rs::prelude::*;
use std::sync::Arc;

/// Why MuJoCo could not take the robot.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PhysicsError {
    /// The URDF text is not available (a description read from a file
    /// that cannot be read again).
    #[error("cannot read the robot's URDF {path}: {reason}")]
    Urdf {
        /// Where the description came from.
        path: String,
        /// Why.
        reason: String,
    },
    /// MuJoCo's compiler refused the model.
    #[error("MuJoCo cannot compile the robot: {0}")]
    Compile(String),
    /// A physics setting out of range.
    #[error("{0}")]
    Settings(String),
    /// An episode names an object the scene does not have.
    #[error("object {index} requested, the scene has {count}")]
    NoObject {
        /// The index asked for.
        index: usize,
        /// How many movable objects the scene has.
        count: usize,
    },
    /// Kinematics refused a configuration (a start of the wrong length,
    /// not finite).
    #[error(transparent)]
    Robot(#[from] crate::robot::RobotError),
    /// A joint or frame tandem's model has and MuJoCo's has not.
    #[error("MuJoCo's model has no {kind} '{name}'")]
    Missing {
        /// `joint`, `body` or `actuator`.
        kind: &'static str,
        /// Its name.
        name: String,
    },
}

/// The compiler settings MuJoCo reads from a `<mujoco>` element inside a
/// URDF: keep fixed-joint bodies (the gripper frame is one), drop visuals
/// (their meshes are not needed for contacts), and keep mesh paths as the
/// URDF writes them.
const URDF_COMPILER: &str = r#"<mujoco><compiler fusestatic="false" discardvisual="true" strippath="false"/></mujoco>"#;

/// The robot in MuJoCo: the compiled model (shared, read-only) and where
/// each of tandem's active joints sits in `qpos`.
pub struct MujocoArm {
    model: Arc<MjModel>,
    qpos_index: Vec<usize>,
    gripper_body: usize,
}

impl MujocoArm {
    /// Compiles `robot`'s URDF with MuJoCo; `gripper` is the frame whose
    /// pose is compared (a link, or a fixed joint's child link).
    ///
    /// # Errors
    /// The URDF unreadable, MuJoCo's compiler refusing it, a joint or the
    /// gripper missing from MuJoCo's model.
    pub fn from_robot(robot: &RobotModel, gripper: &str) -> Result<MujocoArm, PhysicsError> {
        let xml = with_compiler_settings(&robot_urdf(robot)?)?;
        let model = MjModel::from_xml_string(&xml).map_err(|e| PhysicsError::Compile(format!("{e:?}")))?;
        let adr = model.jnt_qposadr();
        let qpos_index = robot
            .joint_names()
            .iter()
            .map(|name| {
                model
                    .name_to_id(MjtObjBase::mjOBJ_JOINT, name)
                    .map(|j| adr[j] as usize)
                    .ok_or_else(|| PhysicsError::Missing { kind: "joint", name: name.clone() })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let gripper_body = model
            .name_to_id(MjtObjBase::mjOBJ_BODY, gripper)
            .ok_or_else(|| PhysicsError::Missing { kind: "body", name: gripper.to_string() })?;
        Ok(MujocoArm { model: Arc::new(model), qpos_index, gripper_body })
    }

    /// The compiled model.
    pub fn model(&self) -> &Arc<MjModel> {
        &self.model
    }

    /// A fresh simulation state (per thread).
    pub fn data(&self) -> MjData<Arc<MjModel>> {
        MjData::new(self.model.clone())
    }

    /// Where each of tandem's active joints sits in MuJoCo's `qpos`.
    pub fn qpos_index(&self) -> &[usize] {
        &self.qpos_index
    }

    /// Writes tandem's configuration `q` (rad or m, in the model's joint
    /// order) into `data`'s `qpos`.
    pub fn set_configuration(&self, data: &mut MjData<Arc<MjModel>>, q: &[f64]) {
        let qpos = data.qpos_mut();
        for (&i, &v) in self.qpos_index.iter().zip(q) {
            qpos[i] = v;
        }
    }

    /// The gripper frame's position (m) and rotation matrix (row-major),
    /// world frame, after MuJoCo's kinematics at `data`'s `qpos`.
    pub fn gripper_pose(&self, data: &mut MjData<Arc<MjModel>>) -> ([f64; 3], [f64; 9]) {
        data.kinematics();
        (data.xpos()[self.gripper_body], data.xmat()[self.gripper_body])
    }
}

/// The text of `robot`'s URDF (embedded, or read again from its file).
fn robot_urdf(robot: &RobotModel) -> Result<String, PhysicsError> {
    let description = robot.description();
    match description.embedded_urdf() {
        Some(text) => Ok(text.to_string()),
        None => std::fs::read_to_string(description.source())
            .map_err(|e| PhysicsError::Urdf { path: description.source().to_string(), reason: e.to_string() }),
    }
}

/// `urdf` with [`URDF_COMPILER`] as the first child of `<robot>`.
fn with_compiler_settings(urdf: &str) -> Result<String, PhysicsError> {
    let bad = |reason: String| PhysicsError::Urdf { path: "<urdf>".into(), reason };
    let doc = roxmltree::Document::parse(urdf).map_err(|e| bad(e.to_string()))?;
    let root = doc.root_element();
    // The end of the root's start tag: the first '>' after it opens.
    let open = root.range().start;
    let end = urdf[open..].find('>').map(|i| open + i + 1).ok_or_else(|| bad("unterminated <robot>".into()))?;
    if urdf[..end].ends_with("/>") {
        return Err(bad("an empty <robot/>".into()));
    }
    Ok(format!("{}{URDF_COMPILER}{}", &urdf[..end], &urdf[end..]))
}
