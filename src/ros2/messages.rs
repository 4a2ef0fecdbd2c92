//! The ROS 2 messages `tandem ros2` reads and writes, each written once as
//! a serde struct whose fields follow its ROS 2 IDL in order and type, so
//! that plain CDR (what rclcpp and rclpy nodes put on the wire) encodes
//! them: [`encode`] and [`decode`]. Tested byte for byte against an
//! independent serializer (PyPI `rosbags`, tests/ros2_messages.rs).

use serde::{Deserialize, Serialize};

/// The CDR encapsulation a ROS 2 payload starts with: plain CDR, little
/// endian (`CDR_LE`), no options.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a payload could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MessageError {
    /// Shorter than the 4-byte encapsulation, or another representation
    /// than plain CDR (big or little endian).
    #[error("not a plain CDR payload (encapsulation {0:02x?})")]
    Encapsulation(Vec<u8>),
    /// The body does not decode as the message.
    #[error("{0}")]
    Cdr(String),
}

/// `message` as a ROS 2 payload: [`CDR_LE`], then its plain CDR body.
///
/// # Errors
/// A message serde cannot write as CDR (none of this module's).
pub fn encode<M: Serialize>(message: &M) -> Result<Vec<u8>, MessageError> {
    let body =
        cdr_encoding::to_vec::<M, byteorder::LittleEndian>(message).map_err(|e| MessageError::Cdr(e.to_string()))?;
    let mut payload = Vec::with_capacity(4 + body.len());
    payload.extend_from_slice(&CDR_LE);
    payload.extend_from_slice(&body);
    Ok(payload)
}

/// A ROS 2 payload read as `M`, in either byte order.
///
/// # Errors
/// Another encapsulation, or a body that does not decode as `M`.
pub fn decode<M: for<'de> Deserialize<'de>>(payload: &[u8]) -> Result<M, MessageError> {
    let (header, body) = payload.split_at_checked(4).ok_or_else(|| MessageError::Encapsulation(payload.to_vec()))?;
    let decoded = match header {
        [0x00, 0x01, _, _] => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        [0x00, 0x00, _, _] => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        _ => return Err(MessageError::Encapsulation(header.to_vec())),
    };
    decoded.map(|(m, _)| m).map_err(|e| MessageError::Cdr(e.to_string()))
}

/// `builtin_interfaces/Time`: seconds and nanoseconds since the epoch.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, 0 … 999,999,999.
    pub nanosec: u32,
}

/// `builtin_interfaces/Duration`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, 0 … 999,999,999.
    pub nanosec: u32,
}

/// `std_msgs/Header`: when, and in which frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// The time of the data.
    pub stamp: Time,
    /// The frame the data is expressed in.
    pub frame_id: String,
}

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Twist`: linear (m/s) and angular (rad/s) velocity.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity (m/s).
    pub linear: Vector3,
    /// Angular velocity (rad/s).
    pub angular: Vector3,
}

/// `geometry_msgs/TwistStamped`: MoveIt Servo's `~/delta_twist_cmds`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Time and frame of the twist.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}

/// `control_msgs/JointJog`: MoveIt Servo's `~/delta_joint_cmds`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointJog {
    /// Time of the command.
    pub header: Header,
    /// The joints commanded.
    pub joint_names: Vec<String>,
    /// Position offsets (rad or m), or empty.
    pub displacements: Vec<f64>,
    /// Velocities (rad/s or m/s), or empty.
    pub velocities: Vec<f64>,
    /// How long the command applies (s).
    pub duration: f64,
}

/// `sensor_msgs/JointState`: the robot's `/joint_states`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Time of the measurement.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad or m), or empty.
    pub position: Vec<f64>,
    /// Velocities (rad/s or m/s), or empty.
    pub velocity: Vec<f64>,
    /// Efforts (N·m or N), or empty.
    pub effort: Vec<f64>,
}

/// `trajectory_msgs/JointTrajectoryPoint`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions (rad or m).
    pub positions: Vec<f64>,
    /// Velocities, or empty.
    pub velocities: Vec<f64>,
    /// Accelerations, or empty.
    pub accelerations: Vec<f64>,
    /// Efforts, or empty.
    pub effort: Vec<f64>,
    /// When the point is reached, from the trajectory's start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/JointTrajectory`: what `joint_trajectory_controller` takes.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// Start time (zero: now).
    pub header: Header,
    /// The joints of every point, in order.
    pub joint_names: Vec<String>,
    /// The points.
    pub points: Vec<JointTrajectoryPoint>,
}

/// `std_msgs/MultiArrayDimension`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// Its label.
    pub label: String,
    /// Its size.
    pub size: u32,
    /// Its stride.
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// The dimensions.
    pub dim: Vec<MultiArrayDimension>,
    /// Padding elements at the front of `data`.
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray`: what the forward position and velocity
/// controllers take.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// The layout (empty for a flat array).
    pub layout: MultiArrayLayout,
    /// The values.
    pub data: Vec<f64>,
}

/// `std_msgs/Int8`: the status topic.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Int8 {
    /// The value.
    pub data: i8,
}

/// `std_msgs/String`: `/robot_description`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMessage {
    /// The text.
    pub data: String,
}

/// `geometry_msgs/Point`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

/// `geometry_msgs/Quaternion` (x, y, z, w).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity, as in the IDL's default.
    fn default() -> Self {
        Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseArray`: graspable objects.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseArray {
    /// Time and frame of the poses.
    pub header: Header,
    /// The poses.
    pub poses: Vec<Pose>,
}

/// `sensor_msgs/PointField`: one field of a [`PointCloud2`]'s points.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    /// The field's name (`x`, `y`, `z`, `rgb`, `intensity`, …).
    pub name: String,
    /// Its offset in a point (bytes).
    pub offset: u32,
    /// Its type: 1 INT8, 2 UINT8, 3 INT16, 4 UINT16, 5 INT32, 6 UINT32,
    /// 7 FLOAT32, 8 FLOAT64.
    pub datatype: u8,
    /// Elements in the field.
    pub count: u32,
}

/// `sensor_msgs/PointCloud2`: points as rows of bytes, laid out by `fields`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Time and frame of the points.
    pub header: Header,
    /// Rows (1 for an unorganised cloud).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// The layout of a point.
    pub fields: Vec<PointField>,
    /// Byte order of `data`.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// `height × row_step` bytes.
    pub data: Vec<u8>,
    /// True when no point is invalid (NaN).
    pub is_dense: bool,
}

/// `sensor_msgs/Image`: here a depth image (REP 118: `32FC1` in m,
/// `16UC1` in mm, NaN or 0 where the camera has no depth).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Time of the image and its camera's optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`32FC1`, `16UC1`, …).
    pub encoding: String,
    /// Byte order of `data` (non-zero: big endian).
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// `height × step` bytes.
    pub data: Vec<u8>,
}

/// `sensor_msgs/RegionOfInterest`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left column (pixels).
    pub x_offset: u32,
    /// Top row (pixels).
    pub y_offset: u32,
    /// Rows (0: the whole image).
    pub height: u32,
    /// Columns (0: the whole image).
    pub width: u32,
    /// Whether the region is to be rectified.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`: a camera's calibration.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Time and the camera's optical frame.
    pub header: Header,
    /// Image rows of the calibration.
    pub height: u32,
    /// Image columns of the calibration.
    pub width: u32,
    /// `plumb_bob` (d: k1, k2, t1, t2, k3), `rational_polynomial`, …; empty
    /// for none.
    pub distortion_model: String,
    /// The distortion coefficients.
    pub d: Vec<f64>,
    /// The intrinsic matrix K, row-major (fx 0 cx; 0 fy cy; 0 0 1).
    pub k: [f64; 9],
    /// The rectification rotation, row-major.
    pub r: [f64; 9],
    /// The projection matrix of the rectified image, row-major 3 × 4.
    pub p: [f64; 12],
    /// Horizontal binning (0 or 1: none).
    pub binning_x: u32,
    /// Vertical binning (0 or 1: none).
    pub binning_y: u32,
    /// The region of the full image this one is.
    pub roi: RegionOfInterest,
}
