//! The node's settings (`tandem ros2 --config node.yaml`): a ROS 2
//! parameters file (`NODE: {ros__parameters: {...}}`, or the parameters
//! alone), with MoveIt Servo's names where Servo has the same setting so
//! that a Servo configuration ports over. Every key is checked: an unknown
//! key, a wrong type or a value out of range names the file and the key.

use super::status::ServoCodes;
use crate::arbitration::ArbitrationMode;
use crate::problem::ProblemError;
use crate::problem::moveit_yaml::{self, Node};
use std::path::Path;

/// Where the arbiter's joint command goes, and as what message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandOut {
    /// `trajectory_msgs/JointTrajectory` with one point a period ahead
    /// (what `joint_trajectory_controller` takes): positions and/or
    /// velocities as `publish_joint_positions` / `publish_joint_velocities`.
    Trajectory,
    /// `std_msgs/Float64MultiArray` of joint positions (the forward
    /// position controller).
    Positions,
    /// `std_msgs/Float64MultiArray` of joint velocities (the forward
    /// velocity controller).
    Velocities,
}

/// How `tandem ros2` runs. Defaults follow MoveIt Servo where it has the
/// same setting.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeSettings {
    /// The node's name (default `tandem`).
    pub node_name: String,
    /// The node's namespace (default `/`).
    pub namespace: String,
    /// DDS domain (0–232; default `ROS_DOMAIN_ID`, else 0).
    pub domain_id: u16,
    /// Control rate (Hz), 15 (the dissertation's) to 1000; default 100.
    pub rate_hz: f64,
    /// A command older than this holds the arm (s; Servo's
    /// `incoming_command_timeout`, default 0.1).
    pub incoming_command_timeout: f64,
    /// A `/joint_states` older than this holds the arm (s; default 0.1).
    pub joint_state_timeout: f64,
    /// The arbitration mode at start (changeable at run time through the
    /// `mode` parameter or the mode topic).
    pub mode: ArbitrationMode,
    /// κ of sum-of-squares' preferred step κ ā_R (0 to 10; default 0, the
    /// dissertation's eq. 5.4; see `ModeSettings::sum_of_squares_center`).
    pub sos_center: f64,
    /// κ of the constrained mode's trust-region centre κ ā_R (0 to 10;
    /// default 0, eq. 5.3).
    pub constrained_center: f64,
    /// Whose numbering of Servo's status codes the status topic uses.
    pub status_codes: ServoCodes,
    /// Largest gripper speed commanded (m/s, default 0.25): faster twists
    /// keep their direction at this speed.
    pub max_speed: f64,
    /// Whether a twist's angular part is executed (eq. 5.9 of the
    /// dissertation); by default only its linear part is, and the arbiter
    /// chooses the orientation (eq. 5.7).
    pub angular_commands: bool,
    /// The robot's joint states (Servo's `joint_topic`).
    pub joint_topic: String,
    /// Twist commands (Servo's `cartesian_command_in_topic`).
    pub cartesian_command_in_topic: String,
    /// Joint commands (Servo's `joint_command_in_topic`).
    pub joint_command_in_topic: String,
    /// The command out (Servo's `command_out_topic`).
    pub command_out_topic: String,
    /// The command's message and contents (Servo's `command_out_type`,
    /// `publish_joint_positions`, `publish_joint_velocities`).
    pub command_out: CommandOut,
    /// In a trajectory: the point's positions.
    pub publish_joint_positions: bool,
    /// In a trajectory: the point's velocities.
    pub publish_joint_velocities: bool,
    /// In a trajectory: the point's accelerations (Servo's
    /// `publish_joint_accelerations`; default true here): the change of
    /// velocity from the previous point over the period, rad/s².
    pub publish_joint_accelerations: bool,
    /// The joints' velocity, acceleration, deceleration and jerk limits:
    /// a MoveIt / ros2_control `joint_limits.yaml` (relative to the
    /// settings file's folder) or `builtin:franka_panda` /
    /// `builtin:franka_fr3`; replaces what the problem's `[robot]
    /// joint_limits` set for the joints it names. `None`: the problem's.
    pub joint_limits: Option<String>,
    /// With position outputs, how far the node's own reference (its last
    /// commanded positions, which the next point continues from) may be
    /// from the measured joint positions before it is re-anchored to the
    /// measurement (rad or m, largest over the joints; 1e-4 to 1). `None`:
    /// the larger of 0.05 and three periods at the fastest joint's
    /// velocity limit (see [`reference_deviation_limit`](Self::reference_deviation_limit)).
    pub max_reference_deviation: Option<f64>,
    /// Status codes (`std_msgs/Int8`; Servo's `status_topic`).
    pub status_topic: String,
    /// Beliefs over the goals (`std_msgs/Float64MultiArray`).
    pub beliefs_topic: String,
    /// Per-tick diagnostics (`std_msgs/Float64MultiArray`, see
    /// [`DIAGNOSTICS`](super::DIAGNOSTICS)).
    pub diagnostics_topic: String,
    /// The arbitration mode by name (`std_msgs/String`), for tools without
    /// parameter services.
    pub mode_topic: String,
    /// Poses of the graspable objects (`geometry_msgs/PoseArray`, root
    /// frame, in the problem's order): each new array re-plans the goals.
    pub goals_topic: String,
    /// Where the robot's URDF is published (`std_msgs/String`,
    /// transient-local, as MoveIt reads it).
    pub robot_description_topic: String,
    /// How long to wait at start for the robot's URDF (s, 0–60; default 0:
    /// no check). When positive, the node starts only if the published
    /// robot has the problem's joints, limits and gripper pose.
    pub robot_description_timeout: f64,
    /// The camera whose points become the scene's point cloud (off by default).
    pub camera: super::camera::CameraSettings,
}

impl Default for NodeSettings {
    fn default() -> Self {
        NodeSettings {
            node_name: "tandem".into(),
            namespace: "/".into(),
            domain_id: std::env::var("ROS_DOMAIN_ID").ok().and_then(|d| d.trim().parse().ok()).unwrap_or(0),
            rate_hz: 100.0,
            incoming_command_timeout: 0.1,
            joint_state_timeout: 0.1,
            mode: ArbitrationMode::SumOfSquares,
            sos_center: 0.0,
            constrained_center: 0.0,
            status_codes: ServoCodes::Jazzy,
            max_speed: 0.25,
            angular_commands: false,
            joint_topic: "/joint_states".into(),
            cartesian_command_in_topic: "~/delta_twist_cmds".into(),
            joint_command_in_topic: "~/delta_joint_cmds".into(),
            command_out_topic: "/joint_trajectory_controller/joint_trajectory".into(),
            command_out: CommandOut::Trajectory,
            publish_joint_positions: true,
            publish_joint_velocities: true,
            publish_joint_accelerations: true,
            joint_limits: None,
            max_reference_deviation: None,
            status_topic: "~/status".into(),
            beliefs_topic: "~/beliefs".into(),
            diagnostics_topic: "~/diagnostics".into(),
            mode_topic: "~/mode".into(),
            goals_topic: "~/goals".into(),
            robot_description_topic: "/robot_description".into(),
            robot_description_timeout: 0.0,
            camera: super::camera::CameraSettings::default(),
        }
    }
}

/// Every key of the settings file.
const KEYS: &[&str] = &[
    "node_name",
    "namespace",
    "domain_id",
    "rate_hz",
    "incoming_command_timeout",
    "joint_state_timeout",
    "mode",
    "sos_center",
    "constrained_center",
    "status_codes",
    "max_speed",
    "angular_commands",
    "joint_topic",
    "cartesian_command_in_topic",
    "joint_command_in_topic",
    "command_out_topic",
    "command_out_type",
    "publish_joint_positions",
    "publish_joint_velocities",
    "publish_joint_accelerations",
    "joint_limits",
    "max_reference_deviation",
    "status_topic",
    "beliefs_topic",
    "diagnostics_topic",
    "mode_topic",
    "goals_topic",
    "robot_description_topic",
    "robot_description_timeout",
];

impl NodeSettings {
    /// The settings in `path` (YAML), defaults for the keys it leaves out.
    ///
    /// # Errors
    /// The file unreadable or malformed; an unknown key, a wrong type or an
    /// out-of-range value (naming the file and key).
    pub fn from_file(path: &Path) -> Result<NodeSettings, ProblemError> {
        let (file, doc) = moveit_yaml::load(path)?;
        let mut settings = NodeSettings::from_yaml(&file, &doc)?;
        // A relative limits file is the settings file's neighbour, as a
        // problem file's paths are.
        if let Some(limits) = &mut settings.joint_limits
            && !limits.starts_with("builtin:")
            && Path::new(limits.as_str()).is_relative()
        {
            let dir = path.parent().unwrap_or(Path::new(""));
            *limits = dir.join(limits.as_str()).to_string_lossy().into_owned();
        }
        Ok(settings)
    }

    /// The settings in `text` (YAML) read from `file`.
    ///
    /// # Errors
    /// As [`from_file`](Self::from_file).
    pub fn from_str(text: &str, file: &str) -> Result<NodeSettings, ProblemError> {
        let doc = moveit_yaml::parse(text, file)?;
        NodeSettings::from_yaml(file, &doc)
    }

    fn from_yaml(file: &str, doc: &yaml_rust2::Yaml) -> Result<NodeSettings, ProblemError> {
        let root = Node::root(file, doc);
        let params = parameters_of(root)?;
        let keys: Vec<&str> = KEYS.iter().chain(&super::camera::CAMERA_KEYS).copied().collect();
        params.fields("the node's parameters", &keys)?;
        let mut s = NodeSettings::default();
        let text = |key: &str, into: &mut String| -> Result<(), ProblemError> {
            let n = params.get(key);
            if !n.is_absent() {
                *into = topic_or_name(&n)?;
            }
            Ok(())
        };
        text("node_name", &mut s.node_name)?;
        text("namespace", &mut s.namespace)?;
        for (key, field) in [
            ("joint_topic", &mut s.joint_topic),
            ("cartesian_command_in_topic", &mut s.cartesian_command_in_topic),
            ("joint_command_in_topic", &mut s.joint_command_in_topic),
            ("command_out_topic", &mut s.command_out_topic),
            ("status_topic", &mut s.status_topic),
            ("beliefs_topic", &mut s.beliefs_topic),
            ("diagnostics_topic", &mut s.diagnostics_topic),
            ("mode_topic", &mut s.mode_topic),
            ("goals_topic", &mut s.goals_topic),
            ("robot_description_topic", &mut s.robot_description_topic),
        ] {
            text(key, field)?;
        }
        let number = |key: &str, range: std::ops::RangeInclusive<f64>, into: &mut f64| -> Result<(), ProblemError> {
            let n = params.get(key);
            if n.is_absent() {
                return Ok(());
            }
            let v = n.number()?;
            if !range.contains(&v) {
                return Err(n.error(format!("{v} is outside [{}, {}]", range.start(), range.end())));
            }
            *into = v;
            Ok(())
        };
        number("rate_hz", 15.0..=1000.0, &mut s.rate_hz)?;
        number("incoming_command_timeout", 0.001..=10.0, &mut s.incoming_command_timeout)?;
        number("joint_state_timeout", 0.001..=10.0, &mut s.joint_state_timeout)?;
        number("max_speed", 0.001..=2.0, &mut s.max_speed)?;
        number("robot_description_timeout", 0.0..=60.0, &mut s.robot_description_timeout)?;
        number("sos_center", 0.0..=10.0, &mut s.sos_center)?;
        number("constrained_center", 0.0..=10.0, &mut s.constrained_center)?;
        let mut domain = f64::from(s.domain_id);
        number("domain_id", 0.0..=232.0, &mut domain)?;
        if domain.fract() != 0.0 {
            return Err(params.get("domain_id").error(format!("must be a whole number, got {domain}")));
        }
        s.domain_id = domain as u16;
        let flag = |key: &str, into: &mut bool| -> Result<(), ProblemError> {
            let n = params.get(key);
            if !n.is_absent() {
                *into = n.value.as_bool().ok_or_else(|| n.error("must be true or false"))?;
            }
            Ok(())
        };
        flag("angular_commands", &mut s.angular_commands)?;
        flag("publish_joint_positions", &mut s.publish_joint_positions)?;
        flag("publish_joint_velocities", &mut s.publish_joint_velocities)?;
        flag("publish_joint_accelerations", &mut s.publish_joint_accelerations)?;
        let limits = params.get("joint_limits");
        if !limits.is_absent() {
            let text = limits.text()?;
            if text.trim().is_empty() {
                return Err(limits.error("must name a joint_limits.yaml or builtin:NAME"));
            }
            s.joint_limits = Some(text.to_string());
        }
        if !params.get("max_reference_deviation").is_absent() {
            let mut deviation = 0.0;
            number("max_reference_deviation", 1e-4..=1.0, &mut deviation)?;
            s.max_reference_deviation = Some(deviation);
        }
        s.camera = super::camera::CameraSettings::read(&params, topic_or_name)?;
        let mode = params.get("mode");
        if !mode.is_absent() {
            s.mode = mode.text()?.parse().map_err(|e| mode.error(format!("{e}")))?;
        }
        let codes = params.get("status_codes");
        if !codes.is_absent() {
            s.status_codes = match codes.text()? {
                "jazzy" => ServoCodes::Jazzy,
                "humble" => ServoCodes::Humble,
                other => return Err(codes.error(format!("'{other}' is not jazzy or humble"))),
            };
        }
        let out = params.get("command_out_type");
        let out_type = if out.is_absent() { "trajectory_msgs/JointTrajectory" } else { out.text()? };
        s.command_out = match out_type {
            "trajectory_msgs/JointTrajectory" | "trajectory_msgs/msg/JointTrajectory" => CommandOut::Trajectory,
            "std_msgs/Float64MultiArray" | "std_msgs/msg/Float64MultiArray" => {
                match (s.publish_joint_positions, s.publish_joint_velocities) {
                    (true, false) => CommandOut::Positions,
                    (false, true) => CommandOut::Velocities,
                    _ => {
                        return Err(out.error(
                            "a Float64MultiArray carries positions or velocities: set exactly one of \
                             publish_joint_positions and publish_joint_velocities",
                        ));
                    }
                }
            }
            other => {
                return Err(out
                    .error(format!("'{other}' is not trajectory_msgs/JointTrajectory or std_msgs/Float64MultiArray")));
            }
        };
        if s.command_out == CommandOut::Trajectory && !s.publish_joint_positions && !s.publish_joint_velocities {
            return Err(params.get("publish_joint_positions").error(
                "a trajectory needs positions or velocities: publish_joint_positions and \
                 publish_joint_velocities are both false",
            ));
        }
        Ok(s)
    }

    /// The control period (s).
    pub fn period(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// Whether the command out carries positions (then the node integrates
    /// them from its own reference).
    pub fn publishes_positions(&self) -> bool {
        match self.command_out {
            CommandOut::Trajectory => self.publish_joint_positions,
            CommandOut::Positions => true,
            CommandOut::Velocities => false,
        }
    }

    /// The largest deviation of the reference from the measurement before
    /// a re-anchor (rad or m), for an arm whose fastest joint's velocity
    /// limit is `max_velocity` (rad/s or m/s): the setting, or the larger
    /// of 0.05 and three periods at `max_velocity`. Three periods: a robot
    /// that reports its state a period or two late at full speed lags by
    /// less, and is not re-anchored while it follows.
    pub fn reference_deviation_limit(&self, max_velocity: f64) -> f64 {
        self.max_reference_deviation.unwrap_or_else(|| (3.0 * max_velocity * self.period()).max(0.05))
    }

    /// `base` with these settings' period and modes' centres (the mode
    /// itself is the control loop's to set).
    pub fn arbiter_settings(&self, base: &crate::arbitration::ArbiterSettings) -> crate::arbitration::ArbiterSettings {
        crate::arbitration::ArbiterSettings {
            period: self.period(),
            modes: crate::arbitration::ModeSettings {
                sum_of_squares_center: self.sos_center,
                constrained_center: self.constrained_center,
                ..base.modes
            },
            ..*base
        }
    }
}

/// The parameters mapping: under `NODE: {ros__parameters: …}` (a ROS 2
/// parameters file; `/**` for any node) or the document itself.
fn parameters_of(root: Node<'_>) -> Result<Node<'_>, ProblemError> {
    if let yaml_rust2::Yaml::Hash(map) = root.value
        && map.len() == 1
        && let Some(key) = map.keys().next().and_then(|k| k.as_str())
        && !KEYS.contains(&key)
        && matches!(root.get(key).value, yaml_rust2::Yaml::Hash(_))
    {
        let node = root.get(key);
        node.fields("a node's entry", &["ros__parameters"])?;
        return node.required("ros__parameters");
    }
    Ok(root)
}

/// A topic or node name: ASCII letters, digits, `_`, `/` and a leading `~`.
fn topic_or_name(n: &Node<'_>) -> Result<String, ProblemError> {
    let text = n.text()?;
    let ok = !text.is_empty()
        && text.char_indices().all(|(i, c)| c.is_ascii_alphanumeric() || c == '_' || c == '/' || (c == '~' && i == 0));
    if ok { Ok(text.to_string()) } else { Err(n.error(format!("'{text}' is not a ROS 2 name"))) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameters_file_is_read_and_every_key_checked() {
        let s = NodeSettings::from_str(
            "tandem:\n  ros__parameters:\n    rate_hz: 500\n    mode: constrained\n    sos_center: 0.5\n    command_out_type: \
             std_msgs/Float64MultiArray\n    publish_joint_positions: false\n    command_out_topic: \
             /forward_velocity_controller/commands\n    status_codes: humble\n",
            "node.yaml",
        )
        .unwrap();
        assert_eq!(s.rate_hz, 500.0);
        assert_eq!(s.mode, ArbitrationMode::Constrained);
        assert_eq!((s.sos_center, s.constrained_center), (0.5, 0.0));
        let arbiter = s.arbiter_settings(&crate::arbitration::ArbiterSettings::default());
        assert_eq!((arbiter.modes.sum_of_squares_center, arbiter.period), (0.5, 1.0 / 500.0));
        assert_eq!(s.command_out, CommandOut::Velocities);
        assert_eq!(s.status_codes, ServoCodes::Humble);
        assert_eq!(s.command_out_topic, "/forward_velocity_controller/commands");
        assert_eq!(NodeSettings::from_str("rate_hz: 15.0\n", "f").unwrap().rate_hz, 15.0);
        // The reference's re-anchoring distance: three periods at full speed, at least 5 cm/rad.
        let at = |text: &str| NodeSettings::from_str(text, "f").unwrap().reference_deviation_limit(2.61);
        assert_eq!(at("rate_hz: 1000\n"), 0.05);
        assert!((at("rate_hz: 15\n") - 3.0 * 2.61 / 15.0).abs() < 1e-15);
        assert_eq!(at("max_reference_deviation: 0.01\n"), 0.01);
        assert!(!s.publishes_positions() && NodeSettings::default().publishes_positions());
        for (text, says) in [
            ("rate_hz: 5\n", "f: rate_hz: 5 is outside [15, 1000]"),
            ("rate_hz: .nan\n", "rate_hz: must be finite"),
            ("rate: 50\n", "rate: unknown key"),
            ("mode: fast\n", "mode: "),
            ("sos_center: -1\n", "sos_center: -1 is outside [0, 10]"),
            ("constrained_center: .nan\n", "constrained_center: must be finite"),
            ("domain_id: 1.5\n", "domain_id: must be a whole number"),
            ("joint_topic: 'a b'\n", "joint_topic: 'a b' is not a ROS 2 name"),
            ("command_out_type: std_msgs/Float64MultiArray\n", "set exactly one"),
            ("angular_commands: 3\n", "angular_commands: must be true or false"),
            ("max_reference_deviation: 2\n", "max_reference_deviation: 2 is outside [0.0001, 1]"),
            ("max_reference_deviation: .nan\n", "max_reference_deviation: must be finite"),
            ("joint_limits: ''\n", "joint_limits: must name"),
            ("publish_joint_accelerations: 1\n", "publish_joint_accelerations: must be true or false"),
            ("tandem:\n  parameters: {}\n", "tandem.parameters: unknown key"),
        ] {
            let e = NodeSettings::from_str(text, "f").unwrap_err().to_string();
            assert!(e.contains(says), "{text:?}: {e}");
        }
    }
}
