//! The TOML layout of problem files (serde), and its validation into a
//! [`Problem`]. Every check names the key it rejects.

use super::grasp::{GraspError, GripperGeometry};
use super::joint_limits::{JointLimitsFile, apply_joint_limits};
use super::toml_source::KeyPath;
use super::{Goal, Problem, ProblemError, RobotSpec, Source};
use crate::robot::{JointSelection, MeshSearchPath, RobotDescription, RobotModel, Srdf, TriMesh};
use crate::scene::{Obstacle, Scene, SceneObject, Shape};
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::sync::Arc;

mod check;
mod solver;
use check::{Check, axis_index};
pub use solver::{MAX_HORIZON, MAX_TIME_LIMIT, MIN_HORIZON, MIN_PLANNER_CLEARANCE, MIN_PLANNER_RESOLUTION};
use solver::{RawOptimizer, RawPlanner};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawProblem {
    name: String,
    #[serde(default)]
    description: String,
    robot: RawRobot,
    #[serde(default)]
    pub(crate) scene: RawScene,
    pub(crate) start: RawStart,
    goal: RawGoal,
    #[serde(default)]
    planner: RawPlanner,
    #[serde(default)]
    optimizer: RawOptimizer,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRobot {
    urdf: String,
    srdf: Option<String>,
    collision_urdf: Option<String>,
    #[serde(default)]
    package_dirs: Vec<String>,
    joints: Option<Vec<String>>,
    chain: Option<[String; 2]>,
    group: Option<String>,
    #[serde(default)]
    hold: BTreeMap<String, f64>,
    gripper: Option<String>,
    #[serde(default)]
    finger_pads: Vec<String>,
    max_grasp_depth: Option<f64>,
    #[serde(default)]
    padding: f64,
    joint_limits: Option<String>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawScene {
    pub(crate) table: Option<RawTable>,
    #[serde(default)]
    pub(crate) obstacles: Vec<RawBody>,
    #[serde(default)]
    pub(crate) objects: Vec<RawBody>,
    #[serde(default)]
    allowed_contacts: Vec<[String; 2]>,
    #[serde(default)]
    point_clouds: Vec<RawPointCloud>,
}

/// A point cloud file as an obstacle: balls of `point_radius` at its
/// points, placed by the sensor's pose.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPointCloud {
    name: Option<String>,
    file: String,
    point_radius: f64,
    spacing: Option<f64>,
    #[serde(default)]
    position: [f64; 3],
    rpy: Option<[f64; 3]>,
    quaternion: Option<[f64; 4]>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawTable {
    #[serde(default = "table_name")]
    name: String,
    /// Centre of the top surface (world, m).
    pub(crate) top: [f64; 3],
    size: [f64; 2],
    #[serde(default = "table_thickness")]
    thickness: f64,
}

fn table_name() -> String {
    "table".into()
}

fn table_thickness() -> f64 {
    0.04
}

/// An obstacle or object: name, shape, pose (and grasps for objects).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBody {
    pub(crate) name: String,
    shape: String,
    pub(crate) size: Option<Vec<f64>>,
    pub(crate) radius: Option<f64>,
    pub(crate) length: Option<f64>,
    mesh: Option<String>,
    scale: Option<[f64; 3]>,
    #[serde(default)]
    pub(crate) position: [f64; 3],
    pub(crate) rpy: Option<[f64; 3]>,
    quaternion: Option<[f64; 4]>,
    #[serde(default)]
    grasps: Vec<RawGrasp>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrasp {
    name: String,
    #[serde(default)]
    position: [f64; 3],
    rpy: Option<[f64; 3]>,
    quaternion: Option<[f64; 4]>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawStart {
    pub(crate) q: Vec<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGoal {
    q: Option<Vec<f64>>,
    frame: Option<String>,
    position: Option<[f64; 3]>,
    rpy: Option<[f64; 3]>,
    quaternion: Option<[f64; 4]>,
    axis: Option<String>,
    direction: Option<[f64; 3]>,
    grasp: Option<String>,
    grasp_frame: Option<String>,
}

impl Check<'_, '_> {
    fn pose(
        &self,
        path: &KeyPath,
        position: &[f64; 3],
        rpy: &Option<[f64; 3]>,
        quaternion: &Option<[f64; 4]>,
    ) -> Result<IsometryMatrix3<f64>, ProblemError> {
        self.finite(&path.key("position"), position)?;
        let rotation = match (rpy, quaternion) {
            (Some(_), Some(_)) => {
                return Err(self.src.error(&path.key("quaternion"), "give rpy or quaternion, not both"));
            }
            (Some(r), None) => {
                self.finite(&path.key("rpy"), r)?;
                Rotation3::from_euler_angles(r[0], r[1], r[2])
            }
            (None, Some(q)) => {
                self.finite(&path.key("quaternion"), q)?;
                let quat = nalgebra::Quaternion::new(q[3], q[0], q[1], q[2]);
                if (quat.norm() - 1.0).abs() > 1e-3 {
                    let msg = format!("must be a unit quaternion [x, y, z, w], has norm {:.4}", quat.norm());
                    return Err(self.src.error(&path.key("quaternion"), msg));
                }
                UnitQuaternion::from_quaternion(quat).to_rotation_matrix()
            }
            (None, None) => Rotation3::identity(),
        };
        Ok(IsometryMatrix3::from_parts(Translation3::from(Vector3::from(*position)), rotation))
    }

    fn shape(&self, path: &KeyPath, b: &RawBody) -> Result<Shape, ProblemError> {
        let need = |key: &str, v: Option<f64>| {
            v.ok_or_else(|| self.src.error(&path.key(key), format!("a {} needs `{key}`", b.shape)))
                .and_then(|v| self.positive(&path.key(key), v))
        };
        let unused = |keys: &[(&str, bool)]| match keys.iter().find(|(_, present)| *present) {
            Some((k, _)) => Err(self.src.error(&path.key(k), format!("does not apply to a {}", b.shape))),
            None => Ok(()),
        };
        let (size, radius, length) = (b.size.is_some(), b.radius.is_some(), b.length.is_some());
        let mesh = b.mesh.is_some() || b.scale.is_some();
        match b.shape.as_str() {
            "box" => {
                unused(&[("radius", radius), ("length", length), ("mesh", mesh)])?;
                let s = b.size.as_deref().ok_or_else(|| self.src.error(&path.key("size"), "a box needs `size`"))?;
                if s.len() != 3 {
                    return Err(self.src.error(&path.key("size"), format!("must hold 3 lengths, has {}", s.len())));
                }
                for (i, v) in s.iter().enumerate() {
                    self.positive(&path.key("size").index(i), *v)?;
                }
                Ok(Shape::cuboid([s[0], s[1], s[2]]))
            }
            "sphere" => {
                unused(&[("size", size), ("length", length), ("mesh", mesh)])?;
                Ok(Shape::sphere(need("radius", b.radius)?))
            }
            "cylinder" | "capsule" => {
                unused(&[("size", size), ("mesh", mesh)])?;
                let (r, l) = (need("radius", b.radius)?, need("length", b.length)?);
                Ok(if b.shape == "cylinder" { Shape::cylinder(r, l) } else { Shape::capsule(r, l) })
            }
            "mesh" => {
                unused(&[("size", size), ("radius", radius), ("length", length)])?;
                self.mesh(path, b)
            }
            other => Err(self.src.error(
                &path.key("shape"),
                format!("unknown shape '{other}' (expected box, sphere, cylinder, capsule or mesh)"),
            )),
        }
    }

    fn mesh(&self, path: &KeyPath, b: &RawBody) -> Result<Shape, ProblemError> {
        let key = path.key("mesh");
        let file = b.mesh.as_deref().ok_or_else(|| self.src.error(&key, "a mesh needs `mesh` (an STL or OBJ file)"))?;
        let scale = b.scale.unwrap_or([1.0; 3]);
        for (i, v) in scale.iter().enumerate() {
            self.positive(&path.key("scale").index(i), *v)?;
        }
        let full = self.src.resolve(file);
        let loaded = match full.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("obj") => TriMesh::from_obj_file(&full, scale),
            _ => TriMesh::from_stl_file(&full, scale),
        };
        let mesh = loaded.map_err(|e| self.src.error(&key, e.to_string()))?;
        Shape::convex_hull_of(&mesh).map_err(|e| self.src.error(&key, e.to_string()))
    }
}

impl RawProblem {
    pub(crate) fn into_problem(self, src: &Source) -> Result<Problem, ProblemError> {
        let check = Check { src };
        let root = KeyPath::root();
        let (robot_spec, robot, srdf, collision_geometry, warnings) = self.robot.load(&check, &root.key("robot"))?;
        let scene = self.scene.build(&check, &robot)?;
        let clash =
            robot_spec.finger_pads.iter().position(|p| scene.obstacle(p).is_some() || scene.object(p).is_some());
        if let Some(i) = clash {
            let at = root.key("robot").key("finger_pads").index(i);
            return Err(src.error(&at, "a finger pad needs a name apart from the scene's obstacles and objects"));
        }
        let start_path = root.key("start").key("q");
        check_configuration(&check, &robot, &start_path, &self.start.q)?;
        let goal = self.goal.build(&check, &root.key("goal"), &robot, &scene)?;
        if matches!(goal, Goal::Grasp { .. }) && robot_spec.gripper.is_none() {
            let msg = "a grasp goal needs `robot.gripper`, the frame that grasps";
            return Err(src.error(&root.key("goal").key("grasp"), msg));
        }
        let planner = self.planner.build(&check, &root.key("planner"))?;
        let optimizer = self.optimizer.build(&check, &root.key("optimizer"), &robot, &scene)?;
        let problem = Problem {
            name: self.name,
            description: self.description,
            origin: src.origin.to_string(),
            robot_spec,
            robot,
            srdf,
            collision_geometry,
            scene,
            start: self.start.q,
            goal,
            planner,
            optimizer,
            warnings,
        };
        check_grasp_depths(src, &problem)?;
        Ok(problem)
    }
}

/// Every grasp frame within the gripper's reach (see [`GripperGeometry`]).
fn check_grasp_depths(src: &Source, problem: &Problem) -> Result<(), ProblemError> {
    let spec = &problem.robot_spec;
    if spec.gripper.is_none() || (spec.finger_pads.is_empty() && spec.max_grasp_depth.is_none()) {
        return Ok(()); // no reach to check against
    }
    let at = |key: KeyPath, source: GraspError| {
        let line = super::toml_source::line_of_path(src.text, &key);
        ProblemError::Grasp { file: src.origin.to_string(), line, key: Some(key.to_string()), source: Box::new(source) }
    };
    let gripper = GripperGeometry::new(problem).map_err(|e| at(KeyPath::root().key("robot"), e))?;
    gripper.check_depths(problem).map_err(|e| {
        let (object, grasp) = match &e {
            GraspError::TooDeep { object, grasp, .. } => (object.as_str(), grasp.as_str()),
            _ => ("", ""),
        };
        let objects = problem.scene.objects();
        let i = objects.iter().position(|o| o.name == object).unwrap_or(0);
        let k = objects.get(i).and_then(|o| o.grasps.iter().position(|g| g.name == grasp)).unwrap_or(0);
        at(KeyPath::root().key("scene").key("objects").index(i).key("grasps").index(k), e)
    })
}

fn check_configuration(check: &Check, robot: &RobotModel, path: &KeyPath, q: &[f64]) -> Result<(), ProblemError> {
    if q.len() != robot.nq() {
        let names = robot.joint_names().join(", ");
        return Err(check
            .src
            .error(path, format!("has {} values, the robot has {} active joints ({names})", q.len(), robot.nq())));
    }
    check.finite(path, q)?;
    for (i, (v, l)) in q.iter().zip(robot.limits()).enumerate() {
        if !l.contains(*v) {
            let msg = format!("{} = {v} is outside its limits [{}, {}]", robot.joint_names()[i], l.lower, l.upper);
            return Err(check.src.error(&path.index(i), msg));
        }
    }
    Ok(())
}

/// The robot of a problem file, and the warnings loading it gave (SRDF
/// entries naming what the URDF lacks).
type LoadedRobot = (RobotSpec, Arc<RobotModel>, Option<Srdf>, Option<Arc<RobotDescription>>, Vec<String>);

impl RawRobot {
    fn load(self, check: &Check, path: &KeyPath) -> Result<LoadedRobot, ProblemError> {
        let src = check.src;
        let search = MeshSearchPath::new(self.package_dirs.iter().map(|d| src.resolve(d)));
        let description = |key: &str, file: &str| -> Result<Arc<RobotDescription>, ProblemError> {
            if src.base.is_none() && file == "robots/panda/panda.urdf" {
                return Ok(Arc::new(RobotDescription::panda()));
            }
            if src.base.is_none() && file == "robots/planar/planar_gripper.urdf" {
                return Ok(Arc::new(RobotDescription::planar_gripper()));
            }
            RobotDescription::from_urdf_file(src.resolve(file), &search)
                .map(Arc::new)
                .map_err(|e| src.error(&path.key(key), e.to_string()))
        };
        let desc = description("urdf", &self.urdf)?;
        let mut warnings = Vec::new();
        let srdf = match &self.srdf {
            Some(file) => {
                let mut s =
                    Srdf::from_srdf_file(src.resolve(file)).map_err(|e| src.error(&path.key("srdf"), e.to_string()))?;
                warnings.extend(s.reconcile(&desc).iter().map(ToString::to_string));
                Some(s)
            }
            None => None,
        };
        let selection = match (&self.joints, &self.chain, &self.group) {
            (Some(j), None, None) => JointSelection::Names(j.clone()),
            (None, Some([root, tip]), None) => JointSelection::Chain { root: root.clone(), tip: tip.clone() },
            (None, None, Some(g)) => {
                let srdf = srdf.as_ref().ok_or_else(|| src.error(&path.key("group"), "a group needs `srdf`"))?;
                srdf.joint_selection(g).map_err(|e| src.error(&path.key("group"), e.to_string()))?
            }
            (None, None, None) => JointSelection::Independent,
            (j, c, g) => {
                let given: Vec<&str> = [("joints", j.is_some()), ("chain", c.is_some()), ("group", g.is_some())]
                    .into_iter()
                    .filter_map(|(k, present)| present.then_some(k))
                    .collect();
                let last = src.last_in_file(path, &given);
                let others: Vec<String> = given.iter().filter(|k| **k != last).map(|k| format!("`{k}`")).collect();
                let msg =
                    format!("conflicts with {}: give only one of `joints`, `chain` or `group`", others.join(" and "));
                return Err(src.error(&path.key(last), msg));
            }
        };
        let plain = RobotModel::builder(desc.clone()).selection(selection.clone());
        let mut builder = plain.clone();
        for (joint, value) in &self.hold {
            builder = builder.hold(joint.clone(), *value);
        }
        let mut robot = builder.build().map_err(|e| {
            // Blame the joint selection when it fails on its own, else the
            // first held joint that fails.
            let at = if plain.clone().build().is_err() {
                let given = [("joints", self.joints.is_some()), ("chain", self.chain.is_some())];
                path.key(given.iter().find(|(_, present)| *present).map_or("urdf", |(k, _)| k))
            } else {
                let bad = self.hold.iter().find(|(j, v)| plain.clone().hold((*j).clone(), **v).build().is_err());
                bad.map_or(path.key("hold"), |(j, _)| path.key("hold").key(j))
            };
            src.error(&at, e.to_string())
        })?;
        if let Some(limits) = &self.joint_limits {
            let at = path.key("joint_limits");
            apply_joint_limits(&mut robot, limits, |file| {
                if src.base.is_none() && file == "robots/panda/joint_limits.yaml" {
                    JointLimitsFile::parse(include_str!("../../../problems/robots/panda/joint_limits.yaml"), file)
                } else {
                    JointLimitsFile::read(src.resolve(file))
                }
            })
            .map_err(|e| src.error(&at, e.to_string()))?;
        }
        let robot = Arc::new(robot);
        if let Some(g) = &self.gripper {
            robot.frame_id(g).map_err(|e| src.error(&path.key("gripper"), e.to_string()))?;
        }
        let padding = check.non_negative(&path.key("padding"), self.padding)?;
        let collision_geometry = match &self.collision_urdf {
            Some(file) => Some(description("collision_urdf", file)?),
            None => None,
        };
        self.check_grasping(check, path, collision_geometry.as_deref().unwrap_or(&desc))?;
        let spec = RobotSpec {
            urdf: src.resolve(&self.urdf),
            srdf: self.srdf.as_deref().map(|f| src.resolve(f)),
            collision_urdf: self.collision_urdf.as_deref().map(|f| src.resolve(f)),
            selection,
            hold: self.hold.into_iter().collect(),
            gripper: self.gripper,
            finger_pads: self.finger_pads,
            max_grasp_depth: self.max_grasp_depth,
            padding,
            joint_limits: self.joint_limits,
        };
        Ok((spec, robot, srdf, collision_geometry, warnings))
    }

    /// Finger pads name collision elements of `geometry` (not links) and
    /// need a gripper; a stated grasp depth is positive.
    fn check_grasping(&self, check: &Check, path: &KeyPath, geometry: &RobotDescription) -> Result<(), ProblemError> {
        let src = check.src;
        let elements = || geometry.links().iter().flat_map(|l| l.collisions.iter().filter_map(|c| c.name.as_deref()));
        for (i, pad) in self.finger_pads.iter().enumerate() {
            let at = path.key("finger_pads").index(i);
            if self.gripper.is_none() {
                return Err(src.error(&at, "finger pads need `robot.gripper`, the frame that grasps"));
            }
            if geometry.link(pad).is_some() {
                let msg = format!("'{pad}' is a link: name the pad's collision elements (<collision name=\"…\">)");
                return Err(src.error(&at, msg));
            }
            if !elements().any(|e| e == pad) {
                let hint = crate::robot::did_you_mean(&crate::robot::suggest_names(pad, elements()));
                return Err(src.error(&at, format!("no collision element of the robot is named '{pad}'{hint}")));
            }
        }
        if let Some(depth) = self.max_grasp_depth {
            check.positive(&path.key("max_grasp_depth"), depth)?;
            if self.gripper.is_none() {
                return Err(src.error(&path.key("max_grasp_depth"), "a grasp depth needs `robot.gripper`"));
            }
        }
        Ok(())
    }
}

impl RawScene {
    pub(crate) fn build(&self, check: &Check, robot: &RobotModel) -> Result<Scene, ProblemError> {
        let path = KeyPath::root().key("scene");
        let mut scene = Scene::new();
        let err = |p: &KeyPath, e: crate::scene::SceneError| check.src.error(p, e.to_string());
        if let Some(t) = &self.table {
            let p = path.key("table");
            check.finite(&p.key("top"), &t.top)?;
            check.positive(&p.key("size").index(0), t.size[0])?;
            check.positive(&p.key("size").index(1), t.size[1])?;
            check.positive(&p.key("thickness"), t.thickness)?;
            scene.add_obstacle(Obstacle::table(t.name.clone(), t.top, t.size, t.thickness)).map_err(|e| err(&p, e))?;
        }
        for (i, b) in self.obstacles.iter().enumerate() {
            let p = path.key("obstacles").index(i);
            if !b.grasps.is_empty() {
                return Err(check.src.error(&p.key("grasps"), "obstacles have no grasps (make it an object)"));
            }
            let shape = check.shape(&p, b)?;
            let pose = check.pose(&p, &b.position, &b.rpy, &b.quaternion)?;
            scene.add_obstacle(Obstacle::new(b.name.clone(), shape, pose)).map_err(|e| err(&p.key("name"), e))?;
        }
        for (i, c) in self.point_clouds.iter().enumerate() {
            let p = path.key("point_clouds").index(i);
            let radius = check.positive(&p.key("point_radius"), c.point_radius)?;
            let pose = check.pose(&p, &c.position, &c.rpy, &c.quaternion)?;
            if let Some(spacing) = c.spacing {
                check.positive(&p.key("spacing"), spacing)?;
            }
            // Thinned (as it is read: a large file is never held whole),
            // every removed point lies within the spacing of a kept one: the
            // kept points' balls grow by it to cover theirs.
            let file = check.src.resolve(&c.file);
            let settings =
                crate::point_cloud::FilterSettings { spacing: c.spacing.unwrap_or(0.0), ..Default::default() };
            let (cloud, report) = crate::point_cloud::PointCloud::read_filtered(&file, &settings)
                .map_err(|e| check.src.error(&p.key("file"), e.to_string()))?;
            let margin = report.radius_margin;
            let name = c.name.clone().unwrap_or_else(|| {
                let taken = |n: &str| scene.obstacle(n).is_some() || scene.object(n).is_some();
                (0..)
                    .map(|k| if k == 0 { "point_cloud".to_string() } else { format!("point_cloud_{k}") })
                    .find(|n| !taken(n))
                    .unwrap_or_default()
            });
            let obstacle = Obstacle::point_cloud(name, &cloud, radius + margin, pose)
                .map_err(|e| check.src.error(&p.key("point_radius"), e.to_string()))?;
            scene.add_obstacle(obstacle).map_err(|e| err(&p.key("name"), e))?;
        }
        for (i, b) in self.objects.iter().enumerate() {
            let p = path.key("objects").index(i);
            let mut object = SceneObject::new(
                b.name.clone(),
                check.shape(&p, b)?,
                check.pose(&p, &b.position, &b.rpy, &b.quaternion)?,
            );
            for (k, g) in b.grasps.iter().enumerate() {
                if b.grasps[..k].iter().any(|other| other.name == g.name) {
                    let msg = format!("'{}' has two grasp frames named '{}'", b.name, g.name);
                    return Err(check.src.error(&p.key("grasps").index(k).key("name"), msg));
                }
                object.add_grasp(
                    g.name.clone(),
                    check.pose(&p.key("grasps").index(k), &g.position, &g.rpy, &g.quaternion)?,
                );
            }
            scene.add_object(object).map_err(|e| err(&p.key("name"), e))?;
        }
        let links: Vec<&str> = robot.description().links().iter().map(|l| l.name.as_str()).collect();
        for (i, [a, b]) in self.allowed_contacts.iter().enumerate() {
            for (k, n) in [a, b].into_iter().enumerate() {
                let known = links.contains(&n.as_str()) || scene.obstacle(n).is_some() || scene.object(n).is_some();
                if !known {
                    let p = path.key("allowed_contacts").index(i).index(k);
                    return Err(check.src.error(&p, format!("no link, obstacle or object named '{n}'")));
                }
            }
            scene.allow_contact(a.clone(), b.clone());
        }
        Ok(scene)
    }
}

impl RawGoal {
    fn build(self, check: &Check, path: &KeyPath, robot: &RobotModel, scene: &Scene) -> Result<Goal, ProblemError> {
        let src = check.src;
        let pose_keys = self.frame.is_some() || self.position.is_some();
        // The first key of each goal kind given, to name a conflict.
        let kinds: Vec<&str> = [
            ("q", self.q.is_some()),
            (if self.frame.is_some() { "frame" } else { "position" }, pose_keys),
            ("grasp", self.grasp.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, present)| present.then_some(k))
        .collect();
        // Keys that only some goal kinds read.
        let unused = |kind: &str, keys: &[(&str, bool)]| match keys.iter().find(|(_, present)| *present) {
            Some((k, _)) => Err(src.error(&path.key(k), format!("does not apply to a {kind} goal"))),
            None => Ok(()),
        };
        let orientation_keys = [
            ("rpy", self.rpy.is_some()),
            ("quaternion", self.quaternion.is_some()),
            ("axis", self.axis.is_some()),
            ("direction", self.direction.is_some()),
        ];
        match (self.q, pose_keys, self.grasp) {
            (Some(q), false, None) => {
                unused("joint", &orientation_keys)?;
                unused("joint", &[("grasp_frame", self.grasp_frame.is_some())])?;
                check_configuration(check, robot, &path.key("q"), &q)?;
                Ok(Goal::Joints(q))
            }
            (None, true, None) => {
                unused("pose", &[("grasp_frame", self.grasp_frame.is_some())])?;
                let frame = self.frame.ok_or_else(|| src.error(path, "a pose goal needs `frame`"))?;
                robot.frame_id(&frame).map_err(|e| src.error(&path.key("frame"), e.to_string()))?;
                let position = self.position.ok_or_else(|| src.error(path, "a pose goal needs `position`"))?;
                check.finite(&path.key("position"), &position)?;
                let orientation = match (self.rpy, self.quaternion) {
                    (None, None) => None,
                    (r, q) => Some(check.pose(path, &position, &r, &q)?.rotation),
                };
                let axis_alignment = match (self.axis, self.direction) {
                    (None, None) => None,
                    (Some(a), Some(d)) => {
                        let axis = axis_index(&a).ok_or_else(|| src.error(&path.key("axis"), "must be x, y or z"))?;
                        let dir = Vector3::from(d);
                        if dir.norm().is_nan() || dir.norm() <= 1e-9 || !dir.iter().all(|v| v.is_finite()) {
                            return Err(src.error(&path.key("direction"), "must be a non-zero finite vector"));
                        }
                        Some((axis, dir.normalize()))
                    }
                    _ => return Err(src.error(path, "`axis` and `direction` go together")),
                };
                Ok(Goal::Pose { frame, position: position.into(), orientation, axis_alignment })
            }
            (None, false, Some(object)) => {
                unused("grasp", &orientation_keys)?;
                let obj = scene
                    .object(&object)
                    .ok_or_else(|| src.error(&path.key("grasp"), format!("the scene has no object '{object}'")))?;
                let grasp = match self.grasp_frame {
                    Some(g) => g,
                    None => obj.grasps.first().map(|g| g.name.clone()).ok_or_else(|| {
                        src.error(&path.key("grasp"), format!("object '{object}' has no grasp frame"))
                    })?,
                };
                scene.grasp_pose(&object, &grasp).map_err(|e| src.error(&path.key("grasp_frame"), e.to_string()))?;
                Ok(Goal::Grasp { object, grasp })
            }
            _ if kinds.len() > 1 => {
                let last = src.last_in_file(path, &kinds);
                let others: Vec<String> = kinds.iter().filter(|k| **k != last).map(|k| format!("`{k}`")).collect();
                let msg = format!(
                    "conflicts with {}: give exactly one kind of goal: `q`, a pose (`frame`, `position`, …) or `grasp`",
                    others.join(" and ")
                );
                Err(src.error(&path.key(last), msg))
            }
            _ => Err(src.error(path, "give exactly one kind of goal: `q`, a pose (`frame`, `position`, …) or `grasp`")),
        }
    }
}
