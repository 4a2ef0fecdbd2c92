//! A problem's world in MuJoCo: the robot compiled from its URDF, the
//! problem's obstacles as static geoms, its movable objects as free bodies,
//! position servos on the arm joints and on the gripper's held joints, and
//! contact settings for grasping.
//!
//! **Contacts.** MuJoCo's advice for grasping: elliptic friction cones,
//! `impratio` 10 (stiffer friction than normal forces), 3 no-slip
//! iterations (no creep of a held object), `multiccd` (several contact
//! points between flat faces, so a box rests on its face and between flat
//! pads), `condim` 4 (torsional friction, so a box held at two pads does not
//! spin about their axis), the `implicitfast` integrator. The robot does not
//! collide with itself in physics (its self-distances are the arbiter's
//! hard constraints); the robot touches obstacles and objects, objects touch
//! everything.
//!
//! **The hand.** The Panda's collision spheres enclose its fingers
//! generously (they leave 1 mm between an open finger and the 6 cm box);
//! for contacts the fingers get the four collision boxes of
//! example-robot-data's `panda.urdf` (Franka's finger, 80 mm between the
//! open pads). The rest of the arm keeps the spheres the arbiter avoids.
//!
//! **Servos.** Each arm joint is a position servo with velocity
//! feed-forward (`kp` = 50 × the joint's effort limit per rad, `kv` =
//! `kp`/10, force clamped to the effort limit) under gravity compensation,
//! as a torque-controlled arm running a joint impedance controller; the
//! held joints (the fingers) are servos of 1000 N/m clamped to their effort
//! limit (the Franka Hand's 70 N).

use super::{PhysicsError, robot_urdf};
use crate::problem::Problem;
use crate::scene::Shape;
use crate::sim::PhysicsSettings;
use mujoco_rs::prelude::*;
use nalgebra::{IsometryMatrix3, UnitQuaternion};
use std::fmt::Write;
use std::sync::Arc;

/// The finger links replaced for contacts, with the side (+1 left, −1
/// right) their boxes mirror to.
const PANDA_FINGERS: [(&str, f64); 2] = [("panda_leftfinger", 1.0), ("panda_rightfinger", -1.0)];

/// example-robot-data's finger collision boxes (left finger): origin
/// (x, y, z m), roll (rad), full size (m).
const PANDA_FINGER_BOXES: [([f64; 3], f64, [f64; 3]); 4] = [
    ([0.0, 18.5e-3, 11e-3], 0.0, [22e-3, 15e-3, 20e-3]),
    ([0.0, 6.8e-3, 2.2e-3], 0.0, [22e-3, 8.8e-3, 3.8e-3]),
    ([0.0, 15.9e-3, 28.35e-3], std::f64::consts::FRAC_PI_6, [17.5e-3, 7e-3, 23.5e-3]),
    ([0.0, 7.58e-3, 45.25e-3], 0.0, [17.5e-3, 15.2e-3, 18.5e-3]),
];

/// A triangle mesh as a free body of the physics scene.
#[derive(Debug, Clone, Copy)]
pub struct SceneMesh<'a> {
    /// Its name (bodies and geoms are `object_{name}`).
    pub name: &'a str,
    /// Its surface, in its own frame (m).
    pub mesh: &'a crate::perception::TriangleMesh,
    /// Where it starts in the world.
    pub pose: IsometryMatrix3<f64>,
    /// Its mass (kg).
    pub mass: f64,
}

/// Which part of the world a MuJoCo geom belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeomRole {
    /// A link of the robot.
    Robot,
    /// A static obstacle (the table, another arm).
    Obstacle,
    /// A movable object (index into the problem's objects).
    Object(usize),
}

/// A joint servo: where the joint sits in `qpos` and `qvel`, its actuator.
#[derive(Debug, Clone, Copy)]
struct Servo {
    qpos: usize,
    actuator: usize,
}

/// An arm servo's stiffness per newton-metre (or newton) of effort limit (1/rad or 1/m).
const ARM_KP_PER_EFFORT: f64 = 50.0;
/// An arm servo's `kp / kv` (1/s): `kv / kp` is its damping's time
/// constant, and the factor of the velocity feed-forward that cancels the
/// damping's drag at the commanded velocity.
const ARM_KP_OVER_KV: f64 = 10.0;
/// `kv / kp` (s): the velocity feed-forward's factor.
const ARM_LEAD: f64 = 1.0 / ARM_KP_OVER_KV;

/// A problem's world compiled by MuJoCo (shared, read-only; one
/// [`MjData`] per thread).
pub struct PhysicsScene {
    model: Arc<MjModel>,
    xml: String,
    arm: Vec<Servo>,
    /// Held joints (the fingers): servo, open value (the hold), closed
    /// value (the lower limit).
    grip: Vec<(Servo, f64, f64)>,
    /// Joints that mimic a held one: `qpos`, the held joint's `qpos`,
    /// multiplier, offset (their start values).
    mimics: Vec<(usize, usize, f64, f64)>,
    /// Free bodies of the movable objects: body id, `qpos` address, start pose.
    objects: Vec<(usize, usize, [f64; 7])>,
    object_names: Vec<String>,
    roles: Vec<GeomRole>,
    timestep: f64,
}

impl PhysicsScene {
    /// Compiles `problem`'s robot and scene; the physics step divides
    /// `period` (s, the control period) into whole steps no longer than
    /// `settings.max_timestep`.
    ///
    /// # Errors
    /// Bad settings, an unreadable URDF, MuJoCo refusing the model, a joint
    /// missing from it.
    pub fn new(problem: &Problem, period: f64, settings: &PhysicsSettings) -> Result<PhysicsScene, PhysicsError> {
        PhysicsScene::with_meshes(problem, period, settings, &[])
    }

    /// As [`Self::new`], with free bodies of triangle meshes beside the
    /// problem's objects (the perception experiment's seven objects): they
    /// follow the problem's objects in [`Self::object_names`] and in
    /// [`GeomRole::Object`]'s index.
    ///
    /// # Errors
    /// As [`Self::new`]; a mesh of a non-positive or non-finite mass.
    pub fn with_meshes(
        problem: &Problem,
        period: f64,
        settings: &PhysicsSettings,
        meshes: &[SceneMesh<'_>],
    ) -> Result<PhysicsScene, PhysicsError> {
        settings.validate().map_err(PhysicsError::Settings)?;
        if !(period.is_finite() && period > 0.0) {
            return Err(PhysicsError::Settings(format!("control period {period} s must be finite and positive")));
        }
        let substeps = (period / settings.max_timestep - 1e-9).ceil().max(1.0);
        let timestep = period / substeps;
        let robot = &problem.robot;
        let urdf = with_contact_fingers(&robot_urdf(robot)?)?;
        let robot_xml = robot_mjcf(&urdf)?;
        let xml = scene_mjcf(&robot_xml, problem, meshes, timestep, settings)?;
        let model = MjModel::from_xml_string(&xml).map_err(|e| PhysicsError::Compile(format!("{e:?}")))?;
        let joint = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_JOINT, name)
                .ok_or_else(|| PhysicsError::Missing { kind: "joint", name: name.to_string() })
        };
        let actuator = |name: &str| {
            model
                .name_to_id(MjtObjBase::mjOBJ_ACTUATOR, &format!("servo_{name}"))
                .ok_or_else(|| PhysicsError::Missing { kind: "actuator", name: name.to_string() })
        };
        let qposadr = model.jnt_qposadr();
        let arm = robot
            .joint_names()
            .iter()
            .map(|name| Ok(Servo { qpos: qposadr[joint(name)?] as usize, actuator: actuator(name)? }))
            .collect::<Result<Vec<_>, PhysicsError>>()?;
        let mut grip = vec![];
        for (name, value) in &problem.robot_spec.hold {
            let j = joint(name)?;
            let lower = model.jnt_range()[j][0];
            grip.push((Servo { qpos: qposadr[j] as usize, actuator: actuator(name)? }, *value, lower));
        }
        let mut mimics = vec![];
        let joints = robot.description().joints();
        for j in joints {
            let Some(m) = &j.mimic else { continue };
            let target = &joints[m.joint].name;
            if problem.robot_spec.hold.iter().any(|(held, _)| held == target) {
                mimics.push((
                    qposadr[joint(&j.name)?] as usize,
                    qposadr[joint(target)?] as usize,
                    m.multiplier,
                    m.offset,
                ));
            }
        }
        let mut objects = vec![];
        let mut object_names = vec![];
        let placed = problem.scene.objects().iter().map(|o| (o.name.as_str(), &o.pose));
        for (name, pose) in placed.chain(meshes.iter().map(|m| (m.name, &m.pose))) {
            let body = model
                .name_to_id(MjtObjBase::mjOBJ_BODY, &format!("object_{name}"))
                .ok_or_else(|| PhysicsError::Missing { kind: "body", name: name.to_string() })?;
            let adr = qposadr[model.body_jntadr()[body] as usize] as usize;
            objects.push((body, adr, pose7(pose)));
            object_names.push(name.to_string());
        }
        let robot_root = model
            .name_to_id(MjtObjBase::mjOBJ_BODY, robot.description().links().first().map_or("", |l| l.name.as_str()))
            .map(|b| model.body_rootid()[b]);
        let roles = model
            .geom_bodyid()
            .iter()
            .map(|&b| {
                let root = model.body_rootid()[b as usize];
                if b == 0 {
                    GeomRole::Obstacle
                } else if Some(root) == robot_root {
                    GeomRole::Robot
                } else {
                    objects.iter().position(|o| o.0 == root as usize).map_or(GeomRole::Obstacle, GeomRole::Object)
                }
            })
            .collect();
        Ok(PhysicsScene { model: Arc::new(model), xml, arm, grip, mimics, objects, object_names, roles, timestep })
    }

    /// The compiled model.
    pub fn model(&self) -> &Arc<MjModel> {
        &self.model
    }

    /// The scene as MJCF, for MuJoCo's viewer (`python -m mujoco.viewer
    /// --mjcf=scene.xml`) or another simulator.
    pub fn mjcf(&self) -> &str {
        &self.xml
    }

    /// The physics step (s).
    pub fn timestep(&self) -> f64 {
        self.timestep
    }

    /// A fresh simulation state (one per thread).
    pub fn data(&self) -> MjData<Arc<MjModel>> {
        MjData::new(self.model.clone())
    }

    /// The problem's movable objects, in its order.
    pub fn object_names(&self) -> &[String] {
        &self.object_names
    }

    /// Which part of the world geom `g` belongs to.
    pub fn role(&self, g: usize) -> GeomRole {
        self.roles.get(g).copied().unwrap_or(GeomRole::Obstacle)
    }

    /// The name of geom `g`'s body for a robot geom (its link), else the
    /// geom's own (the obstacle's or object's name).
    pub fn geom_label(&self, g: usize) -> String {
        let m = &self.model;
        let name = match self.role(g) {
            GeomRole::Robot => m.id_to_name(MjtObjBase::mjOBJ_BODY, m.geom_bodyid()[g] as usize),
            _ => m.id_to_name(MjtObjBase::mjOBJ_GEOM, g),
        };
        name.unwrap_or("an unnamed geom").trim_start_matches("object_").to_string()
    }

    /// Puts the world in its start state: the arm at `q` (rad or m, the
    /// robot's joint order) at rest, the gripper open, the objects where
    /// the problem puts them; the servos hold that state.
    pub fn reset(&self, data: &mut MjData<Arc<MjModel>>, q: &[f64]) {
        data.reset();
        let qpos = data.qpos_mut();
        for (servo, &v) in self.arm.iter().zip(q) {
            qpos[servo.qpos] = v;
        }
        for (servo, open, _) in &self.grip {
            qpos[servo.qpos] = *open;
        }
        for &(joint, target, multiplier, offset) in &self.mimics {
            qpos[joint] = multiplier * qpos[target] + offset;
        }
        for (_, adr, pose) in &self.objects {
            qpos[*adr..*adr + 7].copy_from_slice(pose);
        }
        self.set_targets(data, q, None, false);
        data.forward();
    }

    /// Servo targets: the arm at `q` moving at `qdot` (velocity
    /// feed-forward; `None` for rest), the gripper open or closed.
    pub fn set_targets(&self, data: &mut MjData<Arc<MjModel>>, q: &[f64], qdot: Option<&[f64]>, closed: bool) {
        let ctrl = data.ctrl_mut();
        for (j, servo) in self.arm.iter().enumerate() {
            ctrl[servo.actuator] = q[j] + qdot.map_or(0.0, |v| ARM_LEAD * v[j]);
        }
        for (servo, open, shut) in &self.grip {
            ctrl[servo.actuator] = if closed { *shut } else { *open };
        }
    }

    /// The arm's measured joint positions (rad or m) into `q`.
    pub fn arm_positions(&self, data: &MjData<Arc<MjModel>>, q: &mut [f64]) {
        let qpos = data.qpos();
        for (v, servo) in q.iter_mut().zip(&self.arm) {
            *v = qpos[servo.qpos];
        }
    }

    /// Object `k`'s pose: position (m) and quaternion (w, x, y, z), world.
    pub fn object_pose(&self, data: &MjData<Arc<MjModel>>, k: usize) -> [f64; 7] {
        let (_, adr, _) = self.objects[k];
        let mut pose = [0.0; 7];
        pose.copy_from_slice(&data.qpos()[adr..adr + 7]);
        pose
    }

    /// Object `k`'s start pose.
    pub fn object_start(&self, k: usize) -> [f64; 7] {
        self.objects[k].2
    }
}

/// Position and quaternion (w, x, y, z) of `pose`.
fn pose7(pose: &IsometryMatrix3<f64>) -> [f64; 7] {
    let t = pose.translation.vector;
    let q = UnitQuaternion::from_rotation_matrix(&pose.rotation);
    [t.x, t.y, t.z, q.w, q.i, q.j, q.k]
}

/// `urdf` with the Panda fingers' collisions replaced by
/// [`PANDA_FINGER_BOXES`]; unchanged for a robot without those links.
fn with_contact_fingers(urdf: &str) -> Result<String, PhysicsError> {
    let bad = |reason: String| PhysicsError::Urdf { path: "<urdf>".into(), reason };
    let doc = roxmltree::Document::parse(urdf).map_err(|e| bad(e.to_string()))?;
    // Cuts (start, end, inserted text), applied back to front.
    let mut edits: Vec<(usize, usize, String)> = vec![];
    for link in doc.root_element().children().filter(|n| n.has_tag_name("link")) {
        let Some(&(_, side)) = PANDA_FINGERS.iter().find(|(name, _)| link.attribute("name") == Some(*name)) else {
            continue;
        };
        let collisions: Vec<_> = link.children().filter(|n| n.has_tag_name("collision")).collect();
        for c in &collisions {
            edits.push((c.range().start, c.range().end, String::new()));
        }
        let mut boxes = String::new();
        for (origin, roll, size) in PANDA_FINGER_BOXES {
            let _ = write!(
                boxes,
                r#"<collision><origin xyz="{} {} {}" rpy="{} 0 0"/><geometry><box size="{} {} {}"/></geometry></collision>"#,
                origin[0],
                side * origin[1],
                origin[2],
                side * roll,
                size[0],
                size[1],
                size[2]
            );
        }
        // Before `</link>`: the link's end minus its closing tag.
        let end = link.range().end - "</link>".len();
        if !urdf[..link.range().end].ends_with("</link>") {
            return Err(bad(format!("link {} is not closed by </link>", link.attribute("name").unwrap_or(""))));
        }
        edits.push((end, end, boxes));
    }
    edits.sort_by_key(|e| std::cmp::Reverse(e.0));
    let mut out = urdf.to_string();
    for (start, end, text) in edits {
        out.replace_range(start..end, &text);
    }
    Ok(out)
}

/// The robot as MJCF, by MuJoCo's URDF compiler (a mimic joint becomes an
/// equality constraint).
fn robot_mjcf(urdf: &str) -> Result<String, PhysicsError> {
    let compile = |e: &dyn std::fmt::Debug| PhysicsError::Compile(format!("{e:?}"));
    let mut spec = MjSpec::from_xml_string(&super::with_compiler_settings(urdf)?).map_err(|e| compile(&e))?;
    spec.compile().map_err(|e| compile(&e))?;
    match spec.save_xml_string(1 << 20) {
        Ok(xml) => Ok(xml),
        Err(MjEditError::XmlBufferTooSmall { required_size }) => {
            spec.save_xml_string(required_size + 1).map_err(|e| compile(&e))
        }
        Err(e) => Err(compile(&e)),
    }
}

/// The whole scene: the robot's MJCF with gravity compensation on its
/// bodies and its contact class, then the options, obstacles, objects and
/// servos (see the module docs).
fn scene_mjcf(
    robot: &str,
    problem: &Problem,
    meshes: &[SceneMesh<'_>],
    timestep: f64,
    settings: &PhysicsSettings,
) -> Result<String, PhysicsError> {
    let bad = |what: &str| PhysicsError::Compile(format!("MuJoCo's robot MJCF has no {what}"));
    let mu = settings.friction;
    let mut head = format!(
        r#"<option timestep="{timestep}" cone="elliptic" impratio="10" noslip_iterations="3" integrator="implicitfast"><flag multiccd="enable"/></option>
  <default><default class="tandem_robot"><geom contype="1" conaffinity="2" condim="4" friction="{mu} 0.005 0.0001"/><joint armature="0.1" damping="1"/></default></default>
  "#
    );
    let mut assets = String::new();
    let mut world = String::new();
    for o in problem.scene.obstacles() {
        let geom = geom_xml(&o.name, &o.shape, &o.pose, &mut assets)?;
        let _ = writeln!(
            world,
            r#"    <geom {geom} contype="2" conaffinity="1" condim="3" friction="{mu} 0.005 0.0001"/>"#
        );
    }
    for o in problem.scene.objects() {
        let geom = geom_xml(&format!("object_{}", o.name), &o.shape, &IsometryMatrix3::identity(), &mut assets)?;
        let p = pose7(&o.pose);
        let _ = writeln!(
            world,
            r#"    <body name="object_{}" pos="{} {} {}" quat="{} {} {} {}"><freejoint name="object_{}"/><geom {geom} contype="3" conaffinity="3" condim="4" friction="{mu} 0.005 0.0001" density="{}"/></body>"#,
            o.name, p[0], p[1], p[2], p[3], p[4], p[5], p[6], o.name, settings.object_density
        );
    }
    for m in meshes {
        if !(m.mass.is_finite() && m.mass > 0.0) {
            return Err(PhysicsError::Settings(format!(
                "mesh '{}' has mass {} kg (finite and positive)",
                m.name, m.mass
            )));
        }
        let vertices: Vec<String> = m.mesh.vertices.iter().map(|v| format!("{} {} {}", v[0], v[1], v[2])).collect();
        let faces: Vec<String> = m.mesh.triangles.iter().map(|t| format!("{} {} {}", t[0], t[1], t[2])).collect();
        // `shell`: MuJoCo need not find a closed volume (the body's
        // inertia is given below); contacts use the mesh's convex hull,
        // rays its triangles.
        let _ = write!(
            assets,
            r#"<mesh name="mesh_{}" vertex="{}" face="{}" inertia="shell"/>"#,
            m.name,
            vertices.join(" "),
            faces.join(" ")
        );
        // A solid box of the mesh's bounds, for the inertia.
        let (lo, hi) = m.mesh.vertices.iter().fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), v| {
            ([lo[0].min(v[0]), lo[1].min(v[1]), lo[2].min(v[2])], [hi[0].max(v[0]), hi[1].max(v[1]), hi[2].max(v[2])])
        });
        let e = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let c = [(hi[0] + lo[0]) / 2.0, (hi[1] + lo[1]) / 2.0, (hi[2] + lo[2]) / 2.0];
        let i = |a: f64, b: f64| m.mass * (a * a + b * b) / 12.0;
        let p = pose7(&m.pose);
        let _ = writeln!(
            world,
            r#"    <body name="object_{n}" pos="{} {} {}" quat="{} {} {} {}"><freejoint name="object_{n}"/><inertial pos="{} {} {}" mass="{}" diaginertia="{} {} {}"/><geom name="object_{n}" type="mesh" mesh="mesh_{n}" contype="3" conaffinity="3" condim="4" friction="{mu} 0.005 0.0001"/></body>"#,
            p[0],
            p[1],
            p[2],
            p[3],
            p[4],
            p[5],
            p[6],
            c[0],
            c[1],
            c[2],
            m.mass,
            i(e[1], e[2]),
            i(e[0], e[2]),
            i(e[0], e[1]),
            n = m.name
        );
    }
    if !assets.is_empty() {
        let _ = write!(head, "<asset>{assets}</asset>\n  ");
    }
    let mut servos = String::from("<actuator>");
    for (name, limits) in problem.robot.joint_names().iter().zip(problem.robot.limits()) {
        let effort = if limits.effort.is_finite() && limits.effort > 0.0 { limits.effort } else { 100.0 };
        let kp = ARM_KP_PER_EFFORT * effort;
        let _ = write!(
            servos,
            r#"<position name="servo_{name}" joint="{name}" kp="{kp}" kv="{}" forcerange="{} {effort}"/>"#,
            kp / ARM_KP_OVER_KV,
            -effort
        );
    }
    let description = problem.robot.description();
    for (name, _) in &problem.robot_spec.hold {
        let effort = description.joints().iter().find(|j| &j.name == name).map_or(70.0, |j| j.limits.effort);
        let _ = write!(
            servos,
            r#"<position name="servo_{name}" joint="{name}" kp="1000" kv="20" forcerange="{} {effort}"/>"#,
            -effort
        );
    }
    servos.push_str("</actuator>\n");
    // Allowed contacts of a link with an obstacle (the base on the table):
    // obstacles are the world body's geoms.
    let links: Vec<&str> = description.links().iter().map(|l| l.name.as_str()).collect();
    let scene = &problem.scene;
    let mut excluded = String::new();
    for (a, b) in scene.allowed_contacts() {
        for (link, other) in [(a, b), (b, a)] {
            if links.contains(&link.as_str()) && scene.obstacle(other).is_some() {
                let _ = write!(excluded, r#"<exclude body1="{link}" body2="world"/>"#);
            }
        }
    }
    if !excluded.is_empty() {
        let _ = writeln!(servos, "<contact>{excluded}</contact>");
    }
    // The robot's bodies are the only ones so far: all get gravity
    // compensation, the root the robot's contact class.
    let mut xml = robot.replace("<body ", r#"<body gravcomp="1" "#);
    let first = xml.find("<body ").ok_or_else(|| bad("body"))?;
    xml.insert_str(first + "<body ".len(), r#"childclass="tandem_robot" "#);
    let at = xml.find("<worldbody>").ok_or_else(|| bad("<worldbody>"))?;
    xml.insert_str(at, &head);
    let at = xml.rfind("</worldbody>").ok_or_else(|| bad("</worldbody>"))?;
    xml.insert_str(at, &world);
    let at = xml.rfind("</mujoco>").ok_or_else(|| bad("</mujoco>"))?;
    xml.insert_str(at, &servos);
    Ok(xml)
}

/// A geom's `name`, `type`, `size`, `pos` and `quat` attributes for
/// `shape` at `pose`; a convex hull becomes a mesh asset.
fn geom_xml(
    name: &str,
    shape: &Shape,
    pose: &IsometryMatrix3<f64>,
    assets: &mut String,
) -> Result<String, PhysicsError> {
    let p = pose7(pose);
    let placed =
        format!(r#"name="{name}" pos="{} {} {}" quat="{} {} {} {}""#, p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
    Ok(match shape {
        Shape::Sphere { radius } => format!(r#"{placed} type="sphere" size="{radius}""#),
        Shape::Capsule { radius, half_length } => format!(r#"{placed} type="capsule" size="{radius} {half_length}""#),
        Shape::Cylinder { radius, half_length } => format!(r#"{placed} type="cylinder" size="{radius} {half_length}""#),
        Shape::Box { half_extents: h } => format!(r#"{placed} type="box" size="{} {} {}""#, h.x, h.y, h.z),
        Shape::Points { .. } => {
            return Err(PhysicsError::Settings(format!(
                "'{name}' is a point cloud: MuJoCo simulates the world itself, not a sensor's view of it (give its obstacles as shapes)"
            )));
        }
        Shape::Convex(hull) => {
            let vertices: Vec<String> = hull.points().iter().map(|v| format!("{} {} {}", v[0], v[1], v[2])).collect();
            let _ = write!(assets, r#"<mesh name="{name}_hull" vertex="{}"/>"#, vertices.join(" "));
            format!(r#"{placed} type="mesh" mesh="{name}_hull""#)
        }
    })
}
