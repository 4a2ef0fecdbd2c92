//! tandem on a ROS 2 system (feature `ros2`): the shared-control node
//! `tandem ros2` runs where MoveIt Servo runs, reading Servo's inputs and
//! `/joint_states` and writing what the ROS 2 controllers take, over the
//! DDS wire protocol rclcpp and rclpy nodes speak (`ros2-client` over
//! RustDDS: no ROS installation needed).
//!
//! - [`messages`]: the messages, encoded as plain CDR;
//! - [`status`]: the status topic's codes (MoveIt Servo's, and tandem's own);
//! - [`settings`]: the node's parameters file;
//! - [`control`]: the control loop without the middleware (holds on stale
//!   or malformed input);
//! - [`goals`]: goals placed by a PoseArray, re-planned while the node runs;
//! - [`sensing`]: PointCloud2 and depth images (with CameraInfo) as points;
//! - [`camera`]: a camera topic as the scene's point cloud, built on a
//!   worker and swapped in between ticks;
//! - [`robot_description`]: the published robot checked against the problem's;
//! - [`log`]: the node's log, bounded and rate-limited, off the loop's thread;
//! - [`watchdog`]: a stalled loop reported from the loop's deadline grid;
//! - [`ticker`]: the loop's bookkeeping besides DDS (mode names, tick
//!   statistics in fixed memory, holds logged, the watchdog's heartbeat);
//! - [`node`]: the node on DDS.

pub mod camera;
pub mod control;
pub mod goals;
pub mod log;
pub mod messages;
pub mod node;
pub mod robot_description;
pub mod sensing;
pub mod settings;
pub mod status;
pub mod ticker;
pub mod watchdog;

pub use camera::{CameraSettings, StaleCloud};
pub use control::{
    COMMAND_STALE, ControlLoop, ControlOutput, DIAGNOSTICS, HOLDS, ModeRefusal, POINT_CLOUD_STALE, STATE_STALE,
};
pub use goals::{GoalPoses, GoalPreparer};
pub use node::{NodeError, NodeReport, run_node};
pub use settings::{CommandOut, NodeSettings};
