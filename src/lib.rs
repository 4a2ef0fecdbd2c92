//! tandem: motion for human-robot shared control, after the dissertation
//! *Adaptive Human-Robot Policy Blending for Shared Control Teleoperation*
//! (`docs/references.md`).
//!
//! ```text
//! problem (robot + scene + task) ─► plan ─► optimize ─► validate, accept ─► reference
//!   ─► LQR tracking policy ─► every tick: beliefs, metric, the mode's QP/SOCP
//!      under hard limits and distances ─► certified joint velocity
//! ```
//!
//! One module per box of the pipeline, each on a layer that uses only the
//! layers below it (`docs/design.md`; `tests/architecture.rs` enforces it),
//! from the ground up:
//!
//! - [`robot`]: URDF and SRDF models, exact allocation-free kinematics
//!   (cross-checked against Pinocchio);
//! - [`files`]: the error of every file tandem writes and reads back;
//! - [`settings`]: settings out of range, one error shape everywhere;
//! - [`trajectory`]: the one joint trajectory type and its CSV / Parquet files;
//! - `figures` (feature `experiments`): the SVG toolkit, one style;
//! - [`scene`]: shapes, obstacles, graspable objects;
//! - [`point_cloud`]: a sensor's points from PLY and PCD files;
//! - [`collision`]: the collision model of a robot in its scene, signed
//!   distances (cross-checked against coal), certified motion checks;
//! - [`problem`]: problem files, families, MoveIt import, grasp goals and judge;
//! - [`plan`]: inverse kinematics, RRT-Connect, shortcutting;
//! - [`komo`]: the trajectory optimizer, objectives as data;
//! - [`control`]: LQR tracking policies and the [`RobotPolicy`](control::RobotPolicy)
//!   interface the arbiter queries;
//! - [`pipeline`]: plan → optimize → validate → accept → reference and policy;
//! - `data` (feature `data`): bulk datasets of optimized trajectories;
//! - [`arbitration`]: shared control every tick, in stages — beliefs,
//!   metrics from the robot policies, eight modes as QPs / SOCPs (the exact
//!   active-set solver, Clarabel for cones), hard constraints, certification;
//! - [`sim`]: the kinematic simulator, simulated operators, judges, tasks,
//!   episodes and their recordings, a Gym-style environment;
//! - [`learn`]: learned robot policies and learned arbitration (training
//!   with feature `learn`);
//! - `experiments` (feature `experiments`): the dissertation's experiments
//!   and their one harness;
//! - `teleop` (feature `experiments`; its web server, feature `serve`): `tandem
//!   serve`, shared control from a browser;
//! - `cli` (feature `cli`): the `tandem` command.
//!
//! The features are on by default; a control loop that embeds tandem can
//! turn them off (`default-features = false`) and builds without clap,
//! indicatif, parquet, arrow, rayon, sha2, plotters, candle, axum or tokio.
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
pub mod perception;
pub mod pipeline;
pub mod plan;
pub mod point_cloud;
pub mod problem;
pub mod robot;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod scene;
pub mod settings;
pub mod sim;
#[cfg(feature = "experiments")]
pub mod teleop;
pub mod trajectory;

/// The Rust examples of the user pages run as doctests, so they cannot go
/// stale (`cargo test --doc`).
#[cfg(doctest)]
mod user_pages {
    #[doc = include_str!("../README.md")]
    struct Readme;
    #[doc = include_str!("../docs/embedding.md")]
    struct Embedding;
    #[doc = include_str!("../docs/cli.md")]
    struct Cli;
    #[doc = include_str!("../docs/datasets.md")]
    struct Datasets;
    #[doc = include_str!("../problems/README.md")]
    struct Problems;
}
