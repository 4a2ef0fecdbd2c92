//! URDF loading: XML → validated [`RobotDescription`], and the embedded
//! robots ([`RobotDescription::panda`], [`RobotDescription::planar_gripper`]).
//!
//! urdf-rs does the XML-to-struct work; roxmltree locates elements so every
//! error can name a line. Mesh URIs (`package://pkg/…`, `file://…`, relative
//! paths) resolve against a [`MeshSearchPath`].
//!
//! ```
//! use tandem::robot::{MeshSearchPath, RobotDescription};
//! let urdf = r#"<robot name="arm">
//!   <link name="base"/><link name="tip"/>
//!   <joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
//!     <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="2" effort="5"/></joint>
//! </robot>"#;
//! let arm = RobotDescription::from_urdf_str(urdf, &MeshSearchPath::default()).unwrap();
//! assert_eq!(arm.joints().len(), 1);
//! ```

use super::description::{
    CollisionElement, Geometry, Joint, JointKind, JointLimits, Link, Mimic, RobotDescription, link_tree,
};
use super::error::{RobotError, SourceLocation};
use super::mesh::TriMesh;
use super::xml_checks::{prevalidate, without_visuals};
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Unit, Vector3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where `package://` mesh URIs are looked up.
///
/// `package://pkg/rest` resolves to `dir/pkg/rest` for each package directory
/// `dir`, then to `dir/rest` when `dir` itself is named `pkg`; finally the
/// ancestors of the URDF file are searched for a folder named `pkg`. Relative
/// paths resolve against the URDF's folder.
#[derive(Debug, Clone, Default)]
pub struct MeshSearchPath {
    /// Folders that contain packages (like entries of `ROS_PACKAGE_PATH`).
    pub package_dirs: Vec<PathBuf>,
}

impl MeshSearchPath {
    /// A search path over the given package folders.
    pub fn new(package_dirs: impl IntoIterator<Item = PathBuf>) -> Self {
        MeshSearchPath { package_dirs: package_dirs.into_iter().collect() }
    }

    /// Adds the folders of the `ROS_PACKAGE_PATH` environment variable.
    pub fn with_ros_package_path(mut self) -> Self {
        if let Some(paths) = std::env::var_os("ROS_PACKAGE_PATH") {
            self.package_dirs.extend(std::env::split_paths(&paths));
        }
        self
    }

    /// Candidate files for `uri`, in lookup order.
    fn candidates(&self, uri: &str, urdf_dir: Option<&Path>) -> Vec<PathBuf> {
        if let Some(rest) = uri.strip_prefix("package://") {
            // Some generators write package:///pkg/…; urdfdom tolerates it, so do we.
            let rest = rest.trim_start_matches('/');
            let (pkg, inner) = rest.split_once('/').unwrap_or((rest, ""));
            let mut out = Vec::new();
            for dir in &self.package_dirs {
                out.push(dir.join(pkg).join(inner));
                if dir.file_name().is_some_and(|n| n == pkg) {
                    out.push(dir.join(inner));
                }
            }
            for anc in urdf_dir.into_iter().flat_map(Path::ancestors) {
                if anc.file_name().is_some_and(|n| n == pkg) {
                    out.push(anc.join(inner));
                }
            }
            out
        } else if let Some(abs) = uri.strip_prefix("file://") {
            vec![PathBuf::from(abs)]
        } else {
            let p = PathBuf::from(uri);
            match urdf_dir {
                Some(dir) if p.is_relative() => vec![dir.join(p)],
                _ => vec![p],
            }
        }
    }
}

impl RobotDescription {
    /// Loads and validates a URDF file; meshes are resolved and loaded.
    pub fn from_urdf_file(path: impl AsRef<Path>, search: &MeshSearchPath) -> Result<Self, RobotError> {
        let path = path.as_ref();
        let text =
            std::fs::read_to_string(path).map_err(|source| RobotError::Io { path: path.to_path_buf(), source })?;
        let dir = path.parent().map(|d| if d.as_os_str().is_empty() { Path::new(".") } else { d });
        parse_urdf_in(&text, &path.display().to_string(), dir, search)
    }

    /// Parses URDF text; relative mesh paths resolve against the working directory.
    pub fn from_urdf_str(text: &str, search: &MeshSearchPath) -> Result<Self, RobotError> {
        parse_urdf(text, "<string>", search)
    }

    // The embedded robots are URDF constructors too, so they live here and
    // description.rs does not import its parser.

    /// The embedded default robot: a Franka Emika Panda written from the
    /// published kinematic parameters, with sphere-set collision shapes and a
    /// `panda_hand_tcp` gripper frame at the fingertip centre.
    pub fn panda() -> RobotDescription {
        // The embedded file is tested on every build; failing here is a build defect.
        EMBEDDED_PANDA.parse().expect("embedded Panda URDF is valid")
    }

    /// The embedded planar gripper of the dissertation's planar task:
    /// prismatic `x` and `y` (m, over a 50 × 50 cm table) and a `yaw` joint,
    /// gripper frame `gripper_tcp` 10 cm above the table.
    pub fn planar_gripper() -> RobotDescription {
        EMBEDDED_PLANAR.parse().expect("embedded planar gripper URDF is valid")
    }

    /// The source name of [`Self::panda`]'s description (see [`Self::source`]).
    pub(crate) fn panda_source() -> &'static str {
        EMBEDDED_PANDA.source
    }

    /// The text of an embedded robot's URDF ([`Self::panda`],
    /// [`Self::planar_gripper`]); `None` for one read from a file.
    pub fn embedded_urdf(&self) -> Option<&'static str> {
        [EMBEDDED_PANDA, EMBEDDED_PLANAR].into_iter().find(|e| e.source == self.source).map(|e| e.text)
    }
}

/// A URDF compiled into the library, and the source name its description
/// carries (which [`RobotDescription::embedded_urdf`] looks up).
#[derive(Clone, Copy)]
struct EmbeddedUrdf {
    source: &'static str,
    text: &'static str,
}

impl EmbeddedUrdf {
    fn parse(self) -> Result<RobotDescription, RobotError> {
        parse_urdf(self.text, self.source, &MeshSearchPath::default())
    }
}

const EMBEDDED_PANDA: EmbeddedUrdf =
    EmbeddedUrdf { source: "<embedded panda.urdf>", text: include_str!("../../problems/robots/panda/panda.urdf") };
const EMBEDDED_PLANAR: EmbeddedUrdf = EmbeddedUrdf {
    source: "<embedded planar_gripper.urdf>",
    text: include_str!("../../problems/robots/planar/planar_gripper.urdf"),
};

fn parse_urdf(text: &str, source: &str, search: &MeshSearchPath) -> Result<RobotDescription, RobotError> {
    parse_urdf_in(text, source, None, search)
}

fn parse_urdf_in(
    text: &str,
    source: &str,
    urdf_dir: Option<&Path>,
    search: &MeshSearchPath,
) -> Result<RobotDescription, RobotError> {
    let at = |line: Option<u32>| SourceLocation { source: source.to_string(), line };
    let doc = roxmltree::Document::parse(text)
        .map_err(|e| RobotError::MalformedXml { at: at(Some(e.pos().row)), message: e.to_string() })?;
    let lines = prevalidate(&doc, source)?;
    let urdf = urdf_rs::read_from_string(&without_visuals(text, &doc))
        .map_err(|e| RobotError::InvalidUrdf { at: at(None), message: e.to_string() })?;

    let mut link_ids: HashMap<&str, usize> = HashMap::new();
    let mut links = Vec::with_capacity(urdf.links.len());
    for l in &urdf.links {
        let line = lines.get("link", &l.name);
        if link_ids.insert(&l.name, links.len()).is_some() {
            return Err(RobotError::DuplicateName { at: at(line), kind: "link", name: l.name.clone() });
        }
        let collisions = l
            .collision
            .iter()
            .map(|c| collision_element(c, &l.name, &at(line), urdf_dir, search))
            .collect::<Result<_, _>>()?;
        links.push(Link { name: l.name.clone(), parent_joint: None, collisions, line });
    }

    let mut joints = Vec::with_capacity(urdf.joints.len());
    let mut joint_ids: HashMap<&str, usize> = HashMap::new();
    for j in &urdf.joints {
        let line = lines.get("joint", &j.name);
        if joint_ids.insert(&j.name, joints.len()).is_some() {
            return Err(RobotError::DuplicateName { at: at(line), kind: "joint", name: j.name.clone() });
        }
        let find = |role: &'static str, name: &str| {
            link_ids.get(name).copied().ok_or_else(|| RobotError::MissingLink {
                at: at(line),
                joint: j.name.clone(),
                role,
                link: name.to_string(),
            })
        };
        joints.push(Joint {
            name: j.name.clone(),
            kind: joint_kind(j, &at(line))?,
            parent: find("parent", &j.parent.link)?,
            child: find("child", &j.child.link)?,
            origin: pose(&j.origin, "joint", &j.name, &at(line))?,
            limits: joint_limits(j, &at(line))?,
            mimic: None,
            line,
        });
    }
    let mut load_warnings = Vec::new();
    resolve_mimics(&urdf.joints, &joint_ids, &mut joints, &at, &mut load_warnings)?;

    let mut desc =
        RobotDescription { name: urdf.name.clone(), source: source.to_string(), links, joints, root: 0, load_warnings };
    link_tree(&mut desc)?;
    Ok(desc)
}

/// The element whose numbers are checked, for error messages.
struct Owner<'a> {
    element: &'static str,
    name: &'a str,
    at: &'a SourceLocation,
}

impl Owner<'_> {
    fn check(&self, field: &'static str, value: f64, ok: bool, expected: &'static str) -> Result<f64, RobotError> {
        if ok {
            return Ok(value);
        }
        let (at, element, name) = (self.at.clone(), self.element, self.name.to_string());
        Err(RobotError::InvalidValue { at, element, name, field, value, expected })
    }

    fn finite(&self, field: &'static str, value: f64) -> Result<f64, RobotError> {
        self.check(field, value, value.is_finite(), "a finite number")
    }

    fn positive(&self, field: &'static str, value: f64) -> Result<f64, RobotError> {
        self.check(field, value, value.is_finite() && value > 0.0, "a positive finite number")
    }

    fn non_negative(&self, field: &'static str, value: f64) -> Result<f64, RobotError> {
        self.check(field, value, value >= 0.0, "a non-negative number (or inf)")
    }
}

/// URDF `<origin>`: translation, then fixed-axis roll-pitch-yaw.
fn pose(
    p: &urdf_rs::Pose,
    element: &'static str,
    name: &str,
    at: &SourceLocation,
) -> Result<IsometryMatrix3<f64>, RobotError> {
    for (field, v) in ["origin x", "origin y", "origin z"].into_iter().zip(p.xyz.0) {
        Owner { element, name, at }.finite(field, v)?;
    }
    for (field, v) in ["origin roll", "origin pitch", "origin yaw"].into_iter().zip(p.rpy.0) {
        Owner { element, name, at }.finite(field, v)?;
    }
    let [x, y, z] = p.xyz.0;
    let [r, pi, yaw] = p.rpy.0;
    Ok(IsometryMatrix3::from_parts(Translation3::new(x, y, z), Rotation3::from_euler_angles(r, pi, yaw)))
}

fn joint_kind(j: &urdf_rs::Joint, at: &SourceLocation) -> Result<JointKind, RobotError> {
    use urdf_rs::JointType as T;
    if j.joint_type == T::Fixed {
        return Ok(JointKind::Fixed);
    }
    let raw = j.axis.xyz.0;
    for (field, v) in ["axis x", "axis y", "axis z"].into_iter().zip(raw) {
        Owner { element: "joint", name: &j.name, at }.finite(field, v)?;
    }
    let axis = Unit::try_new(Vector3::from(raw), 1e-12).ok_or_else(|| RobotError::ZeroAxis {
        at: at.clone(),
        joint: j.name.clone(),
        axis: raw,
    })?;
    Ok(match j.joint_type {
        T::Revolute => JointKind::Revolute { axis },
        T::Continuous => JointKind::Continuous { axis },
        T::Prismatic => JointKind::Prismatic { axis },
        // Rejected with a line number by `prevalidate`.
        _ => {
            return Err(RobotError::UnsupportedJointType {
                at: at.clone(),
                joint: j.name.clone(),
                joint_type: format!("{:?}", j.joint_type).to_lowercase(),
            });
        }
    })
}

fn joint_limits(j: &urdf_rs::Joint, at: &SourceLocation) -> Result<JointLimits, RobotError> {
    let l = &j.limit;
    let owner = Owner { element: "joint", name: &j.name, at };
    let velocity = owner.non_negative("limit velocity", l.velocity)?;
    let effort = owner.non_negative("limit effort", l.effort)?;
    let (lower, upper) = match j.joint_type {
        urdf_rs::JointType::Continuous | urdf_rs::JointType::Fixed => (f64::NEG_INFINITY, f64::INFINITY),
        _ => (l.lower, l.upper),
    };
    if lower.is_nan() || upper.is_nan() || lower > upper {
        return Err(RobotError::InvalidLimits { at: at.clone(), joint: j.name.clone(), lower, upper });
    }
    Ok(JointLimits { lower, upper, velocity, effort })
}

/// Resolves `<mimic>` elements. A mimic naming no joint, or on or of a
/// fixed joint, is ignored with a warning (urdfdom and Pinocchio ignore
/// them too); a cycle of mimics is an error.
fn resolve_mimics(
    raw: &[urdf_rs::Joint],
    ids: &HashMap<&str, usize>,
    joints: &mut [Joint],
    at: &dyn Fn(Option<u32>) -> SourceLocation,
    warnings: &mut Vec<String>,
) -> Result<(), RobotError> {
    for (i, j) in raw.iter().enumerate() {
        let Some(m) = &j.mimic else { continue };
        let invalid = |detail: &str| RobotError::InvalidMimic {
            at: at(joints[i].line),
            joint: j.name.clone(),
            target: m.joint.clone(),
            detail: detail.to_string(),
        };
        let ignored = |why: &str| {
            format!("{}: joint '{}' mimics '{}', {why}; the mimic is ignored", at(joints[i].line), j.name, m.joint)
        };
        let Some(&target) = ids.get(m.joint.as_str()) else {
            warnings.push(ignored("which does not exist"));
            continue;
        };
        if !joints[i].kind.is_movable() || !joints[target].kind.is_movable() {
            warnings.push(ignored("but only movable joints can mimic or be mimicked"));
            continue;
        }
        let multiplier = m.multiplier.unwrap_or(1.0);
        let offset = m.offset.unwrap_or(0.0);
        if !multiplier.is_finite() || !offset.is_finite() {
            return Err(invalid("multiplier and offset must be finite"));
        }
        joints[i].mimic = Some(Mimic { joint: target, multiplier, offset });
    }
    check_mimic_cycles(joints, at)
}

fn check_mimic_cycles(joints: &[Joint], at: &dyn Fn(Option<u32>) -> SourceLocation) -> Result<(), RobotError> {
    for start in 0..joints.len() {
        let mut cur = start;
        let mut steps = 0;
        while let Some(m) = &joints[cur].mimic {
            cur = m.joint;
            steps += 1;
            if steps > joints.len() {
                let m0 = joints[start].mimic.as_ref().map(|m| joints[m.joint].name.clone());
                return Err(RobotError::InvalidMimic {
                    at: at(joints[start].line),
                    joint: joints[start].name.clone(),
                    target: m0.unwrap_or_default(),
                    detail: "mimic relations form a cycle".into(),
                });
            }
        }
    }
    Ok(())
}

fn collision_element(
    c: &urdf_rs::Collision,
    link: &str,
    at: &SourceLocation,
    urdf_dir: Option<&Path>,
    search: &MeshSearchPath,
) -> Result<CollisionElement, RobotError> {
    let owner = Owner { element: "link", name: link, at };
    use urdf_rs::Geometry as G;
    let geometry = match &c.geometry {
        G::Box { size } => {
            let mut h = Vector3::zeros();
            for (i, field) in ["box size x", "box size y", "box size z"].into_iter().enumerate() {
                h[i] = owner.positive(field, size.0[i])? / 2.0;
            }
            Geometry::Box { half_extents: h }
        }
        G::Cylinder { radius, length } => Geometry::Cylinder {
            radius: owner.positive("cylinder radius", *radius)?,
            length: owner.positive("cylinder length", *length)?,
        },
        G::Capsule { radius, length } => Geometry::Capsule {
            radius: owner.positive("capsule radius", *radius)?,
            length: owner.positive("capsule length", *length)?,
        },
        G::Sphere { radius } => Geometry::Sphere { radius: owner.positive("sphere radius", *radius)? },
        G::Mesh { filename, scale } => {
            let scale = scale.map_or([1.0; 3], |s| s.0);
            // Negative factors mirror a mesh (legal); zero flattens it into
            // something no collision shape can be built from.
            for (field, v) in ["mesh scale x", "mesh scale y", "mesh scale z"].into_iter().zip(scale) {
                owner.check(field, v, v.is_finite() && v != 0.0, "a finite, non-zero number")?;
            }
            load_mesh(filename, scale, link, at, urdf_dir, search)?
        }
    };
    Ok(CollisionElement { name: c.name.clone(), origin: pose(&c.origin, "link", link, at)?, geometry })
}

fn load_mesh(
    uri: &str,
    scale: [f64; 3],
    link: &str,
    at: &SourceLocation,
    urdf_dir: Option<&Path>,
    search: &MeshSearchPath,
) -> Result<Geometry, RobotError> {
    let candidates = search.candidates(uri, urdf_dir);
    let Some(path) = candidates.iter().find(|p| p.is_file()).cloned() else {
        return Err(RobotError::MeshNotFound {
            at: at.clone(),
            link: link.to_string(),
            uri: uri.to_string(),
            searched: candidates,
        });
    };
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let mesh = match ext.as_deref() {
        Some("stl") => TriMesh::from_stl_file(&path, scale)?,
        Some("obj") => TriMesh::from_obj_file(&path, scale)?,
        Some("dae") => TriMesh::from_collada_file(&path, scale)?,
        other => {
            return Ok(Geometry::UnreadableMesh {
                uri: uri.to_string(),
                path,
                format: other.unwrap_or_default().to_string(),
            });
        }
    };
    Ok(Geometry::Mesh { uri: uri.to_string(), path, mesh: Arc::new(mesh) })
}
