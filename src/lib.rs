//! tandem: motion for human-robot shared control.
//!
//! The pipeline (see `DESIGN.md`): robot models from URDF → collision-free
//! seeds → KOMO-style trajectory optimization → LQR tracking policies →
//! per-tick arbitration between a human operator and the policy. This
//! release provides the first box: [`robot`], URDF models with exact,
//! allocation-free kinematics cross-checked against Pinocchio.
//!
//! ```
//! use tandem::robot::{KinematicsWorkspace, RobotModel};
//! let panda = RobotModel::panda();
//! let mut ws = KinematicsWorkspace::new(&panda);
//! panda.forward_kinematics(&mut ws, &panda.neutral_configuration()).unwrap();
//! ```

pub mod arbitration;
pub mod cli;
pub mod collision;
pub mod control;
pub mod data;
pub mod figures;
pub mod komo;
pub mod learn;
pub mod plan;
pub mod plot;
pub mod robot;
pub mod scene;
pub mod sim;
