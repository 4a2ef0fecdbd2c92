//! tandem: motion for human-robot shared control.
//!
//! The pipeline (see `DESIGN.md`): robot models from URDF → collision-free
//! seeds → KOMO-style trajectory optimization → LQR tracking policies →
//! per-tick arbitration between a human operator and the policy. The boxes
//! that work today, each a module:
//!
//! - [`robot`]: URDF (and SRDF) models with exact, allocation-free
//!   kinematics, cross-checked against Pinocchio;
//! - [`collision`]: collision models of the robot and its scene, signed
//!   distances (cross-checked against coal), motion checks;
//! - [`scene`]: scenes, problem files and families, MoveIt inputs;
//! - [`plan`]: inverse kinematics and RRT-Connect;
//! - [`komo`]: trajectory optimization with objectives as data;
//! - [`control`]: LQR tracking policies, and the [`RobotPolicy`](control::RobotPolicy)
//!   interface the arbiter queries;
//! - [`arbitration`]: shared control every tick — metrics from the robot
//!   policy, six blending modes as Clarabel QPs/SOCPs, hard constraints;
//! - [`sim`]: the kinematic simulator, simulated operators and, with the
//!   `experiments` feature, the seed's experiments;
//! - [`data`]: trajectory files and, with the `data` feature, bulk
//!   datasets in Parquet;
//! - `figures` (with `experiments`): SVG figures;
//! - `cli` (with the `cli` feature): the `tandem` command.
//!
//! The features are on by default; a control loop that embeds tandem can
//! turn them off (`default-features = false`) and builds without clap,
//! indicatif, parquet, arrow, rayon, sha2 or plotters.
//!
//! ```
//! use tandem::robot::{KinematicsWorkspace, RobotModel};
//! let panda = RobotModel::panda();
//! let mut ws = KinematicsWorkspace::new(&panda);
//! panda.forward_kinematics(&mut ws, &panda.neutral_configuration()).unwrap();
//! ```

#![warn(missing_docs)]

pub mod arbitration;
#[cfg(feature = "cli")]
pub mod cli;
pub mod collision;
pub mod control;
#[cfg(feature = "data")]
pub mod data;
#[cfg(feature = "experiments")]
pub mod experiments;
#[cfg(feature = "experiments")]
pub mod figures;
pub mod files;
pub mod komo;
pub mod learn;
pub mod pipeline;
pub mod plan;
pub mod problem;
pub mod robot;
pub mod scene;
pub mod settings;
pub mod sim;
#[cfg(feature = "serve")]
pub mod teleop;
pub mod trajectory;
