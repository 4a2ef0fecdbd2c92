//! The compiled kinematic model: a [`RobotDescription`] with a choice of
//! active joints, the others held at fixed values.
//!
//! Compilation folds every fixed or held joint into constant placements, so
//! forward kinematics walks only the moving *bodies* — one per active joint
//! (plus one per joint that mimics an active joint) and the root. A
//! [`RobotModel`] is immutable and `Send + Sync`; per-thread mutable state
//! lives in a [`KinematicsWorkspace`](super::KinematicsWorkspace).
//!
//! ```
//! use tandem::robot::{RobotDescription, RobotModel};
//! use std::sync::Arc;
//! let panda = Arc::new(RobotDescription::panda());
//! let arm = RobotModel::builder(panda)
//!     .chain("panda_link0", "panda_hand_tcp")
//!     .hold("panda_finger_joint1", 0.04)
//!     .build()
//!     .unwrap();
//! assert_eq!(arm.nq(), 7);
//! assert_eq!(arm.joint_names()[0], "panda_joint1");
//! ```

use super::description::{JointKind, JointLimits, RobotDescription};
use super::error::{RobotError, suggest};
use super::motion_limits::{JointMotionLimits, LimitSource, MotionLimitOverride, PositionVelocityLimit};
use super::placement::Placement;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use std::collections::HashMap;
use std::sync::Arc;

mod compile;

/// How one body moves relative to its parent, in its joint frame.
/// Axis-aligned axes get their own variants: they make FK cheaper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Motion {
    RevoluteX,
    RevoluteY,
    RevoluteZ,
    Revolute(Vector3<f64>),
    Prismatic(Vector3<f64>),
}

impl Motion {
    fn new(kind: &JointKind) -> Option<Motion> {
        let axis = kind.axis()?.into_inner();
        let exact = |i: usize| (0..3).all(|k| axis[k] == if k == i { 1.0 } else { 0.0 });
        Some(match kind {
            JointKind::Prismatic { .. } => Motion::Prismatic(axis),
            _ if exact(0) => Motion::RevoluteX,
            _ if exact(1) => Motion::RevoluteY,
            _ if exact(2) => Motion::RevoluteZ,
            _ => Motion::Revolute(axis),
        })
    }

    /// The joint's displacement at `value` (rad or m), in its frame.
    pub(crate) fn displacement(&self, value: f64) -> IsometryMatrix3<f64> {
        match *self {
            Motion::Prismatic(axis) => {
                IsometryMatrix3::from_parts(Translation3::from(axis * value), Rotation3::identity())
            }
            _ => IsometryMatrix3::from_parts(
                Translation3::identity(),
                Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(self.axis()), value),
            ),
        }
    }

    /// Unit axis in the joint frame.
    pub(crate) fn axis(&self) -> Vector3<f64> {
        match *self {
            Motion::RevoluteX => Vector3::x(),
            Motion::RevoluteY => Vector3::y(),
            Motion::RevoluteZ => Vector3::z(),
            Motion::Revolute(a) | Motion::Prismatic(a) => a,
        }
    }

    /// The axis in world coordinates for a joint frame with rotation `r`;
    /// axis-aligned axes are a column of `r`, no product needed.
    #[inline(always)]
    pub(crate) fn world_axis(&self, r: &nalgebra::Matrix3<f64>) -> Vector3<f64> {
        match *self {
            Motion::RevoluteX => r.column(0).into_owned(),
            Motion::RevoluteY => r.column(1).into_owned(),
            Motion::RevoluteZ => r.column(2).into_owned(),
            Motion::Revolute(a) | Motion::Prismatic(a) => r * a,
        }
    }

    pub(crate) fn is_prismatic(&self) -> bool {
        matches!(self, Motion::Prismatic(_))
    }
}

/// A rigid segment moved by one joint; its frame is that joint's frame.
#[derive(Debug, Clone)]
pub(crate) struct Body {
    /// Parent body (bodies are sorted so `parent < self`); the root is its own parent.
    pub(crate) parent: usize,
    /// Joint frame in the parent body frame at zero joint value.
    pub(crate) placement: Placement,
    pub(crate) motion: Motion,
    /// Column of the active joint that drives this body.
    pub(crate) column: usize,
    /// Joint value = multiplier · q[column] + offset (1 and 0 unless a mimic).
    pub(crate) multiplier: f64,
    pub(crate) offset: f64,
}

/// What a frame is attached to in the URDF.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameKind {
    /// A link's frame.
    Link,
    /// A joint's frame (which URDF makes equal to its child link's frame).
    Joint,
}

/// A named frame rigidly attached to a body.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Name of the link or joint.
    pub name: String,
    /// Link or joint frame.
    pub kind: FrameKind,
    /// Index of the link (or joint) in the description.
    pub element: usize,
    pub(crate) body: usize,
    /// Pose of the frame in its body frame.
    pub(crate) placement: Placement,
}

/// Index of a frame in a [`RobotModel`], from [`RobotModel::frame_id`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FrameId(pub(crate) usize);

impl FrameId {
    /// Position of the frame in [`RobotModel::frames`].
    pub fn index(self) -> usize {
        self.0
    }
}

/// Which joints a model moves.
#[derive(Debug, Clone, PartialEq)]
pub enum JointSelection {
    /// Every movable joint not driven by a mimic, in URDF order.
    Independent,
    /// These joints, in this order.
    Names(Vec<String>),
    /// The independent movable joints on the path from `root` (a link) to
    /// `tip` (a link or joint frame), root first.
    Chain {
        /// The link the chain starts at.
        root: String,
        /// The link or joint frame it ends at.
        tip: String,
    },
    /// A MoveIt group's joints: the union of its chains' joints, the named
    /// joints and the parent joints of the named links, in depth-first
    /// tree order (as MoveIt orders a group's joints), keeping only the
    /// independent movable ones (fixed joints and
    /// mimics may be listed, as MoveIt allows, but do not become active).
    Union {
        /// `(base_link, tip_link)` chains.
        chains: Vec<(String, String)>,
        /// Joint names.
        joints: Vec<String>,
        /// Link names (each stands for the joint above it).
        links: Vec<String>,
    },
}

/// Builds a [`RobotModel`]; see the module example.
#[derive(Debug, Clone)]
pub struct RobotModelBuilder {
    description: Arc<RobotDescription>,
    selection: JointSelection,
    held: Vec<(String, f64)>,
}

impl RobotModelBuilder {
    /// Moves exactly these joints, in this order (the order of `q`).
    pub fn active_joints<S: Into<String>>(mut self, names: impl IntoIterator<Item = S>) -> Self {
        self.selection = JointSelection::Names(names.into_iter().map(Into::into).collect());
        self
    }

    /// Moves the independent joints between link `root` and frame `tip`.
    pub fn chain(mut self, root: impl Into<String>, tip: impl Into<String>) -> Self {
        self.selection = JointSelection::Chain { root: root.into(), tip: tip.into() };
        self
    }

    /// Sets the selection directly.
    pub fn selection(mut self, selection: JointSelection) -> Self {
        self.selection = selection;
        self
    }

    /// Holds an inactive joint at `value` (rad or m). Inactive joints not
    /// named here sit at 0, or at the middle of their limits when 0 is outside.
    pub fn hold(mut self, joint: impl Into<String>, value: f64) -> Self {
        self.held.push((joint.into(), value));
        self
    }

    /// Compiles the model.
    ///
    /// # Errors
    /// Unknown joint or frame names, a fixed or mimic joint chosen as active,
    /// a root that is not an ancestor of the tip, held values outside limits.
    pub fn build(self) -> Result<RobotModel, RobotError> {
        RobotModel::compile(self.description, &self.selection, &self.held)
    }
}

/// An immutable kinematic model with a fixed set of active joints.
///
/// The configuration `q` holds one value per active joint (rad for revolute,
/// m for prismatic) in the order of [`RobotModel::joint_names`]. All poses are
/// expressed in the frame of the URDF root link ("world").
#[derive(Debug, Clone)]
pub struct RobotModel {
    description: Arc<RobotDescription>,
    /// Description indices of the active joints, in q order.
    active: Vec<usize>,
    joint_names: Vec<String>,
    limits: Vec<JointLimits>,
    /// Velocity, acceleration, deceleration and jerk limits, per active joint.
    motion: Vec<JointMotionLimits>,
    /// Value of every description joint when q = 0 for the active ones.
    held_values: Vec<f64>,
    pub(crate) bodies: Vec<Body>,
    frames: Vec<Frame>,
    frame_lookup: HashMap<String, usize>,
}

impl RobotModel {
    /// Starts a model over `description` whose active joints are, unless
    /// changed, [`JointSelection::Independent`].
    pub fn builder(description: Arc<RobotDescription>) -> RobotModelBuilder {
        RobotModelBuilder { description, selection: JointSelection::Independent, held: Vec::new() }
    }

    /// The embedded Panda with its 7 arm joints active and the fingers held
    /// open (0.04 m each).
    pub fn panda() -> RobotModel {
        // Both names exist in the embedded URDF, which a unit test checks.
        Self::builder(Arc::new(RobotDescription::panda()))
            .chain("panda_link0", "panda_hand_tcp")
            .hold("panda_finger_joint1", 0.04)
            .build()
            .expect("embedded Panda model compiles")
    }

    /// The description the model was compiled from.
    pub fn description(&self) -> &Arc<RobotDescription> {
        &self.description
    }

    /// Number of active joints (the length of `q`).
    pub fn nq(&self) -> usize {
        self.active.len()
    }

    /// Names of the active joints, in `q` order.
    pub fn joint_names(&self) -> &[String] {
        &self.joint_names
    }

    /// Limits of the active joints, in `q` order.
    pub fn limits(&self) -> &[JointLimits] {
        &self.limits
    }

    /// The velocity, acceleration, deceleration and jerk limits of each
    /// active joint, in `q` order, with where each came from: the URDF's
    /// velocity limit and tandem's defaults
    /// ([`JointMotionLimits::default_for`]), the published Franka Panda
    /// table for the embedded Panda, or what
    /// [`Self::apply_motion_limits`] set (a `joint_limits.yaml`).
    pub fn motion_limits(&self) -> &[JointMotionLimits] {
        &self.motion
    }

    /// Sets the motion limits of the joints named in `limits` (joints of
    /// the model that are not active are ignored, as MoveIt ignores the
    /// entries of joints outside a group), recording `source`.
    ///
    /// # Errors
    /// [`RobotError::InvalidLimit`] for a value that is not finite and
    /// positive.
    pub fn apply_motion_limits<'a>(
        &mut self,
        limits: impl IntoIterator<Item = (&'a str, MotionLimitOverride, Option<PositionVelocityLimit>)>,
        source: &LimitSource,
    ) -> Result<(), RobotError> {
        for (joint, set, profile) in limits {
            for (what, value) in [
                ("max_velocity", set.velocity),
                ("max_acceleration", set.acceleration),
                ("max_deceleration", set.deceleration),
                ("max_jerk", set.jerk),
            ] {
                if let Some(v) = value
                    && !(v.is_finite() && v > 0.0)
                {
                    return Err(RobotError::InvalidLimit { joint: joint.to_string(), what, value: v });
                }
            }
            if let Some(j) = self.joint_names.iter().position(|n| n == joint) {
                self.motion[j].apply(&set, profile, source);
            }
        }
        Ok(())
    }

    /// Description indices of the active joints, in `q` order.
    pub fn active_joint_indices(&self) -> &[usize] {
        &self.active
    }

    /// The unit of active joint `j`'s value: "m" for a prismatic joint,
    /// "rad" otherwise (for axis labels and messages); `None` past nq.
    pub fn joint_unit(&self, j: usize) -> Option<&'static str> {
        let joint = &self.description.joints()[*self.active.get(j)?];
        Some(if joint.kind.name() == "prismatic" { "m" } else { "rad" })
    }

    /// All frames: one per link, then one per joint, in URDF order.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }

    /// The frame with this name; link frames take precedence over joint
    /// frames of the same name.
    pub fn frame_id(&self, name: &str) -> Result<FrameId, RobotError> {
        self.frame_lookup.get(name).map(|&i| FrameId(i)).ok_or_else(|| RobotError::UnknownFrame {
            name: name.to_string(),
            suggestions: suggest(name, self.frames.iter().map(|f| f.name.as_str())),
        })
    }

    /// Ids of all frames, in [`frames`](Self::frames) order.
    pub fn frame_ids(&self) -> impl ExactSizeIterator<Item = FrameId> + use<> {
        (0..self.frames.len()).map(FrameId)
    }

    /// The frame of link number `link` of the description.
    pub fn link_frame(&self, link: usize) -> FrameId {
        FrameId(link)
    }

    /// Name of a frame.
    pub fn frame_name(&self, frame: FrameId) -> &str {
        &self.frames[frame.0].name
    }

    /// The active joints' names for a message: all of them up to 12, else
    /// the first and last five around how many are left out (a
    /// 100,000-link robot's full list made a 789 KB message).
    fn joint_list(&self) -> String {
        let names = &self.joint_names;
        if names.len() <= 12 {
            return names.join(", ");
        }
        let n = names.len();
        format!("{}, … {} more …, {}", names[..5].join(", "), n - 10, names[n - 5..].join(", "))
    }

    /// Checks that `q` has one finite value per active joint.
    pub fn check_configuration(&self, q: &[f64]) -> Result<(), RobotError> {
        if q.len() != self.nq() {
            return Err(RobotError::WrongDof { expected: self.nq(), got: q.len(), joints: self.joint_list() });
        }
        match q.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(index) => {
                Err(RobotError::NonFinite { joint: self.joint_names[index].clone(), index, value: q[index] })
            }
        }
    }

    /// Checks that `q` has one finite value per active joint, each within
    /// its joint's position limits.
    ///
    /// # Errors
    /// [`RobotError::WrongDof`], [`RobotError::NonFinite`], or
    /// [`RobotError::OutsideLimits`] naming the first joint at fault.
    pub fn check_within_limits(&self, q: &[f64]) -> Result<(), RobotError> {
        self.check_configuration(q)?;
        match q.iter().zip(&self.limits).position(|(v, l)| !l.contains(*v)) {
            None => Ok(()),
            Some(index) => Err(RobotError::OutsideLimits {
                joint: self.joint_names[index].clone(),
                index,
                value: q[index],
                lower: self.limits[index].lower,
                upper: self.limits[index].upper,
            }),
        }
    }

    /// True when every value of `q` lies within its joint's position limits.
    pub fn within_limits(&self, q: &[f64]) -> bool {
        q.len() == self.nq() && q.iter().zip(&self.limits).all(|(v, l)| l.contains(*v))
    }

    /// A configuration in the middle of the limits (0 for unlimited joints).
    pub fn neutral_configuration(&self) -> Vec<f64> {
        self.limits.iter().map(default_value).collect()
    }

    /// The value of every joint of the description (URDF order) at `q`:
    /// active joints from `q`, mimics from their targets, the rest held.
    pub fn all_joint_values(&self, q: &[f64]) -> Result<Vec<f64>, RobotError> {
        self.check_configuration(q)?;
        let mut values = self.held_values.clone();
        for (k, &j) in self.active.iter().enumerate() {
            values[j] = q[k];
        }
        let joints = self.description.joints();
        for j in 0..joints.len() {
            values[j] = resolve_value(joints, &values, j);
        }
        Ok(values)
    }
}

fn default_value(l: &JointLimits) -> f64 {
    if l.contains(0.0) { 0.0 } else { 0.5 * (l.lower + l.upper) }
}

/// Value of joint `j` given the values of independent joints (mimics
/// resolved, following a chain of mimics of any length without recursion;
/// the URDF loader refuses cycles).
fn resolve_value(joints: &[super::Joint], values: &[f64], j: usize) -> f64 {
    let (mut multiplier, mut offset, mut at) = (1.0, 0.0, j);
    while let Some(m) = &joints[at].mimic {
        // value(j) = multiplier · value(at) + offset, value(at) = m.multiplier · value(m.joint) + m.offset
        offset += multiplier * m.offset;
        multiplier *= m.multiplier;
        at = m.joint;
    }
    multiplier * values[at] + offset
}
