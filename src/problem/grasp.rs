//! Grasping with a parallel gripper: which parts of the gripper may come
//! close to what it grasps, how deep a grasp frame may lie in its object,
//! and a judge of a grasp at a configuration.
//!
//! A problem's gripper is its gripper frame (`robot.gripper`; its z axis is
//! the approach direction, e.g. the Panda's `panda_hand_tcp` between the
//! fingertips) and its **finger pads** (`robot.finger_pads`): named robot
//! collision elements forming the inner contact surfaces of the fingers.
//! The links that carry pads are the **fingers**; the other links on the
//! gripper frame's rigid body are the **palm**. A grasp goal lets only the
//! pads come close to its target object: the palm and the fingers' other
//! shapes are checked against it like against any body, with the margin
//! (see [`Problem::collision_model`]), in planning, optimization and
//! validation alike.
//!
//! **Depth.** A grasp frame's depth in its object is how far the object
//! extends from the frame's origin against the approach axis (the object's
//! support along −z of the frame, [`grasp_depth`]): how far the gripper
//! frame sinks into the object. The gripper reaches
//! [`GripperGeometry::max_depth`]: `robot.max_grasp_depth` when given, else
//! the distance along the gripper's z from the gripper frame back to the
//! farthest point of the palm's (padded) collision shapes; any deeper and
//! the palm enters the object. Problem files with a deeper grasp frame are
//! refused with [`GraspError::TooDeep`].
//!
//! **Judging** ([`GraspJudge`]): at a configuration, whether the object lies
//! between the finger pads (on the closing segment through the fingertip
//! centre), whether the fingertip centre lies within the
//! object's footprint along the approach axis, the gripper's tilt, and the
//! clearances of palm, fingers and pads from the object; a
//! [`GraspReport`] says whether that meets [`GraspCriteria`].
//!
//! ```
//! use tandem::robot::KinematicsWorkspace;
//! use tandem::problem::{GraspCriteria, GraspJudge, Problem, grasp_depth};
//! let problem = Problem::builtin("panda_grasp_box")?;
//! let judge = GraspJudge::new(&problem)?;
//! let max_depth = judge.geometry().max_depth().unwrap(); // m, from the Panda's palm
//! let box_ = problem.scene.object("box").unwrap();
//! assert!(grasp_depth(box_, &box_.grasps[0]) <= max_depth);
//! let mut ws = KinematicsWorkspace::new(&problem.robot);
//! let report = judge.judge(&mut ws, &problem.start, box_, &GraspCriteria::default())?;
//! assert!(!report.between_pads); // the start pose holds the gripper far above the box
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::Problem;
use crate::collision::{CollisionError, signed_distance};
use crate::robot::{FrameId, KinematicsWorkspace, RobotError, RobotModel};
use crate::scene::{GraspFrame, SceneObject, Shape};
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3, Vector3};
use thiserror::Error;

/// Errors about grasps and grippers.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GraspError {
    /// The problem names no gripper frame (`robot.gripper`).
    #[error("the problem names no gripper frame (robot.gripper)")]
    NoGripper,
    /// Judging a grasp needs finger pads (`robot.finger_pads`).
    #[error("the gripper has no finger pads (robot.finger_pads): cannot tell its fingers")]
    NoPads,
    /// A pad name that no collision element of the robot has.
    #[error("no robot collision element is named '{name}'{}", crate::robot::did_you_mean(suggestions))]
    UnknownPad {
        /// The pad name.
        name: String,
        /// Close names that exist.
        suggestions: Vec<String>,
    },
    /// Pads must lie on exactly two links, the fingers of a parallel gripper.
    #[error("finger pads must lie on exactly two links (a parallel gripper), they lie on [{}]", links.join(", "))]
    FingerCount {
        /// The links carrying pads.
        links: Vec<String>,
    },
    /// A grasp frame deeper in its object than the gripper reaches.
    #[error(
        "grasp frame '{grasp}' of '{object}' lies {depth:.4} m deep in the object along its approach axis, \
         but the gripper reaches only {max_depth:.4} m past its palm (robot.max_grasp_depth, or from the palm's geometry)"
    )]
    TooDeep {
        /// The object.
        object: String,
        /// The grasp frame.
        grasp: String,
        /// Its depth in the object (m).
        depth: f64,
        /// How deep the gripper reaches (m).
        max_depth: f64,
    },
    /// A bad collision element (mesh, dimension).
    #[error(transparent)]
    Collision(#[from] CollisionError),
    /// An unknown frame, or a configuration the robot rejects.
    #[error(transparent)]
    Robot(#[from] RobotError),
}

/// Depth (m) of grasp frame `grasp` in `object`: the object's extent from
/// the frame's origin against its approach axis (its support along the
/// frame's −z). Negative when the origin lies outside the object on the
/// approach side (e.g. an approach frame above it).
pub fn grasp_depth(object: &SceneObject, grasp: &GraspFrame) -> f64 {
    let up = -(grasp.pose.rotation * Vector3::z());
    object.shape.support(&up) - grasp.pose.translation.vector.dot(&up)
}

/// A collision shape of the gripper, on a robot frame.
#[derive(Debug, Clone)]
struct PlacedShape {
    frame: FrameId,
    shape: Shape,
    /// Pose of the shape in `frame`.
    local: IsometryMatrix3<f64>,
}

/// The gripper's collision geometry, split into palm, fingers and pads;
/// see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct GripperGeometry {
    gripper: FrameId,
    palm: Vec<PlacedShape>,
    /// Shapes of the finger links other than the pads.
    fingers: Vec<PlacedShape>,
    pads: Vec<PlacedShape>,
    /// Per finger: its link frame and the centroid of its pads (link frame).
    pad_centers: Vec<(FrameId, Point3<f64>)>,
    /// Robot padding (m): every shape is inflated by it.
    padding: f64,
    max_depth: Option<f64>,
}

impl GripperGeometry {
    /// The gripper of `problem`: its frame, the palm and fingers from its
    /// collision geometry (the `collision_urdf` one when given) and pads.
    ///
    /// # Errors
    /// No gripper frame; pad names that no collision element has; shapes
    /// tandem cannot build.
    pub fn new(problem: &Problem) -> Result<GripperGeometry, GraspError> {
        let spec = &problem.robot_spec;
        let robot = &problem.robot;
        let gripper = robot.frame_id(spec.gripper.as_deref().ok_or(GraspError::NoGripper)?)?;
        let geometry = problem.collision_geometry.as_deref().unwrap_or(robot.description());
        let element_names =
            || geometry.links().iter().flat_map(|l| l.collisions.iter().filter_map(|c| c.name.as_deref()));
        if let Some(name) = spec.finger_pads.iter().find(|p| !element_names().any(|e| e == p.as_str())) {
            let suggestions = crate::robot::suggest_names(name, element_names());
            return Err(GraspError::UnknownPad { name: name.clone(), suggestions });
        }
        let is_pad = |name: &Option<String>| name.as_ref().is_some_and(|n| spec.finger_pads.contains(n));
        let gripper_body = robot.frame_in_body(gripper).0;
        let mut geometry_out = GripperGeometry {
            gripper,
            palm: Vec::new(),
            fingers: Vec::new(),
            pads: Vec::new(),
            pad_centers: Vec::new(),
            padding: spec.padding,
            max_depth: spec.max_grasp_depth,
        };
        for (li, link) in robot.description().links().iter().enumerate() {
            let Some(source) = geometry.link(&link.name) else { continue };
            let frame = robot.link_frame(li);
            let is_finger = source.collisions.iter().any(|c| is_pad(&c.name));
            if !is_finger && robot.frame_in_body(frame).0 != gripper_body {
                continue;
            }
            let (mut pad_sum, mut pad_count) = (Vector3::zeros(), 0.0);
            for element in &source.collisions {
                let Some(shape) = Shape::from_geometry(&element.geometry).map_err(CollisionError::from)? else {
                    return Err(CollisionError::UnreadableMesh { link: link.name.clone() }.into());
                };
                let placed = PlacedShape { frame, shape, local: element.origin };
                match (is_finger, is_pad(&element.name)) {
                    (true, true) => {
                        pad_sum += element.origin.translation.vector;
                        pad_count += 1.0;
                        geometry_out.pads.push(placed);
                    }
                    (true, false) => geometry_out.fingers.push(placed),
                    (false, _) => geometry_out.palm.push(placed),
                }
            }
            if pad_count > 0.0 {
                geometry_out.pad_centers.push((frame, Point3::from(pad_sum / pad_count)));
            }
        }
        if geometry_out.max_depth.is_none() && !spec.finger_pads.is_empty() {
            geometry_out.max_depth = Some(geometry_out.palm_reach(robot));
        }
        Ok(geometry_out)
    }

    /// The gripper frame (its z axis is the approach direction).
    pub fn gripper_frame(&self) -> FrameId {
        self.gripper
    }

    /// How deep the gripper frame may lie in an object (m): stated, or
    /// from the palm (when the gripper has pads); `None` when unknown.
    pub fn max_depth(&self) -> Option<f64> {
        self.max_depth
    }

    /// Distance along the gripper's z from the gripper frame back to the
    /// farthest point of the palm's padded shapes along z (infinite
    /// without a palm).
    fn palm_reach(&self, robot: &RobotModel) -> f64 {
        let (body, gripper_in_body) = robot.frame_in_body(self.gripper);
        let to_gripper = gripper_in_body.inverse();
        let farthest = self
            .palm
            .iter()
            .filter(|s| robot.frame_in_body(s.frame).0 == body)
            .map(|s| {
                let pose = to_gripper * robot.frame_in_body(s.frame).1 * s.local;
                let z_in_shape = pose.rotation.inverse() * Vector3::z();
                pose.translation.z + s.shape.support(&z_in_shape) + self.padding
            })
            .fold(f64::NEG_INFINITY, f64::max);
        -farthest
    }

    /// Checks that every grasp frame of every object of `problem` lies no
    /// deeper than [`max_depth`](Self::max_depth) (nothing to check when
    /// unknown).
    ///
    /// # Errors
    /// [`GraspError::TooDeep`] for the first grasp frame that does not.
    pub fn check_depths(&self, problem: &Problem) -> Result<(), GraspError> {
        let Some(max_depth) = self.max_depth else { return Ok(()) };
        for object in problem.scene.objects() {
            for grasp in &object.grasps {
                let depth = grasp_depth(object, grasp);
                if depth > max_depth {
                    return Err(GraspError::TooDeep {
                        object: object.name.clone(),
                        grasp: grasp.name.clone(),
                        depth,
                        max_depth,
                    });
                }
            }
        }
        Ok(())
    }
}

/// What a grasp must meet to succeed; see [`GraspReport::failure`].
#[derive(Debug, Clone, PartialEq)]
pub struct GraspCriteria {
    /// World direction the gripper's approach axis (its z) should point
    /// along (unit). Default: straight down, `[0, 0, −1]`.
    pub approach: Vector3<f64>,
    /// Largest angle between the two (rad). Default 0.05.
    pub max_tilt: f64,
    /// Clearance (m) the palm and the fingers' shapes other than the pads
    /// must keep from the object. Default 0.005, the shipped problems'
    /// collision margin.
    pub margin: f64,
}

impl Default for GraspCriteria {
    fn default() -> Self {
        GraspCriteria { approach: -Vector3::z(), max_tilt: 0.05, margin: 0.005 }
    }
}

impl GraspCriteria {
    /// The criteria a solved grasp problem is held to: the grasp frame's
    /// approach axis, `max_tilt`, and the margin of the problem's collision
    /// inequalities at the final slice (the largest; 0 without one) less
    /// `tolerance` (m, what the optimizer may miss it by). `None` when the
    /// goal is not a grasp.
    pub fn for_goal(problem: &Problem, max_tilt: f64, tolerance: f64) -> Option<GraspCriteria> {
        let target = problem.grasp_target()?;
        let margin = problem
            .optimizer
            .objectives
            .iter()
            .filter(|o| o.feature == "collision" && o.kind == super::ObjectiveKind::Inequality && o.time.end >= 1.0)
            .map(|o| o.margin)
            .fold(0.0, f64::max);
        Some(GraspCriteria {
            approach: target.rotation * Vector3::z(),
            max_tilt,
            margin: (margin - tolerance).max(0.0),
        })
    }
}

/// A grasp measured at one configuration; see [`GraspJudge::judge`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspReport {
    /// The object crosses the closing segment: the segment joining the
    /// two fingers' pad centres, moved to pass through the gripper frame
    /// (the fingertip centre). Closing the fingers would meet it there.
    pub between_pads: bool,
    /// The line through the gripper frame along its approach axis crosses
    /// the object: the fingertip centre lies within the object's footprint
    /// seen along the approach.
    pub in_footprint: bool,
    /// Angle (rad) between the gripper's approach axis and the criteria's.
    pub tilt: f64,
    /// Smallest signed distance (m; negative inside) between the object
    /// and the palm's shapes.
    pub palm_clearance: f64,
    /// The same for the fingers' shapes other than the pads.
    pub finger_clearance: f64,
    /// The same for the pads (they may touch the object).
    pub pad_distance: f64,
}

impl GraspReport {
    /// Why the grasp fails `criteria`, or `None` when it succeeds.
    pub fn failure(&self, criteria: &GraspCriteria) -> Option<String> {
        if !self.between_pads {
            Some("the object is not between the finger pads".into())
        } else if !self.in_footprint {
            Some("the fingertip centre is outside the object's footprint".into())
        } else if self.tilt > criteria.max_tilt {
            Some(format!("the gripper is tilted {:.4} rad (at most {})", self.tilt, criteria.max_tilt))
        } else if self.palm_clearance < criteria.margin {
            Some(format!("the palm is {:.4} m from the object (at least {})", self.palm_clearance, criteria.margin))
        } else if self.finger_clearance < criteria.margin {
            let d = self.finger_clearance;
            Some(format!("a finger's outer side is {d:.4} m from the object (at least {})", criteria.margin))
        } else {
            None
        }
    }

    /// Whether the grasp meets `criteria`.
    pub fn success(&self, criteria: &GraspCriteria) -> bool {
        self.failure(criteria).is_none()
    }
}

/// Judges grasps of one problem's gripper; build it once, judge many
/// configurations (a simulator's episodes, a dataset's final slices).
#[derive(Debug, Clone)]
pub struct GraspJudge {
    geometry: GripperGeometry,
    robot: std::sync::Arc<RobotModel>,
}

impl GraspJudge {
    /// The judge of `problem`'s gripper.
    ///
    /// # Errors
    /// As [`GripperGeometry::new`]; a gripper without pads, or whose pads
    /// do not lie on exactly two links.
    pub fn new(problem: &Problem) -> Result<GraspJudge, GraspError> {
        let geometry = GripperGeometry::new(problem)?;
        if geometry.pads.is_empty() {
            return Err(GraspError::NoPads);
        }
        if geometry.pad_centers.len() != 2 {
            let links = geometry.pad_centers.iter().map(|(f, _)| problem.robot.frame_name(*f).to_string()).collect();
            return Err(GraspError::FingerCount { links });
        }
        Ok(GraspJudge { geometry, robot: problem.robot.clone() })
    }

    /// The gripper's geometry.
    pub fn geometry(&self) -> &GripperGeometry {
        &self.geometry
    }

    /// The robot whose gripper this judges.
    pub fn robot(&self) -> &std::sync::Arc<RobotModel> {
        &self.robot
    }

    /// Measures the grasp of `object` (free, or attached to the robot) at
    /// configuration `q`; `criteria` gives the approach axis the tilt is
    /// measured from.
    ///
    /// # Errors
    /// A configuration the robot rejects; an object attached to an unknown
    /// frame.
    pub fn judge(
        &self,
        ws: &mut KinematicsWorkspace,
        q: &[f64],
        object: &SceneObject,
        criteria: &GraspCriteria,
    ) -> Result<GraspReport, RobotError> {
        let robot = &self.robot;
        robot.forward_kinematics(ws, q)?;
        let object_pose = match &object.attachment {
            Some(a) => robot.frame_pose(ws, robot.frame_id(&a.frame)?) * a.pose,
            None => object.pose,
        };
        let clearance = |shapes: &[PlacedShape]| {
            shapes
                .iter()
                .map(|s| {
                    let pose = robot.frame_pose(ws, s.frame) * s.local;
                    signed_distance(&s.shape, &pose, &object.shape, &object_pose).distance - self.geometry.padding
                })
                .fold(f64::INFINITY, f64::min)
        };
        let centers: Vec<Point3<f64>> =
            self.geometry.pad_centers.iter().map(|(frame, c)| robot.frame_pose(ws, *frame) * c).collect();
        let gripper = robot.frame_pose(ws, self.geometry.gripper);
        let axis = gripper.rotation * Vector3::z();
        let reach =
            (gripper.translation.vector - object_pose.translation.vector).norm() + object.shape.bounding_radius() + 1.0;
        let tcp = Point3::from(gripper.translation.vector);
        // The pads' centroids may lie off the fingertips (a pad can run up
        // the whole finger): close through the gripper frame instead.
        let shift = tcp - nalgebra::center(&centers[0], &centers[1]);
        Ok(GraspReport {
            between_pads: segment_crosses(&(centers[0] + shift), &(centers[1] + shift), &object.shape, &object_pose),
            in_footprint: segment_crosses(&(tcp - axis * reach), &(tcp + axis * reach), &object.shape, &object_pose),
            tilt: axis.angle(&criteria.approach),
            palm_clearance: clearance(&self.geometry.palm),
            finger_clearance: clearance(&self.geometry.fingers),
            pad_distance: clearance(&self.geometry.pads),
        })
    }
}

/// Whether the segment from `a` to `b` (world) meets `shape` at `pose`.
fn segment_crosses(a: &Point3<f64>, b: &Point3<f64>, shape: &Shape, pose: &IsometryMatrix3<f64>) -> bool {
    let along = b - a;
    let length = along.norm();
    let rotation = Rotation3::rotation_between(&Vector3::z(), &along).unwrap_or_else(|| {
        // Antiparallel to z (or degenerate): a half turn about x.
        Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    let middle = Translation3::from(a.coords + along / 2.0);
    let segment = Shape::Capsule { radius: 0.0, half_length: length / 2.0 };
    signed_distance(&segment, &IsometryMatrix3::from_parts(middle, rotation), shape, pose).distance <= 0.0
}
