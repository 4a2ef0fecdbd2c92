//! tandem on a ROS 2 system (feature `ros2`). For now the messages the
//! shared-control node exchanges with standard ROS 2 nodes (MoveIt
//! Servo's inputs, `/joint_states`, the controllers' commands), encoded as
//! plain CDR as rclcpp and rclpy put them on the wire, and the status
//! topic's codes (MoveIt Servo's, and tandem's own).

pub mod messages;
pub mod status;
