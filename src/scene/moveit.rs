//! MoveIt inputs: a planning scene YAML (collision objects of box,
//! cylinder and sphere primitives with poses, and an allowed collision
//! matrix) and a motion plan request YAML (group, start joint state, joint
//! goal constraints) — the formats of MotionBenchMaker's problems.
//! [`Problem::from_moveit`] turns a URDF + SRDF pair and these files into a
//! [`Problem`].

use super::problem::{Goal, OptimizerSettings, PlannerSettings, Problem, ProblemError, RobotSpec};

/// Planner clearance (m) of problems imported from MoveIt files.
pub const MOVEIT_CLEARANCE: f64 = 0.0005;
use super::toml_source::KeyPath;
use super::{Obstacle, Scene};
use crate::collision::Shape;
use crate::robot::{MeshSearchPath, RobotDescription, RobotModel, Srdf};
use nalgebra::{IsometryMatrix3, Quaternion, Translation3, UnitQuaternion, Vector3};
use std::path::Path;
use std::sync::Arc;
use yaml_rust2::{Yaml, YamlLoader};

/// A node of a YAML document with its key path, for errors.
struct Node<'a> {
    file: &'a str,
    path: KeyPath,
    value: &'a Yaml,
}

impl<'a> Node<'a> {
    fn error(&self, message: impl Into<String>) -> ProblemError {
        let key = self.path.to_string();
        ProblemError::Invalid {
            file: self.file.to_string(),
            line: None,
            key: (!key.is_empty()).then_some(key),
            message: message.into(),
        }
    }

    fn get(&self, key: &str) -> Node<'a> {
        Node { file: self.file, path: self.path.key(key), value: &self.value[key] }
    }

    fn required(&self, key: &str) -> Result<Node<'a>, ProblemError> {
        let n = self.get(key);
        if n.value.is_badvalue() || n.value.is_null() { Err(n.error("missing")) } else { Ok(n) }
    }

    fn items(&self) -> Result<Vec<Node<'a>>, ProblemError> {
        match self.value {
            Yaml::Array(items) => Ok(items
                .iter()
                .enumerate()
                .map(|(i, value)| Node { file: self.file, path: self.path.index(i), value })
                .collect()),
            Yaml::BadValue | Yaml::Null => Ok(Vec::new()),
            _ => Err(self.error("must be a list")),
        }
    }

    fn number(&self) -> Result<f64, ProblemError> {
        let v = match self.value {
            Yaml::Integer(i) => *i as f64,
            other => other.as_f64().ok_or_else(|| self.error("must be a number"))?,
        };
        if v.is_finite() { Ok(v) } else { Err(self.error(format!("must be finite, got {v}"))) }
    }

    fn numbers(&self) -> Result<Vec<f64>, ProblemError> {
        self.items()?.iter().map(Node::number).collect()
    }

    fn text(&self) -> Result<&'a str, ProblemError> {
        self.value.as_str().ok_or_else(|| self.error("must be a string"))
    }

    fn texts(&self) -> Result<Vec<&'a str>, ProblemError> {
        self.items()?.iter().map(Node::text).collect()
    }
}

fn load(path: &Path) -> Result<(String, Yaml), ProblemError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ProblemError::Io { path: path.into(), source })?;
    let mut docs = YamlLoader::load_from_str(&text).map_err(|e| ProblemError::Invalid {
        file: file.clone(),
        line: Some(e.marker().line() as u32),
        key: None,
        message: format!("malformed YAML: {}", e.info()),
    })?;
    let doc = docs.pop().filter(|d| !d.is_null()).ok_or_else(|| ProblemError::Invalid {
        file: file.clone(),
        line: None,
        key: None,
        message: "empty YAML document".into(),
    })?;
    Ok((file, doc))
}

/// A `{position: [x, y, z], orientation: [x, y, z, w]}` pose.
fn pose(node: &Node) -> Result<IsometryMatrix3<f64>, ProblemError> {
    let p = node.required("position")?;
    let o = node.required("orientation")?;
    let (pv, ov) = (p.numbers()?, o.numbers()?);
    if pv.len() != 3 {
        return Err(p.error(format!("must hold 3 numbers, has {}", pv.len())));
    }
    if ov.len() != 4 {
        return Err(o.error(format!("must hold 4 numbers [x, y, z, w], has {}", ov.len())));
    }
    let q = Quaternion::new(ov[3], ov[0], ov[1], ov[2]);
    if (q.norm() - 1.0).abs() > 1e-3 {
        return Err(o.error(format!("must be a unit quaternion, has norm {:.4}", q.norm())));
    }
    let rotation = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
    Ok(IsometryMatrix3::from_parts(Translation3::from(Vector3::new(pv[0], pv[1], pv[2])), rotation))
}

/// A MoveIt `SolidPrimitive`: box [x, y, z], cylinder [height, radius],
/// sphere [radius] (m).
fn primitive(node: &Node) -> Result<Shape, ProblemError> {
    let kind = node.required("type")?;
    let dims_node = node.required("dimensions")?;
    let dims = dims_node.numbers()?;
    let need = |n: usize| {
        if dims.len() == n && dims.iter().all(|d| *d > 0.0) {
            Ok(())
        } else {
            Err(dims_node
                .error(format!("a {} needs {n} positive dimensions, got {dims:?}", kind.value.as_str().unwrap_or("?"))))
        }
    };
    match kind.text()? {
        "box" => need(3).map(|_| Shape::cuboid([dims[0], dims[1], dims[2]])),
        "cylinder" => need(2).map(|_| Shape::cylinder(dims[1], dims[0])),
        "sphere" => need(1).map(|_| Shape::sphere(dims[0])),
        other => Err(kind.error(format!("unsupported primitive '{other}' (expected box, cylinder or sphere)"))),
    }
}

/// Reads a MoveIt planning scene YAML: every collision object's
/// primitives become obstacles (named `id`, then `id/1`, `id/2`, … for
/// further primitives); `true` entries of the allowed collision matrix
/// become allowed contacts.
///
/// # Errors
/// Unreadable or malformed YAML, unsupported primitives, bad dimensions or
/// poses — each naming the file and key path.
pub fn read_moveit_scene(path: impl AsRef<Path>) -> Result<Scene, ProblemError> {
    let (file, doc) = load(path.as_ref())?;
    let root = Node { file: &file, path: KeyPath::root(), value: &doc };
    let mut scene = Scene::new();
    for object in root.get("world").get("collision_objects").items()? {
        let id = object.required("id")?.text()?;
        // Newer MoveIt gives the object a pose and primitive poses relative to it.
        let base = match object.get("pose").value {
            Yaml::BadValue | Yaml::Null => IsometryMatrix3::identity(),
            _ => pose(&object.get("pose"))?,
        };
        let poses = object.get("primitive_poses").items()?;
        let primitives = object.get("primitives").items()?;
        if poses.len() != primitives.len() {
            return Err(object.error(format!("{} primitives but {} primitive_poses", primitives.len(), poses.len())));
        }
        for (k, (prim, p)) in primitives.iter().zip(&poses).enumerate() {
            let name = if k == 0 { id.to_string() } else { format!("{id}/{k}") };
            let obstacle = Obstacle::new(name, primitive(prim)?, base * pose(p)?);
            scene.add_obstacle(obstacle).map_err(|e| prim.error(e.to_string()))?;
        }
    }
    let acm = root.get("allowed_collision_matrix");
    let names = acm.get("entry_names").texts()?;
    for (i, row) in acm.get("entry_values").items()?.iter().enumerate() {
        for (j, cell) in row.items()?.iter().enumerate() {
            if j > i && cell.value.as_bool() == Some(true) {
                let (a, b) = (names.get(i), names.get(j));
                let (Some(a), Some(b)) = (a, b) else {
                    return Err(cell.error("the matrix is larger than entry_names"));
                };
                scene.allow_contact(*a, *b);
            }
        }
    }
    Ok(scene)
}

/// A MoveIt motion plan request with a joint-space goal.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveItRequest {
    pub group: String,
    /// Start joint values by name (all joints the request lists).
    pub start: Vec<(String, f64)>,
    /// Goal joint values by name (the first goal constraint's joint constraints).
    pub goal: Vec<(String, f64)>,
}

/// Reads a MoveIt motion plan request YAML.
///
/// # Errors
/// Malformed YAML, a missing group, start state or joint goal, names and
/// positions of different lengths.
pub fn read_moveit_request(path: impl AsRef<Path>) -> Result<MoveItRequest, ProblemError> {
    let (file, doc) = load(path.as_ref())?;
    let root = Node { file: &file, path: KeyPath::root(), value: &doc };
    let group = root.required("group_name")?.text()?.to_string();
    let state = root.required("start_state")?.required("joint_state")?;
    let names = state.required("name")?.texts()?;
    let positions = state.required("position")?.numbers()?;
    if names.len() != positions.len() {
        return Err(state.error(format!("{} names but {} positions", names.len(), positions.len())));
    }
    let start = names.iter().map(|n| n.to_string()).zip(positions).collect();
    let goals = root.required("goal_constraints")?.items()?;
    let first = goals.first().ok_or_else(|| root.get("goal_constraints").error("no goal constraint"))?;
    let mut goal = Vec::new();
    for c in first.required("joint_constraints")?.items()? {
        goal.push((c.required("joint_name")?.text()?.to_string(), c.required("position")?.number()?));
    }
    Ok(MoveItRequest { group, start, goal })
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

impl Problem {
    /// A problem from MoveIt inputs: the robot from `urdf` with the joints
    /// of the request's SRDF group active (held joints at their start
    /// values when within limits), the SRDF's disabled pairs, the scene's
    /// obstacles and allowed contacts, the request's start and joint goal.
    ///
    /// # Errors
    /// Any file unreadable or invalid; a group the SRDF lacks; start or goal
    /// missing an active joint or outside the limits.
    pub fn from_moveit(urdf: &Path, srdf: &Path, scene_file: &Path, request: &Path) -> Result<Problem, ProblemError> {
        let invalid = |file: &Path, e: &dyn std::fmt::Display| ProblemError::Invalid {
            file: file.display().to_string(),
            line: None,
            key: None,
            message: e.to_string(),
        };
        let search = MeshSearchPath::default().with_ros_package_path();
        let desc = Arc::new(RobotDescription::from_urdf_file(urdf, &search).map_err(|e| invalid(urdf, &e))?);
        let srdf_data = Srdf::from_srdf_file(srdf).map_err(|e| invalid(srdf, &e))?;
        srdf_data.check_against(&desc).map_err(|e| invalid(srdf, &e))?;
        let req = read_moveit_request(request)?;
        let selection = srdf_data.joint_selection(&req.group).map_err(|e| invalid(request, &e))?;
        let probe = RobotModel::builder(desc.clone()).selection(selection.clone()).build();
        let probe = probe.map_err(|e| invalid(request, &e))?;
        // Other movable joints are held where the request starts them (when legal).
        let hold: Vec<(String, f64)> = req
            .start
            .iter()
            .filter(|(n, v)| {
                !probe.joint_names().contains(n)
                    && desc.joint(n).is_some_and(|j| j.kind.is_movable() && j.mimic.is_none() && j.limits.contains(*v))
            })
            .cloned()
            .collect();
        let mut builder = RobotModel::builder(desc.clone()).selection(selection.clone());
        for (n, v) in &hold {
            builder = builder.hold(n.clone(), *v);
        }
        let robot = Arc::new(builder.build().map_err(|e| invalid(request, &e))?);
        let start = pick(request, "start_state", robot.joint_names(), &req.start)?;
        let goal = pick(request, "goal_constraints", robot.joint_names(), &req.goal)?;
        for (what, q) in [("start_state", &start), ("goal_constraints", &goal)] {
            robot.check_configuration(q).map_err(|e| invalid(request, &format!("{what}: {e}")))?;
        }
        let scene = read_moveit_scene(scene_file)?;
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
        })
    }
}
