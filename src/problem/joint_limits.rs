//! MoveIt's and ros2_control's `joint_limits.yaml`: the velocity,
//! acceleration, deceleration and jerk limits of a robot's joints (the
//! URDF has only velocity), read strictly into
//! [`MotionLimitOverride`]s for [`RobotModel::apply_motion_limits`].
//!
//! Both layouts are read: MoveIt's (`joint_limits:` at the root, beside
//! `default_velocity_scaling_factor` and `default_acceleration_scaling_factor`)
//! and ros2_control's parameter file (`<node>: ros__parameters:
//! joint_limits:`). Per joint, a `max_*` value applies when its `has_*`
//! flag is true, as in both; a joint without `has_deceleration_limits`
//! slows down within its acceleration limit. Position, effort and soft
//! limits are accepted and not used (tandem takes position limits from the
//! URDF). Any other key is an error naming it, as is a joint the robot
//! does not have.

use super::ProblemError;
use super::moveit_yaml::{self, Node};
use crate::robot::{BUILTIN_LIMITS, LimitSource, MotionLimitOverride, RobotModel, builtin_limits};
use std::path::Path;

/// The keys of one joint's entry.
const JOINT_KEYS: [&str; 19] = [
    "has_position_limits",
    "min_position",
    "max_position",
    "has_velocity_limits",
    "max_velocity",
    "has_acceleration_limits",
    "max_acceleration",
    "has_deceleration_limits",
    "max_deceleration",
    "has_jerk_limits",
    "max_jerk",
    "has_effort_limits",
    "max_effort",
    "angle_wraparound",
    "has_soft_limits",
    "k_position",
    "k_velocity",
    "soft_lower_limit",
    "soft_upper_limit",
];

/// One `joint_limits.yaml`: each joint named in it and what it sets.
#[derive(Debug, Clone, PartialEq)]
pub struct JointLimitsFile {
    /// The file (as given), for errors and for [`LimitSource::File`].
    pub file: String,
    /// The joints in file order, with what each sets.
    pub joints: Vec<(String, MotionLimitOverride)>,
}

impl JointLimitsFile {
    /// Reads `path`.
    ///
    /// # Errors
    /// The file unreadable or not YAML; a key that is not a joint limit
    /// (named with its path); a `max_*` value missing where its `has_*`
    /// flag is true, or not finite and positive.
    pub fn read(path: impl AsRef<Path>) -> Result<JointLimitsFile, ProblemError> {
        let (file, doc) = moveit_yaml::load(path.as_ref())?;
        Self::from_yaml(&file, &doc)
    }

    /// Parses `text`, naming it `file` in errors.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn parse(text: &str, file: &str) -> Result<JointLimitsFile, ProblemError> {
        let doc = moveit_yaml::parse(text, file)?;
        Self::from_yaml(file, &doc)
    }

    fn from_yaml(file: &str, doc: &yaml_rust2::Yaml) -> Result<JointLimitsFile, ProblemError> {
        let root = Node::root(file, doc);
        let table = find_table(&root)?;
        let yaml_rust2::Yaml::Hash(map) = table.value else {
            return Err(table.error("must be a mapping of joint names to their limits"));
        };
        let mut joints = Vec::with_capacity(map.len());
        for key in map.keys() {
            let Some(name) = key.as_str() else {
                return Err(table.error(format!("has a joint name that is not a string: {key:?}")));
            };
            let entry = table.get(name);
            entry.fields("a joint's limits", &JOINT_KEYS)?;
            let limit = |flag: &str, key: &str| -> Result<Option<f64>, ProblemError> {
                let has = entry.get(flag);
                let on = match has.value {
                    yaml_rust2::Yaml::Boolean(b) => *b,
                    _ if has.is_absent() => false,
                    _ => return Err(has.error("must be true or false")),
                };
                if !on {
                    return Ok(None);
                }
                let value = entry.required(key)?;
                let x = value.number()?;
                if !(x.is_finite() && x > 0.0) {
                    return Err(value.error(format!("{x} must be finite and above 0")));
                }
                Ok(Some(x))
            };
            let set = MotionLimitOverride {
                velocity: limit("has_velocity_limits", "max_velocity")?,
                acceleration: limit("has_acceleration_limits", "max_acceleration")?,
                deceleration: limit("has_deceleration_limits", "max_deceleration")?,
                jerk: limit("has_jerk_limits", "max_jerk")?,
            };
            joints.push((name.to_string(), set));
        }
        Ok(JointLimitsFile { file: file.to_string(), joints })
    }

    /// Sets `robot`'s motion limits from this file.
    ///
    /// # Errors
    /// A joint the robot's description does not have (with suggestions).
    pub fn apply_to(&self, robot: &mut RobotModel) -> Result<(), ProblemError> {
        let names: Vec<String> = robot.description().joints().iter().map(|j| j.name.clone()).collect();
        for (joint, _) in &self.joints {
            if !names.contains(joint) {
                let hint =
                    crate::robot::did_you_mean(&crate::robot::suggest_names(joint, names.iter().map(String::as_str)));
                return Err(ProblemError::Invalid {
                    file: self.file.clone(),
                    line: None,
                    key: Some(format!("joint_limits.{joint}")),
                    message: format!("the robot has no joint named '{joint}'{hint}"),
                });
            }
        }
        let source = LimitSource::File(self.file.clone());
        robot.apply_motion_limits(self.joints.iter().map(|(j, set)| (j.as_str(), *set, None)), &source).map_err(|e| {
            ProblemError::Invalid { file: self.file.clone(), line: None, key: None, message: e.to_string() }
        })
    }
}

/// Sets `robot`'s motion limits from a built-in table (`franka_panda`,
/// `franka_fr3`) for the joints it names.
///
/// # Errors
/// An unknown table (the message lists the known ones).
pub fn apply_builtin_limits(robot: &mut RobotModel, name: &str) -> Result<(), String> {
    let &known = BUILTIN_LIMITS.iter().find(|k| **k == name).ok_or_else(|| {
        format!(
            "no built-in joint limits named '{name}' (known: {})",
            BUILTIN_LIMITS.map(|k| format!("builtin:{k}")).join(", ")
        )
    })?;
    let names = robot.joint_names().to_vec();
    let sets: Vec<_> = names
        .iter()
        .filter_map(|j| builtin_limits(known, j).map(|(set, profile)| (j.as_str(), set, profile)))
        .collect();
    robot.apply_motion_limits(sets, &LimitSource::Builtin(known)).map_err(|e| e.to_string())
}

/// Sets `robot`'s motion limits from `spec`: `builtin:NAME` (see
/// [`apply_builtin_limits`]) or the path of a `joint_limits.yaml`, read
/// with `read` (a caller's own resolution of relative paths and of
/// embedded files).
///
/// # Errors
/// An unknown table (as a [`ProblemError::Invalid`] naming `spec`), or
/// what reading or applying the file returns.
pub fn apply_joint_limits(
    robot: &mut RobotModel,
    spec: &str,
    read: impl FnOnce(&str) -> Result<JointLimitsFile, ProblemError>,
) -> Result<(), ProblemError> {
    match spec.strip_prefix("builtin:") {
        Some(name) => apply_builtin_limits(robot, name).map_err(|message| ProblemError::Invalid {
            file: spec.to_string(),
            line: None,
            key: None,
            message,
        }),
        None => read(spec)?.apply_to(robot),
    }
}

/// The `joint_limits` mapping: at the root (MoveIt) or under one node's
/// `ros__parameters` (ros2_control).
fn find_table<'a>(root: &Node<'a>) -> Result<Node<'a>, ProblemError> {
    let direct = root.get("joint_limits");
    if !direct.is_absent() {
        root.fields(
            "a joint_limits.yaml",
            &["joint_limits", "default_velocity_scaling_factor", "default_acceleration_scaling_factor"],
        )?;
        return Ok(direct);
    }
    if let yaml_rust2::Yaml::Hash(map) = root.value
        && map.len() == 1
        && let Some(node) = map.keys().next().and_then(|k| k.as_str())
    {
        let params = root.get(node).get("ros__parameters");
        let table = params.get("joint_limits");
        if !table.is_absent() {
            return Ok(table);
        }
    }
    Err(root.error("has no `joint_limits` mapping (MoveIt: at the root; ros2_control: under <node>.ros__parameters)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_panda_file_is_the_builtin_table() {
        let file =
            JointLimitsFile::parse(include_str!("../../problems/robots/panda/joint_limits.yaml"), "panda").unwrap();
        let mut from_file = RobotModel::builder(std::sync::Arc::new(crate::robot::RobotDescription::panda()))
            .chain("panda_link0", "panda_hand_tcp")
            .build()
            .unwrap();
        file.apply_to(&mut from_file).unwrap();
        let builtin = RobotModel::panda();
        for (a, b) in from_file.motion_limits().iter().zip(builtin.motion_limits()) {
            assert_eq!(
                (a.velocity, a.acceleration, a.deceleration, a.jerk),
                (b.velocity, b.acceleration, b.deceleration, b.jerk)
            );
        }
        assert_eq!(builtin.motion_limits()[1].sources[3], LimitSource::Builtin("franka_panda"));
    }

    #[test]
    fn ros2_control_layout_and_errors_name_the_key() {
        let text = "limiter:\n  ros__parameters:\n    joint_limits:\n      panda_joint1:\n        has_acceleration_limits: true\n        max_acceleration: 5.0\n        has_deceleration_limits: true\n        max_deceleration: 7.5\n        has_jerk_limits: false\n        max_jerk: 1.0\n";
        let f = JointLimitsFile::parse(text, "limits.yaml").unwrap();
        assert_eq!(
            f.joints,
            vec![(
                "panda_joint1".into(),
                MotionLimitOverride { velocity: None, acceleration: Some(5.0), deceleration: Some(7.5), jerk: None }
            )]
        );
        let bad = "joint_limits:\n  panda_joint1:\n    has_jerk_limits: true\n    max_jerk: -3\n";
        let e = JointLimitsFile::parse(bad, "l.yaml").unwrap_err().to_string();
        assert!(e.contains("l.yaml") && e.contains("joint_limits.panda_joint1.max_jerk") && e.contains("-3"), "{e}");
        let unknown = "joint_limits:\n  panda_joint1:\n    max_acceleraton: 3\n";
        let e = JointLimitsFile::parse(unknown, "l.yaml").unwrap_err().to_string();
        assert!(e.contains("max_acceleraton"), "{e}");
        let missing = "joint_limits:\n  panda_joint1:\n    has_acceleration_limits: true\n";
        let e = JointLimitsFile::parse(missing, "l.yaml").unwrap_err().to_string();
        assert!(e.contains("max_acceleration") && e.contains("missing"), "{e}");
        let mut panda = RobotModel::panda();
        let typo = JointLimitsFile::parse("joint_limits:\n  panda_jiont1: {}\n", "l.yaml").unwrap();
        let e = typo.apply_to(&mut panda).unwrap_err().to_string();
        assert!(e.contains("panda_jiont1") && e.contains("panda_joint1"), "{e}");
    }

    #[test]
    fn the_fr3_table_limits_velocity_by_position() {
        let mut panda = RobotModel::panda();
        apply_builtin_limits(&mut panda, "franka_fr3").unwrap();
        let j4 = &panda.motion_limits()[3];
        assert_eq!((j4.acceleration, j4.jerk), (10.0, 5000.0));
        // libfranka: upward speed of joint 4 is zero at q = −0.1458.
        assert_eq!(j4.velocity_range(-0.1458, 1.0).1, 0.0);
        let (down, up) = j4.velocity_range(-1.5, 1.0);
        assert!(up > 2.0 && down < -2.0, "{down} {up}");
        assert!(apply_builtin_limits(&mut panda, "franka_ur5").unwrap_err().contains("builtin:franka_fr3"));
    }
}
