//! The robot as its URDF describes it: links, joints, limits, mimics and
//! collision geometry, validated, before any choice of active joints.
//!
//! A [`RobotDescription`] is what `tandem inspect` prints and what a
//! [`RobotModel`](super::RobotModel) is compiled from. Poses are in metres
//! and radians; a joint's origin is the pose of its child link frame in its
//! parent link frame at zero joint value, as in URDF.
//!
//! ```
//! use tandem::robot::RobotDescription;
//! let panda = RobotDescription::panda();
//! assert_eq!(panda.root_link(), "panda_link0");
//! assert!(panda.joint("panda_joint4").is_some());
//! ```

use super::error::{RobotError, SourceLocation};
use super::mesh::TriMesh;
use nalgebra::{IsometryMatrix3, Unit, Vector3};
use std::sync::Arc;

/// Kind of a joint, with its axis (unit, in the joint frame) when it moves.
#[derive(Debug, Clone, PartialEq)]
pub enum JointKind {
    /// Rotation about `axis`, within position limits.
    Revolute {
        /// Unit axis in the joint frame.
        axis: Unit<Vector3<f64>>,
    },
    /// Rotation about `axis` without position limits.
    Continuous {
        /// Unit axis in the joint frame.
        axis: Unit<Vector3<f64>>,
    },
    /// Translation along `axis` (metres).
    Prismatic {
        /// Unit axis in the joint frame.
        axis: Unit<Vector3<f64>>,
    },
    /// No motion.
    Fixed,
}

impl JointKind {
    /// URDF name of the kind (`revolute`, `continuous`, `prismatic`, `fixed`).
    pub fn name(&self) -> &'static str {
        match self {
            JointKind::Revolute { .. } => "revolute",
            JointKind::Continuous { .. } => "continuous",
            JointKind::Prismatic { .. } => "prismatic",
            JointKind::Fixed => "fixed",
        }
    }

    /// The motion axis in the joint frame; `None` for fixed joints.
    pub fn axis(&self) -> Option<Unit<Vector3<f64>>> {
        match self {
            JointKind::Revolute { axis } | JointKind::Continuous { axis } | JointKind::Prismatic { axis } => {
                Some(*axis)
            }
            JointKind::Fixed => None,
        }
    }

    /// True for revolute, continuous and prismatic joints.
    pub fn is_movable(&self) -> bool {
        !matches!(self, JointKind::Fixed)
    }
}

/// Position, velocity and effort limits of a joint (SI: rad or m, rad/s or
/// m/s, N·m or N). Continuous joints have infinite position limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lower position limit (rad or m; −∞ for continuous joints).
    pub lower: f64,
    /// Upper position limit (rad or m; +∞ for continuous joints).
    pub upper: f64,
    /// Velocity limit (rad/s or m/s).
    pub velocity: f64,
    /// Effort limit (N·m or N).
    pub effort: f64,
}

impl JointLimits {
    /// True when `value` lies within `[lower, upper]`.
    pub fn contains(&self, value: f64) -> bool {
        value >= self.lower && value <= self.upper
    }
}

/// `value = multiplier · value(joint) + offset`, as in URDF `<mimic>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mimic {
    /// Index of the mimicked joint in [`RobotDescription::joints`].
    pub joint: usize,
    /// value = multiplier · (the mimicked joint's value) + offset.
    pub multiplier: f64,
    /// Offset (rad or m).
    pub offset: f64,
}

/// One joint of the URDF.
#[derive(Debug, Clone)]
pub struct Joint {
    /// Name, as in the URDF.
    pub name: String,
    /// Type and axis.
    pub kind: JointKind,
    /// Index of the parent link in [`RobotDescription::links`].
    pub parent: usize,
    /// Index of the child link in [`RobotDescription::links`].
    pub child: usize,
    /// Pose of the joint (and child link) frame in the parent link frame at zero value.
    pub origin: IsometryMatrix3<f64>,
    /// Position, velocity and effort limits.
    pub limits: JointLimits,
    /// The joint this one follows, if any.
    pub mimic: Option<Mimic>,
    /// Line of the `<joint>` element in the source, when known.
    pub line: Option<u32>,
}

/// Shape of a collision element, in the element's own frame.
#[derive(Debug, Clone)]
pub enum Geometry {
    /// Box with the given half extents (m) along x, y, z.
    Box {
        /// Half the side lengths along x, y, z (m).
        half_extents: Vector3<f64>,
    },
    /// Cylinder along z, centred on the origin.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Full length (m).
        length: f64,
    },
    /// Capsule along z: a cylinder of `length` capped by two hemispheres.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Full length (m).
        length: f64,
    },
    /// Sphere centred on the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// Triangle mesh, already scaled, in the element frame.
    Mesh {
        /// The URI as written in the URDF.
        uri: String,
        /// The file it resolved to.
        path: std::path::PathBuf,
        /// The triangles, scaled into the element frame.
        mesh: Arc<TriMesh>,
    },
    /// A mesh file that exists but whose format tandem cannot read for
    /// collision (e.g. COLLADA `.dae`); kept so the link's geometry is
    /// accounted for, and reported by [`RobotDescription::lint`].
    UnreadableMesh {
        /// The URI as written.
        uri: String,
        /// The file it resolved to.
        path: std::path::PathBuf,
        /// File extension (lower case), or empty.
        format: String,
    },
}

impl Geometry {
    /// Short kind name (`box`, `cylinder`, `capsule`, `sphere`, `mesh`).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Geometry::Box { .. } => "box",
            Geometry::Cylinder { .. } => "cylinder",
            Geometry::Capsule { .. } => "capsule",
            Geometry::Sphere { .. } => "sphere",
            Geometry::Mesh { .. } | Geometry::UnreadableMesh { .. } => "mesh",
        }
    }
}

/// One `<collision>` element of a link.
#[derive(Debug, Clone)]
pub struct CollisionElement {
    /// The element's `name` attribute, if any.
    pub name: Option<String>,
    /// Pose of the shape in the link frame.
    pub origin: IsometryMatrix3<f64>,
    /// The shape.
    pub geometry: Geometry,
}

/// One link of the URDF.
#[derive(Debug, Clone)]
pub struct Link {
    /// Name, as in the URDF.
    pub name: String,
    /// Index of the joint whose child this link is; `None` for the root.
    pub parent_joint: Option<usize>,
    /// Its `<collision>` elements.
    pub collisions: Vec<CollisionElement>,
    /// 1-based line in the source file, when known.
    pub line: Option<u32>,
}

/// A validated URDF: a tree of links joined by joints, with one root.
///
/// Immutable once built; `Send + Sync`, share it behind an `Arc`.
#[derive(Debug, Clone)]
pub struct RobotDescription {
    pub(crate) name: String,
    pub(crate) source: String,
    pub(crate) links: Vec<Link>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) root: usize,
    /// Problems tolerated while loading (ignored mimics, …), with locations.
    pub(crate) load_warnings: Vec<String>,
}

impl RobotDescription {
    /// The `name` attribute of `<robot>`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where the description came from (file path or `<string>`).
    pub fn source(&self) -> &str {
        &self.source
    }

    /// All links, in URDF order.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// All joints, in URDF order.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Name of the root link (the one link with no parent joint).
    pub fn root_link(&self) -> &str {
        &self.links[self.root].name
    }

    pub(crate) fn root_index(&self) -> usize {
        self.root
    }

    /// Joint by name.
    pub fn joint(&self, name: &str) -> Option<&Joint> {
        self.joint_index(name).map(|i| &self.joints[i])
    }

    /// Link by name.
    pub fn link(&self, name: &str) -> Option<&Link> {
        self.link_index(name).map(|i| &self.links[i])
    }

    pub(crate) fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    pub(crate) fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// Names of the movable joints (revolute, continuous, prismatic) that no
    /// `<mimic>` drives, in URDF order: the default active joints.
    pub fn independent_joints(&self) -> Vec<&str> {
        self.joints.iter().filter(|j| j.kind.is_movable() && j.mimic.is_none()).map(|j| j.name.as_str()).collect()
    }

    /// Child joints of each link, in URDF order.
    pub fn children(&self) -> Vec<Vec<usize>> {
        let mut children = vec![Vec::new(); self.links.len()];
        for (j, joint) in self.joints.iter().enumerate() {
            children[joint.parent].push(j);
        }
        children
    }

    /// Joints from the root down to `link` (root first).
    pub fn joints_to_root(&self, link: usize) -> Vec<usize> {
        let mut path = Vec::new();
        let mut cur = link;
        while let Some(j) = self.links[cur].parent_joint {
            path.push(j);
            cur = self.joints[j].parent;
        }
        path.reverse();
        path
    }

    /// Problems that do not stop loading but deserve a look: joints that
    /// cannot move, links without collision geometry, empty meshes.
    pub fn lint(&self) -> Vec<String> {
        let mut problems = self.load_warnings.clone();
        for j in self.joints.iter().filter(|j| j.kind.is_movable()) {
            let at = self.location(j.line);
            if j.limits.velocity == 0.0 {
                problems.push(format!("{at}: joint '{}' has velocity limit 0, so it cannot move", j.name));
            }
            if j.limits.lower == j.limits.upper {
                problems.push(format!(
                    "{at}: joint '{}' has equal position limits ({}), so it cannot move",
                    j.name, j.limits.lower
                ));
            }
        }
        // Frame-only links (flanges, tool points) normally carry no geometry;
        // a robot with none at all cannot be collision-checked.
        if self.links.iter().all(|l| l.collisions.is_empty()) {
            problems.push("no link has collision geometry, so collision checks will see nothing".to_string());
        }
        for l in &self.links {
            for c in &l.collisions {
                match &c.geometry {
                    Geometry::Mesh { path, mesh, .. } if mesh.triangles.is_empty() => {
                        problems.push(format!("link '{}': mesh {} has no triangles", l.name, path.display()));
                    }
                    Geometry::UnreadableMesh { path, format, .. } => problems.push(format!(
                        "link '{}': collision mesh {} is '{format}', which tandem cannot read \
                         (use STL or OBJ); collision queries will not see it",
                        l.name,
                        path.display()
                    )),
                    _ => {}
                }
            }
        }
        problems
    }

    pub(crate) fn location(&self, line: Option<u32>) -> SourceLocation {
        SourceLocation { source: self.source.clone(), line }
    }

    /// The mesh files its collision geometry was read from (or could not
    /// be read from), in link order.
    pub fn mesh_files(&self) -> impl Iterator<Item = &std::path::Path> {
        self.links.iter().flat_map(|link| &link.collisions).filter_map(|c| match &c.geometry {
            Geometry::Mesh { path, .. } | Geometry::UnreadableMesh { path, .. } => Some(path.as_path()),
            _ => None,
        })
    }
}

/// Checks that a parsed description is a single tree and fills `parent_joint`.
pub(crate) fn link_tree(desc: &mut RobotDescription) -> Result<(), RobotError> {
    for (j, joint) in desc.joints.iter().enumerate() {
        let child = &mut desc.links[joint.child];
        if let Some(other) = child.parent_joint {
            return Err(RobotError::KinematicLoop {
                at: SourceLocation { source: desc.source.clone(), line: joint.line },
                detail: format!(
                    "link '{}' is the child of both '{}' and '{}'",
                    child.name, desc.joints[other].name, joint.name
                ),
            });
        }
        child.parent_joint = Some(j);
    }
    let roots: Vec<usize> = (0..desc.links.len()).filter(|&l| desc.links[l].parent_joint.is_none()).collect();
    match roots.as_slice() {
        [] if desc.links.is_empty() => Err(RobotError::NoLinks { at: desc.location(None) }),
        [] => Err(RobotError::KinematicLoop {
            at: desc.location(desc.joints.first().and_then(|j| j.line)),
            detail: "every link has a parent joint, so the joints form a cycle".into(),
        }),
        [root] => {
            desc.root = *root;
            check_reachable(desc)
        }
        many => Err(RobotError::MultipleRoots {
            at: desc.location(None),
            roots: many.iter().map(|&l| desc.links[l].name.clone()).collect(),
        }),
    }
}

/// With one root and one parent per link, a cycle shows up as links the root
/// cannot reach.
fn check_reachable(desc: &RobotDescription) -> Result<(), RobotError> {
    let children = desc.children();
    let mut seen = vec![false; desc.links.len()];
    let mut stack = vec![desc.root];
    while let Some(l) = stack.pop() {
        seen[l] = true;
        stack.extend(children[l].iter().map(|&j| desc.joints[j].child));
    }
    match seen.iter().position(|s| !s) {
        None => Ok(()),
        Some(l) => {
            let joint = desc.links[l].parent_joint.map(|j| &desc.joints[j]);
            Err(RobotError::KinematicLoop {
                at: desc.location(joint.and_then(|j| j.line)),
                detail: format!(
                    "link '{}' lies on a cycle of joints not connected to root '{}'",
                    desc.links[l].name,
                    desc.root_link()
                ),
            })
        }
    }
}
