//! MoveIt planning scene YAML (`moveit_msgs/PlanningScene`) into a
//! [`Scene`]: every field of the message is either read or refused with a
//! named error; nothing is dropped in silence.
//!
//! - `world.collision_objects`: primitives (box, cylinder, sphere, cone is
//!   refused), meshes (each becomes its convex hull, as URDF meshes do:
//!   conservative — a point inside the hull counts as a collision), planes
//!   (half-spaces: the side the normal `(a, b, c)` points away from is
//!   solid, modelled as a box [`PLANE_EXTENT`] on a side and half as deep
//!   whose top face is the plane: exact within that distance of the world
//!   origin). Poses are in `header.frame_id`; the object `pose` places the
//!   object and its shapes' poses are relative to it. `operation`: add
//!   (replaces an object of the same id), remove (one id, or every object
//!   for an empty id), append (shapes added to an object), move (a new
//!   `pose`, shapes kept).
//! - Frames: the planning frame (empty, the URDF root link, or the parent
//!   frame of an SRDF virtual joint whose child is the root, with an
//!   identity `robot_state.multi_dof_joint_state`), and the frames of
//!   `fixed_frame_transforms` given in it. Other frames (robot links, whose
//!   pose depends on the robot state) are refused.
//! - `robot_state.attached_collision_objects`: objects attached to
//!   `link_name` (poses in that link's frame), touching it and its
//!   `touch_links`. The robot state's joint values are not read: the start
//!   comes from the request.
//! - `allowed_collision_matrix`: `true` entries become allowed contacts; a
//!   `true` default entry is refused. Entries naming no robot link,
//!   obstacle or object are kept out and reported in
//!   [`MoveItScene::warnings`], as MoveIt keeps and ignores them (an ACM
//!   saved for a robot with a gripper, loaded for the arm alone); so are
//!   unknown `touch_links`.
//! - `world.octomap`: a binary `OcTree` (as MoveIt's occupancy map
//!   monitor publishes it), its occupied cells an obstacle `octomap` of
//!   balls covering them ([`PointCloud::from_octomap_binary`](crate::point_cloud::PointCloud::from_octomap_binary)).
//! - Refused unless neutral: `link_padding` (must be 0), `link_scale` (1),
//!   multi-DOF transforms (identity).
//!   Ignored: `name`, `robot_model_name`, `object_colors`, `is_diff`,
//!   object `type` and subframes.

use super::ProblemError;
use super::moveit_yaml::{Node, load, parse};
use crate::robot::{RobotDescription, Srdf, TriMesh};
use crate::scene::{Obstacle, Scene, SceneObject, Shape};
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3, Vector3};
use std::path::Path;

/// Side of the box standing in for a plane's half-space (m): distances to
/// it are those to the half-space for points within half this distance of
/// the plane's point nearest the world origin.
pub const PLANE_EXTENT: f64 = 200.0;

const SCENE_FIELDS: [&str; 10] = [
    "name",
    "robot_state",
    "robot_model_name",
    "fixed_frame_transforms",
    "allowed_collision_matrix",
    "link_padding",
    "link_scale",
    "object_colors",
    "world",
    "is_diff",
];

const OBJECT_FIELDS: [&str; 13] = [
    "header",
    "pose",
    "id",
    "type",
    "primitives",
    "primitive_poses",
    "meshes",
    "mesh_poses",
    "planes",
    "plane_poses",
    "subframe_names",
    "subframe_poses",
    "operation",
];

/// One collision object as the operations leave it: its id, pose (world)
/// and shapes (poses relative to the object).
struct MoveItObject {
    id: String,
    pose: IsometryMatrix3<f64>,
    shapes: Vec<(Shape, IsometryMatrix3<f64>)>,
}

/// Known frames: name and pose in the world (the URDF root frame).
struct Frames {
    known: Vec<(String, IsometryMatrix3<f64>)>,
    root: String,
}

impl Frames {
    fn resolve(&self, node: &Node, name: &str) -> Result<IsometryMatrix3<f64>, ProblemError> {
        if let Some((_, pose)) = self.known.iter().find(|(n, _)| n == name) {
            return Ok(*pose);
        }
        let names: Vec<&str> = self.known.iter().map(|(n, _)| n.as_str()).filter(|n| !n.is_empty()).collect();
        Err(node.error(format!(
            "frame '{name}' is not the planning frame or a fixed frame (known: {}); poses in a robot link's frame \
             depend on the robot state, which tandem does not apply to the scene: give them in '{}'",
            names.join(", "),
            self.root
        )))
    }
}

/// A planning scene as read, and what reading it tolerated.
#[derive(Debug, Clone)]
pub struct MoveItScene {
    /// The obstacles, attached objects and allowed contacts.
    pub scene: Scene,
    /// One line per entry left out because it names nothing tandem knows
    /// (allowed-collision-matrix names, touch links), naming file and key.
    pub warnings: Vec<String>,
}

/// Reads a MoveIt planning scene YAML for `robot` (and its SRDF, whose
/// virtual joint names the planning frame); see the module documentation
/// for what is read and what is refused.
///
/// # Errors
/// Unreadable or malformed YAML, a document that is not a planning scene
/// (unknown keys, e.g. a motion plan request), unsupported shapes or
/// fields, bad dimensions, poses or frames — each naming the file and key path.
pub fn read_moveit_scene(
    path: impl AsRef<Path>,
    robot: &RobotDescription,
    srdf: Option<&Srdf>,
) -> Result<MoveItScene, ProblemError> {
    let (file, doc) = load(path.as_ref())?;
    scene_from_yaml(&file, &doc, robot, srdf)
}

/// [`read_moveit_scene`] of YAML text read from `origin` (a name for errors).
///
/// # Errors
/// As [`read_moveit_scene`].
pub fn moveit_scene_from_str(
    text: &str,
    origin: &str,
    robot: &RobotDescription,
    srdf: Option<&Srdf>,
) -> Result<MoveItScene, ProblemError> {
    scene_from_yaml(origin, &parse(text, origin)?, robot, srdf)
}

fn scene_from_yaml(
    file: &str,
    doc: &yaml_rust2::Yaml,
    robot: &RobotDescription,
    srdf: Option<&Srdf>,
) -> Result<MoveItScene, ProblemError> {
    let root = Node::root(file, doc);
    if !matches!(doc, yaml_rust2::Yaml::Hash(_)) {
        return Err(root.error("a planning scene must be a mapping (moveit_msgs/PlanningScene)"));
    }
    if let Err(e) = root.fields("a planning scene", &SCENE_FIELDS) {
        let request_keys = ["group_name", "goal_constraints", "start_state"];
        let looks_like_request = request_keys.iter().any(|k| !root.get(k).is_absent());
        return Err(if looks_like_request {
            root.error(format!("{e} — this looks like a motion plan request, not a planning scene"))
        } else {
            e
        });
    }
    let frames = frames(&root, robot, srdf)?;
    neutral_links(&root)?;
    let world = root.get("world");
    world.fields("the world", &["collision_objects", "octomap"])?;
    let mut objects: Vec<MoveItObject> = Vec::new();
    for object in world.get("collision_objects").items()? {
        apply(&object, &frames, &mut objects)?;
    }
    let mut scene = Scene::new();
    if let Some(octomap) = octomap(&world.get("octomap"), &frames)? {
        scene.add_obstacle(octomap).map_err(|e| root.error(format!("the octomap: {e}")))?;
    }
    for o in &objects {
        for (k, (shape, pose)) in o.shapes.iter().enumerate() {
            let obstacle = Obstacle::new(shape_name(&o.id, k), shape.clone(), o.pose * pose);
            scene.add_obstacle(obstacle).map_err(|e| root.error(format!("collision object '{}': {e}", o.id)))?;
        }
    }
    let mut warnings = Vec::new();
    attached_objects(&root.get("robot_state"), robot, &mut scene, &mut warnings)?;
    allowed_collisions(&root.get("allowed_collision_matrix"), robot, &mut scene, &mut warnings)?;
    Ok(MoveItScene { scene, warnings })
}

/// `world.octomap` (`octomap_msgs/OctomapWithPose`): its occupied cells as
/// an obstacle named `octomap`, a ball around each cell's centre that
/// covers the cell (radius `resolution × √3 / 2`), placed by `origin` in
/// the header's frame; `None` without data.
fn octomap(node: &Node, frames: &Frames) -> Result<Option<Obstacle>, ProblemError> {
    node.fields("an octomap with its pose", &["header", "origin", "octomap"])?;
    let map = node.get("octomap");
    map.fields("an octomap", &["header", "binary", "id", "resolution", "data"])?;
    let data = map.get("data");
    let bytes: Vec<u8> = data
        .numbers()?
        .iter()
        .map(|&v| match v {
            // int8 in the message; 0–255 accepted as the same bytes.
            v if v.fract() == 0.0 && (-128.0..=255.0).contains(&v) => Ok(v as i64 as u8),
            v => Err(data.error(format!("{v} is not a byte (int8)"))),
        })
        .collect::<Result<_, _>>()?;
    if bytes.is_empty() {
        return Ok(None);
    }
    let binary = map.get("binary");
    if binary.value.as_bool() != Some(true) {
        return Err(binary.error(
            "only binary octomaps are read (binary: true, as MoveIt's occupancy map monitor publishes): a full \
             map's occupancy values are not",
        ));
    }
    let id = map.required("id")?;
    if id.text()? != "OcTree" {
        return Err(id.error(format!("octree type '{}' (only OcTree is read)", id.text()?)));
    }
    let resolution = map.required("resolution")?;
    let cloud = crate::point_cloud::PointCloud::from_octomap_binary(&bytes, resolution.number()?, node.file)
        .map_err(|e| data.error(e.message))?;
    let frame = frames.resolve(&node.get("header"), node.header_frame()?)?;
    let origin = node.get("origin");
    let origin = if origin.is_absent() { IsometryMatrix3::identity() } else { origin.pose()? };
    let radius = resolution.number()? * 3f64.sqrt() / 2.0;
    Obstacle::point_cloud("octomap", &cloud, radius, frame * origin).map(Some).map_err(|e| data.error(e.to_string()))
}

/// Obstacle names of an object's shapes: `id`, then `id/1`, `id/2`, ….
fn shape_name(id: &str, k: usize) -> String {
    if k == 0 { id.to_string() } else { format!("{id}/{k}") }
}

/// The planning frame, its synonyms and the fixed frames.
fn frames(root: &Node, robot: &RobotDescription, srdf: Option<&Srdf>) -> Result<Frames, ProblemError> {
    let state = root.get("robot_state");
    state
        .fields("a robot state", &["joint_state", "multi_dof_joint_state", "attached_collision_objects", "is_diff"])?;
    state.get("joint_state").fields("a joint state", &["header", "name", "position", "velocity", "effort"])?;
    identity_multi_dof(&state.get("multi_dof_joint_state"))?;
    let identity = IsometryMatrix3::identity();
    let mut known = vec![(String::new(), identity), (robot.root_link().to_string(), identity)];
    for v in srdf.iter().flat_map(|s| &s.virtual_joints).filter(|v| v.child_link == robot.root_link()) {
        known.push((v.parent_frame.clone(), identity));
    }
    let frames = Frames { known, root: robot.root_link().to_string() };
    let mut fixed = Vec::new();
    for t in root.get("fixed_frame_transforms").items()? {
        t.fields("a transform stamped", &["header", "child_frame_id", "transform"])?;
        let parent = frames.resolve(&t.get("header").get("frame_id"), t.header_frame()?)?;
        let child = t.required("child_frame_id")?.text()?.to_string();
        fixed.push((child, parent * t.required("transform")?.transform()?));
    }
    let mut frames = frames;
    for (name, pose) in fixed {
        match frames.known.iter().find(|(n, _)| *n == name) {
            // Restating the planning frame as itself is harmless; moving it is not.
            Some((_, existing)) if (existing.to_homogeneous() - pose.to_homogeneous()).abs().max() > 1e-9 => {
                return Err(root
                    .get("fixed_frame_transforms")
                    .error(format!("frame '{name}' is the planning frame or given twice, with another transform")));
            }
            Some(_) => {}
            None => frames.known.push((name, pose)),
        }
    }
    Ok(frames)
}

/// A multi-DOF joint state must leave the robot base where the URDF puts it.
fn identity_multi_dof(node: &Node) -> Result<(), ProblemError> {
    node.fields("a multi-DOF joint state", &["header", "joint_names", "transforms", "twist", "wrench"])?;
    for t in node.get("transforms").items()? {
        let pose = t.transform()?;
        if (pose.to_homogeneous() - nalgebra::Matrix4::identity()).abs().max() > 1e-9 {
            return Err(t.error(
                "a multi-DOF joint away from identity moves the robot base, which tandem keeps at the URDF root",
            ));
        }
    }
    Ok(())
}

/// `link_padding` must be 0 and `link_scale` 1 for every link.
fn neutral_links(root: &Node) -> Result<(), ProblemError> {
    for (key, field, neutral) in [("link_padding", "padding", 0.0), ("link_scale", "scale", 1.0)] {
        for item in root.get(key).items()? {
            item.fields(key, &["link_name", field])?;
            let value = item.required(field)?.number()?;
            if value != neutral {
                let link = item.get("link_name").text_or_empty()?;
                return Err(item.get(field).error(format!(
                    "{field} {value} for link '{link}': per-link {field} is not supported (only {neutral}); pad all links with the problem's robot.padding instead"
                )));
            }
        }
    }
    Ok(())
}

/// Applies one collision object message to `objects`.
fn apply(node: &Node, frames: &Frames, objects: &mut Vec<MoveItObject>) -> Result<(), ProblemError> {
    node.fields("a collision object", &OBJECT_FIELDS)?;
    let id = node.get("id").text_or_empty()?.to_string();
    let operation = operation(&node.get("operation"))?;
    let at = objects.iter().position(|o| o.id == id);
    match operation {
        Operation::Remove => {
            match (id.is_empty(), at) {
                (true, _) => objects.clear(),
                (false, Some(i)) => {
                    objects.remove(i);
                }
                (false, None) => return Err(node.get("id").error(format!("cannot remove '{id}': no such object"))),
            }
            return Ok(());
        }
        Operation::Move => {
            let i = at.ok_or_else(|| node.get("id").error(format!("cannot move '{id}': no such object")))?;
            if !shapes(node, &id)?.is_empty() {
                return Err(node.error("a move gives a new `pose` only; its shapes stay (append to add shapes)"));
            }
            objects[i].pose = object_pose(node, frames)?;
            return Ok(());
        }
        Operation::Add | Operation::Append => {}
    }
    if id.is_empty() {
        return Err(node.required("id")?.error("must not be empty"));
    }
    let shapes = shapes(node, &id)?;
    let pose = object_pose(node, frames)?;
    match (operation, at) {
        (Operation::Append, Some(i)) => {
            // Appended shapes are posed in the message's object frame; keep them relative to the existing one.
            let relative = objects[i].pose.inverse() * pose;
            objects[i].shapes.extend(shapes.into_iter().map(|(s, p)| (s, relative * p)));
        }
        (_, Some(i)) => objects[i] = MoveItObject { id, pose, shapes },
        (_, None) => objects.push(MoveItObject { id, pose, shapes }),
    }
    Ok(())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Operation {
    Add,
    Remove,
    Append,
    Move,
}

/// `operation`: 0 add (the default), 1 remove, 2 append, 3 move, or their names.
fn operation(node: &Node) -> Result<Operation, ProblemError> {
    if node.is_absent() {
        return Ok(Operation::Add);
    }
    let named = node.value.as_str().map(str::to_ascii_lowercase);
    let number = node.value.as_i64();
    match (named.as_deref(), number) {
        (Some("add"), _) | (_, Some(0)) => Ok(Operation::Add),
        (Some("remove"), _) | (_, Some(1)) => Ok(Operation::Remove),
        (Some("append"), _) | (_, Some(2)) => Ok(Operation::Append),
        (Some("move"), _) | (_, Some(3)) => Ok(Operation::Move),
        _ => Err(node.error("must be add (0), remove (1), append (2) or move (3)")),
    }
}

/// The object's world pose: its header frame, then its `pose` (identity when absent).
fn object_pose(node: &Node, frames: &Frames) -> Result<IsometryMatrix3<f64>, ProblemError> {
    let frame = frames.resolve(&node.get("header").get("frame_id"), node.header_frame()?)?;
    let pose = node.get("pose");
    Ok(if pose.is_absent() { frame } else { frame * pose.pose()? })
}

/// Every shape of an object message with its pose relative to the object.
fn shapes(node: &Node, id: &str) -> Result<Vec<(Shape, IsometryMatrix3<f64>)>, ProblemError> {
    let mut out = Vec::new();
    for (list, poses_key) in [("primitives", "primitive_poses"), ("meshes", "mesh_poses"), ("planes", "plane_poses")] {
        let shapes = node.get(list).items()?;
        let poses = node.get(poses_key).items()?;
        // Planes without poses lie in the object frame.
        let no_poses = list == "planes" && poses.is_empty();
        if shapes.len() != poses.len() && !no_poses {
            let message = format!("object '{id}': {} {list} but {} {poses_key}", shapes.len(), poses.len());
            return Err(node.error(message));
        }
        for (k, item) in shapes.iter().enumerate() {
            let pose = if no_poses { IsometryMatrix3::identity() } else { poses[k].pose()? };
            out.push(match list {
                "primitives" => (primitive(item)?, pose),
                "meshes" => (mesh(item)?, pose),
                _ => (half_space(), pose * plane_pose(item)?),
            });
        }
    }
    Ok(out)
}

/// A `shape_msgs/SolidPrimitive`: box `[x, y, z]`, cylinder `[height,
/// radius]`, sphere `[radius]` (m).
fn primitive(node: &Node) -> Result<Shape, ProblemError> {
    node.fields("a solid primitive", &["type", "dimensions", "polygon"])?;
    if !node.get("polygon").is_absent() {
        return Err(node.get("polygon").error("prism primitives are not supported"));
    }
    let kind = node.required("type")?;
    let dims_node = node.required("dimensions")?;
    let dims = dims_node.numbers()?;
    // The message's type constants: BOX = 1, SPHERE = 2, CYLINDER = 3, CONE = 4, PRISM = 5.
    let name = match (kind.value.as_str(), kind.value.as_i64()) {
        (Some(s), _) => s.to_ascii_lowercase(),
        (None, Some(1)) => "box".into(),
        (None, Some(2)) => "sphere".into(),
        (None, Some(3)) => "cylinder".into(),
        (None, Some(4)) => "cone".into(),
        (None, Some(5)) => "prism".into(),
        _ => return Err(kind.error("must be box, cylinder or sphere (or 1, 3, 2)")),
    };
    let need = |n: usize| {
        if dims.len() == n && dims.iter().all(|d| *d > 0.0) {
            Ok(())
        } else {
            Err(dims_node.error(format!("a {name} needs {n} positive dimensions, got {dims:?}")))
        }
    };
    match name.as_str() {
        "box" => need(3).map(|_| Shape::cuboid([dims[0], dims[1], dims[2]])),
        "cylinder" => need(2).map(|_| Shape::cylinder(dims[1], dims[0])),
        "sphere" => need(1).map(|_| Shape::sphere(dims[0])),
        other => Err(kind.error(format!("unsupported primitive '{other}' (expected box, cylinder or sphere)"))),
    }
}

/// A `shape_msgs/Mesh` as the convex hull of its vertices (m).
fn mesh(node: &Node) -> Result<Shape, ProblemError> {
    node.fields("a mesh", &["vertices", "triangles"])?;
    let vertices: Vec<Point3<f64>> =
        node.required("vertices")?.items()?.iter().map(|v| v.vector3().map(Point3::from)).collect::<Result<_, _>>()?;
    let mut triangles = Vec::new();
    for t in node.get("triangles").items()? {
        let indices = t.one_field("a mesh triangle", "vertex_indices")?;
        let ids = indices.numbers()?;
        let valid =
            ids.len() == 3 && ids.iter().all(|&i| i >= 0.0 && i.fract() == 0.0 && (i as usize) < vertices.len());
        if !valid {
            return Err(indices.error(format!("must be 3 vertex indices below {}, got {ids:?}", vertices.len())));
        }
        triangles.push([ids[0] as u32, ids[1] as u32, ids[2] as u32]);
    }
    let mesh = TriMesh { vertices, triangles };
    Shape::convex_hull_of(&mesh).map_err(|e| node.get("vertices").error(e.to_string()))
}

/// The box standing in for a half-space (see [`PLANE_EXTENT`]), placed by [`plane_pose`].
fn half_space() -> Shape {
    Shape::cuboid([PLANE_EXTENT, PLANE_EXTENT, PLANE_EXTENT / 2.0])
}

/// The unit normal and offset of a plane message.
fn plane_coefficients(node: &Node) -> Result<(Vector3<f64>, f64), ProblemError> {
    let coef = node.one_field("a plane", "coef")?;
    let c = coef.numbers()?;
    let normal = match c.as_slice() {
        [a, b, c, _] => Vector3::new(*a, *b, *c),
        _ => return Err(coef.error(format!("must hold 4 coefficients [a, b, c, d], has {}", c.len()))),
    };
    let norm = normal.norm();
    if norm.is_nan() || norm <= 1e-9 {
        return Err(coef.error("the normal (a, b, c) must not be zero"));
    }
    Ok((normal / norm, c[3] / norm))
}

/// Pose of the half-space box of a `shape_msgs/Plane` `{coef: [a, b, c,
/// d]}` (`a x + b y + c z + d = 0`) in the plane's frame: the box fills
/// `a x + b y + c z + d ≤ 0` near the plane, its top face on the plane,
/// its z axis along the normal.
fn plane_pose(node: &Node) -> Result<IsometryMatrix3<f64>, ProblemError> {
    let (n, d) = plane_coefficients(node)?;
    // The plane's point nearest the frame origin, then half a depth inside.
    let foot = -d * n;
    let center = foot - n * (PLANE_EXTENT / 4.0);
    let rotation = Rotation3::rotation_between(&Vector3::z(), &n)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
    Ok(IsometryMatrix3::from_parts(Translation3::from(center), rotation))
}

/// `robot_state.attached_collision_objects`: scene objects attached to their link.
fn attached_objects(
    state: &Node,
    robot: &RobotDescription,
    scene: &mut Scene,
    warnings: &mut Vec<String>,
) -> Result<(), ProblemError> {
    for a in state.get("attached_collision_objects").items()? {
        a.fields("an attached collision object", &["link_name", "object", "touch_links", "detach_posture", "weight"])?;
        let link_node = a.required("link_name")?;
        let link = link_node.text()?;
        if robot.link(link).is_none() {
            return Err(link_node.error(format!("no link '{link}' in robot '{}'", robot.name())));
        }
        let object = a.required("object")?;
        object.fields("a collision object", &OBJECT_FIELDS)?;
        if !matches!(operation(&object.get("operation"))?, Operation::Add | Operation::Append) {
            return Err(object
                .get("operation")
                .error("an attached object must be added (a removal has nothing to remove)"));
        }
        let frame = object.header_frame()?;
        if !frame.is_empty() && frame != link {
            return Err(object.get("header").get("frame_id").error(format!(
                "an object attached to '{link}' must be posed in that link's frame (empty or '{link}'), not '{frame}'"
            )));
        }
        let id = object.required("id")?.text()?;
        let pose = match object.get("pose") {
            p if p.is_absent() => IsometryMatrix3::identity(),
            p => p.pose()?,
        };
        let touch = a.get("touch_links").texts()?;
        for (k, (shape, local)) in shapes(&object, id)?.into_iter().enumerate() {
            let name = shape_name(id, k);
            let o = SceneObject::new(name.clone(), shape, IsometryMatrix3::identity());
            scene.add_object(o).map_err(|e| object.error(e.to_string()))?;
            scene.attach(&name, link, pose * local).map_err(|e| object.error(e.to_string()))?;
            scene.allow_contact(link, name.clone());
            for t in &touch {
                if robot.link(t).is_none() {
                    let message = format!("no link '{t}' in robot '{}'; touch link ignored", robot.name());
                    warnings.push(a.get("touch_links").error(message).to_string());
                    continue;
                }
                scene.allow_contact(*t, name.clone());
            }
        }
    }
    Ok(())
}

/// `true` entries of the allowed collision matrix become allowed contacts;
/// names that are no robot link, obstacle or object are left out with a
/// warning (once per name).
fn allowed_collisions(
    acm: &Node,
    robot: &RobotDescription,
    scene: &mut Scene,
    warnings: &mut Vec<String>,
) -> Result<(), ProblemError> {
    acm.fields(
        "an allowed collision matrix",
        &["entry_names", "entry_values", "default_entry_names", "default_entry_values"],
    )?;
    let names = acm.get("entry_names").texts()?;
    let known = |n: &str| robot.link(n).is_some() || scene.obstacle(n).is_some() || scene.object(n).is_some();
    let unknown: Vec<bool> = names.iter().map(|n| !known(n)).collect();
    let name_nodes = acm.get("entry_names").items()?;
    for ((name, node), _) in names.iter().zip(&name_nodes).zip(&unknown).filter(|(_, u)| **u) {
        let close = crate::robot::suggest_names(
            name,
            robot.links().iter().map(|l| l.name.as_str()).chain(scene.obstacles().iter().map(|o| o.name.as_str())),
        );
        let message = format!(
            "no link, obstacle or object named '{name}'{}; its entries are ignored, as MoveIt does",
            crate::robot::did_you_mean(&close)
        );
        warnings.push(node.error(message).to_string());
    }
    let rows = acm.get("entry_values").items()?;
    if rows.len() != names.len() {
        return Err(acm.get("entry_values").error(format!("{} rows for {} entry_names", rows.len(), names.len())));
    }
    for (i, row) in rows.iter().enumerate() {
        let cells = row.one_field("a matrix row", "enabled")?.items()?;
        if cells.len() != names.len() {
            return Err(row.error(format!("{} values for {} entry_names", cells.len(), names.len())));
        }
        for (j, cell) in cells.iter().enumerate() {
            let allowed = cell.value.as_bool().ok_or_else(|| cell.error("must be true or false"))?;
            if j > i && allowed && !unknown[i] && !unknown[j] {
                scene.allow_contact(names[i], names[j]);
            }
        }
    }
    let defaults = acm.get("default_entry_values");
    for (k, v) in defaults.items()?.iter().enumerate() {
        if v.value.as_bool().ok_or_else(|| v.error("must be true or false"))? {
            let name = acm.get("default_entry_names").items()?.get(k).and_then(|n| n.value.as_str()).unwrap_or("?");
            return Err(v.error(format!(
                "a default entry allowing '{name}' to touch everything is not supported: list its pairs in entry_values"
            )));
        }
    }
    Ok(())
}
