//! MoveIt inputs: a planning scene YAML (see [`read_moveit_scene`]:
//! collision objects of primitives, meshes and planes, fixed frames,
//! attached objects, an allowed collision matrix) and a motion plan request
//! YAML (group, start joint state, one joint goal) — the formats of
//! MotionBenchMaker's problems. [`Problem::from_moveit`] turns a URDF +
//! SRDF pair and these files into a [`Problem`]. Every field is read or
//! refused with an error naming the file and key: nothing is dropped in silence.

use super::moveit_scene::read_moveit_scene;
use super::moveit_yaml::{Node, load, parse};
use super::{Goal, OptimizerSettings, PlannerSettings, Problem, ProblemError, RobotSpec};
use crate::robot::{MeshSearchPath, RobotDescription, RobotModel, Srdf};
use std::path::Path;
use std::sync::Arc;

/// Planner clearance (m) of problems imported from MoveIt files.
pub const MOVEIT_CLEARANCE: f64 = 0.0005;

/// A MoveIt motion plan request with a joint-space goal.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveItRequest {
    /// The planning group (an SRDF group).
    pub group: String,
    /// Start joint values by name (all joints the request lists).
    pub start: Vec<(String, f64)>,
    /// Goal joint values by name (the goal constraint's joint constraints).
    pub goal: Vec<(String, f64)>,
}

const REQUEST_FIELDS: [&str; 15] = [
    "workspace_parameters",
    "start_state",
    "goal_constraints",
    "path_constraints",
    "trajectory_constraints",
    "reference_trajectories",
    "pipeline_id",
    "planner_id",
    "group_name",
    "num_planning_attempts",
    "allowed_planning_time",
    "max_velocity_scaling_factor",
    "max_acceleration_scaling_factor",
    "cartesian_speed_limited_link",
    "max_cartesian_speed",
];

const CONSTRAINT_LISTS: [&str; 4] =
    ["joint_constraints", "position_constraints", "orientation_constraints", "visibility_constraints"];

/// Reads a MoveIt motion plan request YAML (`moveit_msgs/MotionPlanRequest`).
///
/// Read: `group_name`, the start's `joint_state` (names and positions),
/// one goal constraint of joint constraints. Refused: other goal
/// constraints (position, orientation, visibility), several goal
/// constraints (alternatives tandem does not plan to), path and trajectory
/// constraints, reference trajectories, attached objects or a moved base in
/// the start state, duplicate joint names. Ignored (tandem's planner
/// settings apply): planner and pipeline ids, attempts, planning time,
/// scaling factors, workspace bounds, joint-constraint tolerances.
///
/// # Errors
/// Malformed YAML, unknown keys, a missing group, start state or joint
/// goal, names and positions of different lengths, anything refused above.
pub fn read_moveit_request(path: impl AsRef<Path>) -> Result<MoveItRequest, ProblemError> {
    let (file, doc) = load(path.as_ref())?;
    request_from_yaml(&file, &doc)
}

/// [`read_moveit_request`] of YAML text read from `origin` (a name for errors).
///
/// # Errors
/// As [`read_moveit_request`].
pub fn moveit_request_from_str(text: &str, origin: &str) -> Result<MoveItRequest, ProblemError> {
    request_from_yaml(origin, &parse(text, origin)?)
}

fn request_from_yaml(file: &str, doc: &yaml_rust2::Yaml) -> Result<MoveItRequest, ProblemError> {
    let root = Node::root(file, doc);
    if !matches!(doc, yaml_rust2::Yaml::Hash(_)) {
        return Err(root.error("a motion plan request must be a mapping (moveit_msgs/MotionPlanRequest)"));
    }
    root.fields("a motion plan request", &REQUEST_FIELDS)?;
    let group = root.required("group_name")?.text()?.to_string();
    let start_state = root.required("start_state")?;
    start_state
        .fields("a robot state", &["joint_state", "multi_dof_joint_state", "attached_collision_objects", "is_diff"])?;
    if !start_state.get("attached_collision_objects").items()?.is_empty() {
        return Err(start_state
            .get("attached_collision_objects")
            .error("attached objects belong in the planning scene's robot_state"));
    }
    let multi = start_state.get("multi_dof_joint_state");
    multi.fields("a multi-DOF joint state", &["header", "joint_names", "transforms", "twist", "wrench"])?;
    for t in multi.get("transforms").items()? {
        if (t.transform()?.to_homogeneous() - nalgebra::Matrix4::identity()).abs().max() > 1e-9 {
            return Err(t.error(
                "a multi-DOF joint away from identity moves the robot base, which tandem keeps at the URDF root",
            ));
        }
    }
    let state = start_state.required("joint_state")?;
    state.fields("a joint state", &["header", "name", "position", "velocity", "effort"])?;
    let names = state.required("name")?.texts()?;
    let positions = state.required("position")?.numbers()?;
    if names.len() != positions.len() {
        return Err(state.error(format!("{} names but {} positions", names.len(), positions.len())));
    }
    if let Some((k, name)) = names.iter().enumerate().find(|(k, n)| names[..*k].contains(n)) {
        return Err(state.get("name").error(format!("joint '{name}' is listed twice (entry {k})")));
    }
    let start = names.iter().map(|n| n.to_string()).zip(positions).collect();
    for key in ["path_constraints", "trajectory_constraints", "reference_trajectories"] {
        refuse_constraints(&root.get(key), key)?;
    }
    let goals = root.required("goal_constraints")?.items()?;
    let first = match goals.as_slice() {
        [one] => one,
        [] => return Err(root.get("goal_constraints").error("no goal constraint")),
        many => {
            return Err(root
                .get("goal_constraints")
                .error(format!("{} goal constraints (alternatives); tandem plans to one joint goal", many.len())));
        }
    };
    first.fields(
        "a goal constraint",
        &["name", "joint_constraints", "position_constraints", "orientation_constraints", "visibility_constraints"],
    )?;
    for key in &CONSTRAINT_LISTS[1..] {
        if !first.get(key).items()?.is_empty() {
            return Err(first.get(key).error("only joint constraints are supported as goals"));
        }
    }
    let mut goal: Vec<(String, f64)> = Vec::new();
    for c in first.required("joint_constraints")?.items()? {
        c.fields("a joint constraint", &["joint_name", "position", "tolerance_above", "tolerance_below", "weight"])?;
        let name = c.required("joint_name")?.text()?.to_string();
        if goal.iter().any(|(n, _)| *n == name) {
            return Err(c.get("joint_name").error(format!("joint '{name}' is constrained twice")));
        }
        goal.push((name, c.required("position")?.number()?));
    }
    Ok(MoveItRequest { group, start, goal })
}

/// Path and trajectory constraints and reference trajectories must be
/// empty: tandem would not honour them.
fn refuse_constraints(node: &Node, key: &str) -> Result<(), ProblemError> {
    let any = |n: &Node| -> Result<bool, ProblemError> {
        let mut found = false;
        for list in CONSTRAINT_LISTS {
            found |= !n.get(list).items()?.is_empty();
        }
        Ok(found)
    };
    let set = match key {
        "path_constraints" => {
            node.fields(
                "constraints",
                &[
                    "name",
                    "joint_constraints",
                    "position_constraints",
                    "orientation_constraints",
                    "visibility_constraints",
                ],
            )?;
            any(node)?
        }
        "trajectory_constraints" => {
            node.fields("trajectory constraints", &["constraints"])?;
            !node.get("constraints").items()?.is_empty()
        }
        _ => !node.items()?.is_empty(),
    };
    if set {
        return Err(node.error(format!("{key} are not supported: tandem would not honour them")));
    }
    Ok(())
}

/// Values of `joints` from `named`, or an error naming the missing one.
fn pick(file: &Path, what: &str, joints: &[String], named: &[(String, f64)]) -> Result<Vec<f64>, ProblemError> {
    joints
        .iter()
        .map(|j| {
            named.iter().find(|(n, _)| n == j).map(|(_, v)| *v).ok_or_else(|| ProblemError::Invalid {
                file: file.display().to_string(),
                line: None,
                key: Some(what.to_string()),
                message: format!("no value for joint '{j}'"),
            })
        })
        .collect()
}

/// How far outside a joint limit (rad or m) a MoveIt start or goal value
/// is read as the limit, with a warning: requests written with π rounded
/// differently from the URDF's limit (±π against ±3.14159, 2.7e-6 apart)
/// are what MoveIt plans, not errors.
pub const MOVEIT_LIMIT_TOLERANCE: f64 = 1e-4;

/// `value` of joint `name` within `[lower, upper]`: itself, or the limit
/// when at most [`MOVEIT_LIMIT_TOLERANCE`] beyond it (a warning says so);
/// `None` farther out (and for NaN).
fn snap_to_limits(
    name: &str,
    value: f64,
    lower: f64,
    upper: f64,
    what: &str,
    warnings: &mut Vec<String>,
) -> Option<f64> {
    let limit = if value < lower {
        lower
    } else if value > upper {
        upper
    } else {
        return (!value.is_nan()).then_some(value);
    };
    if (value - limit).abs() > MOVEIT_LIMIT_TOLERANCE {
        return None;
    }
    warnings.push(format!(
        "{what}: joint '{name}' = {value} is {:.1e} outside its limit {limit}; read as {limit}",
        (value - limit).abs()
    ));
    Some(limit)
}

impl Problem {
    /// A problem from MoveIt inputs: the robot from `urdf` with the joints
    /// of the request's SRDF group active (a MoveIt group: chains, joints,
    /// links and subgroups; see [`Srdf::joint_selection`]), every other movable joint the
    /// start names held at its value, the SRDF's disabled pairs, the
    /// scene's obstacles, attached objects and allowed contacts, the
    /// request's start and joint goal. SRDF entries and allowed-collision
    /// names the robot and scene lack are left out, as MoveIt does, and
    /// listed in [`Problem::warnings`].
    ///
    /// # Errors
    /// Any file unreadable or invalid; a group the SRDF lacks; a start
    /// naming a joint the URDF lacks, or missing an active joint; a goal
    /// constraining a joint outside the group or missing one; start, goal
    /// or held values outside their joint limits (naming the joint) by
    /// more than [`MOVEIT_LIMIT_TOLERANCE`] (closer ones are read as the
    /// limit, with a warning, as MoveIt does).
    pub fn from_moveit(urdf: &Path, srdf: &Path, scene_file: &Path, request: &Path) -> Result<Problem, ProblemError> {
        let invalid = |file: &Path, key: Option<&str>, e: &dyn std::fmt::Display| ProblemError::Invalid {
            file: file.display().to_string(),
            line: None,
            key: key.map(str::to_string),
            message: e.to_string(),
        };
        let search = MeshSearchPath::default().with_ros_package_path();
        let desc = Arc::new(RobotDescription::from_urdf_file(urdf, &search).map_err(|e| invalid(urdf, None, &e))?);
        let mut srdf_data = Srdf::from_srdf_file(srdf).map_err(|e| invalid(srdf, None, &e))?;
        let mut warnings: Vec<String> = srdf_data.reconcile(&desc).iter().map(ToString::to_string).collect();
        let req = read_moveit_request(request)?;
        let selection = srdf_data.joint_selection(&req.group).map_err(|e| invalid(request, Some("group_name"), &e))?;
        let probe = RobotModel::builder(desc.clone()).selection(selection.clone()).build();
        let probe = probe.map_err(|e| invalid(request, Some("group_name"), &e))?;
        let start_key = Some("start_state.joint_state");
        let mut hold: Vec<(String, f64)> = Vec::new();
        for (name, value) in &req.start {
            let joint = desc.joint(name).ok_or_else(|| {
                let close = crate::robot::suggest_names(name, desc.joints().iter().map(|j| j.name.as_str()));
                let message =
                    format!("no joint '{name}' in robot '{}'{}", desc.name(), crate::robot::did_you_mean(&close));
                invalid(request, start_key, &message)
            })?;
            // Fixed joints do not move and mimics follow their joint: their values say nothing.
            if probe.joint_names().contains(name) || !joint.kind.is_movable() || joint.mimic.is_some() {
                continue;
            }
            let (lo, hi) = (joint.limits.lower, joint.limits.upper);
            let Some(value) = snap_to_limits(name, *value, lo, hi, "start_state", &mut warnings) else {
                let message = format!("joint '{name}' = {value} is outside its limits [{lo}, {hi}]");
                return Err(invalid(request, start_key, &message));
            };
            hold.push((name.clone(), value));
        }
        let mut builder = RobotModel::builder(desc.clone()).selection(selection.clone());
        for (n, v) in &hold {
            builder = builder.hold(n.clone(), *v);
        }
        let robot = Arc::new(builder.build().map_err(|e| invalid(request, None, &e))?);
        if let Some((name, _)) = req.goal.iter().find(|(n, _)| !robot.joint_names().contains(n)) {
            let message =
                format!("joint '{name}' is not in group '{}' ({})", req.group, robot.joint_names().join(", "));
            return Err(invalid(request, Some("goal_constraints"), &message));
        }
        let mut start = pick(request, "start_state", robot.joint_names(), &req.start)?;
        let mut goal = pick(request, "goal_constraints", robot.joint_names(), &req.goal)?;
        for (what, q) in [("start_state", &mut start), ("goal_constraints", &mut goal)] {
            for ((value, limits), name) in q.iter_mut().zip(robot.limits()).zip(robot.joint_names()) {
                if let Some(snapped) = snap_to_limits(name, *value, limits.lower, limits.upper, what, &mut warnings) {
                    *value = snapped;
                }
            }
            robot.check_within_limits(q).map_err(|e| invalid(request, Some(what), &e))?;
        }
        let read = read_moveit_scene(scene_file, &desc, Some(&srdf_data))?;
        warnings.extend(read.warnings);
        let scene = read.scene;
        Ok(Problem {
            name: request.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
            description: format!("MoveIt request {} in scene {}", request.display(), scene_file.display()),
            origin: request.display().to_string(),
            robot_spec: RobotSpec {
                urdf: urdf.into(),
                srdf: Some(srdf.into()),
                collision_urdf: None,
                selection,
                hold,
                gripper: None,
                finger_pads: Vec::new(),
                max_grasp_depth: None,
                padding: 0.0,
                joint_limits: None,
            },
            robot,
            srdf: Some(srdf_data),
            collision_geometry: None,
            scene,
            start,
            goal: Goal::Joints(goal),
            // MoveIt goals may sit closer than the default 1 mm clearance
            // to an obstacle (MotionBenchMaker's bookshelf_small 19: 0.68 mm);
            // certify with half a millimetre instead.
            planner: PlannerSettings { clearance: MOVEIT_CLEARANCE, ..PlannerSettings::default() },
            optimizer: OptimizerSettings::default(),
            warnings,
        })
    }
}
