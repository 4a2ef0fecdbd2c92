//! Problems: a robot, a scene, a start, a goal, and the settings of the
//! planner and optimizer. Problem files in TOML (format in
//! `problems/README.md`), problem families that draw many problems from
//! one, MoveIt's scene and motion-plan request files, and grasp goals:
//! [`grasp`] says which parts of a gripper may touch what it grasps, how
//! deep a grasp frame may lie, and judges a grasp.
//!
//! ```
//! use tandem::problem::{Goal, Problem};
//! let problem = Problem::builtin("panda_grasp_box")?;
//! assert!(matches!(problem.goal, Goal::Grasp { .. }));
//! let model = problem.collision_model()?;
//! assert!(model.pair_count() > 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod family;
pub mod grasp;
mod joint_limits;
mod moveit;
mod moveit_scene;
pub(crate) mod moveit_yaml;
mod planner;
mod problem_file;
mod toml_source;

pub use family::{FamilySample, ProblemFamily, sample_seed};
pub use grasp::{GraspCriteria, GraspError, GraspJudge, GraspReport, GripperGeometry, grasp_depth};
pub use joint_limits::{JointLimitsFile, apply_builtin_limits, apply_joint_limits};
pub use moveit::{
    MOVEIT_CLEARANCE, MOVEIT_LIMIT_TOLERANCE, MoveItRequest, moveit_request_from_str, read_moveit_request,
};
pub use moveit_scene::{MoveItScene, PLANE_EXTENT, moveit_scene_from_str, read_moveit_scene};
pub use planner::{DynamicDomain, PlannerSettings, RootBias};
pub use problem_file::{MAX_HORIZON, MAX_TIME_LIMIT, MIN_HORIZON, MIN_PLANNER_CLEARANCE, MIN_PLANNER_RESOLUTION};

use crate::collision::{CollisionError, CollisionModel};
use crate::robot::{JointSelection, RobotDescription, RobotModel, Srdf};
use crate::scene::Scene;
use nalgebra::{IsometryMatrix3, Vector3};
use problem_file::RawProblem;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;
use toml_source::{KeyPath, line_of, line_of_path, path_at};

/// Errors loading a problem (or family) file: what is wrong, in which file,
/// at which key and line.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ProblemError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        #[source]
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not valid TOML, or a key is unknown, has the wrong type
    /// or an out-of-range value, or names something that does not exist.
    #[error("{file}{}: {}{message}", line.map(|l| format!(":{l}")).unwrap_or_default(), key.as_ref().map(|k| format!("{k}: ")).unwrap_or_default())]
    Invalid {
        /// The file (or `<builtin:NAME>`).
        file: String,
        /// 1-based line, when known.
        line: Option<u32>,
        /// Key path (e.g. `scene.obstacles[2].size`), when known.
        key: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A grasp the gripper cannot make, e.g. a grasp frame deeper in its
    /// object than the fingers reach ([`GraspError::TooDeep`]).
    #[error("{file}{}: {}{source}", line.map(|l| format!(":{l}")).unwrap_or_default(), key.as_ref().map(|k| format!("{k}: ")).unwrap_or_default())]
    Grasp {
        /// The file (or `<builtin:NAME>`).
        file: String,
        /// 1-based line, when known.
        line: Option<u32>,
        /// Key path, when known.
        key: Option<String>,
        /// Why the grasp cannot be made.
        #[source]
        source: Box<GraspError>,
    },
}

/// What the motion must achieve.
#[derive(Debug, Clone, PartialEq)]
pub enum Goal {
    /// Reach this configuration (one value per active joint).
    Joints(Vec<f64>),
    /// Bring robot frame `frame` to `position` (world, m); when given, also
    /// to `orientation`, or point its `axis` (its own x, y or z) along
    /// world `direction`.
    Pose {
        /// The robot frame to place.
        frame: String,
        /// Target position (world, m).
        position: Vector3<f64>,
        /// Target orientation (world), if any.
        orientation: Option<nalgebra::Rotation3<f64>>,
        /// Frame axis (0 = x, 1 = y, 2 = z) to point along a world direction, if any.
        axis_alignment: Option<(usize, Vector3<f64>)>,
    },
    /// Grasp scene object `object` at its grasp frame `grasp` with the gripper frame.
    Grasp {
        /// The scene object to grasp.
        object: String,
        /// Its grasp frame.
        grasp: String,
    },
}

/// How an objective enters the optimization problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectiveKind {
    /// A sum-of-squares cost.
    SumOfSquares,
    /// An equality constraint.
    Equality,
    /// An inequality constraint (feature ≤ 0).
    Inequality,
}

/// A span of the motion, as fractions of its duration (0 = start, 1 = end).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeRange {
    /// Fraction of the duration where it starts (0 ≤ start ≤ end).
    pub start: f64,
    /// Fraction where it ends (≤ 1).
    pub end: f64,
}

/// One objective of the optimizer, as data: feature, time range, kind,
/// scale, target and order (see docs/design.md, "Objectives are data").
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectiveSpec {
    /// Feature name: `joint_state`, `joint_limits`, `position`,
    /// `position_difference`, `scalar_product`, `orientation_difference`,
    /// `collision`, `control`.
    pub feature: String,
    /// Frames the feature reads: robot frames, objects (`box`) or grasp
    /// frames (`box/top`).
    pub frames: Vec<String>,
    /// Frame axes (`x`, `y`, `z`) for `scalar_product`.
    pub axes: Vec<usize>,
    /// Where in the motion it applies.
    pub time: TimeRange,
    /// Cost, equality or inequality.
    pub kind: ObjectiveKind,
    /// Weight of its rows (> 0).
    pub scale: f64,
    /// Value the feature is driven to (default 0).
    pub target: Option<Vec<f64>>,
    /// 0: the feature itself; 1: its velocity; 2: its acceleration.
    pub order: u8,
    /// Safety margin (m or rad) for `collision` and `joint_limits`.
    pub margin: f64,
    /// `collision` only: the margin (m) to the scene's obstacles, when it
    /// differs from `margin` (which then holds between robot shapes and to
    /// the scene's objects).
    pub obstacle_margin: Option<f64>,
}

/// Trajectory optimizer settings and objectives.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizerSettings {
    /// Number of optimized configurations q_1..q_T.
    pub horizon: usize,
    /// Duration of the motion (s).
    pub duration: f64,
    /// Order k of the problem: configurations before q_1 fixed to the start.
    pub order: u8,
    /// Evaluation budget of the optimizer (trial points, rejected ones included).
    pub max_iterations: usize,
    /// The objectives, as data.
    pub objectives: Vec<ObjectiveSpec>,
}

impl Default for OptimizerSettings {
    fn default() -> Self {
        OptimizerSettings { horizon: 50, duration: 5.0, order: 2, max_iterations: 500, objectives: Vec::new() }
    }
}

/// How the robot is loaded.
#[derive(Debug, Clone)]
pub struct RobotSpec {
    /// The robot's URDF.
    pub urdf: PathBuf,
    /// Its SRDF, if given.
    pub srdf: Option<PathBuf>,
    /// A second URDF of the same robot whose collision geometry replaces the
    /// first's (e.g. a sphere-set approximation).
    pub collision_urdf: Option<PathBuf>,
    /// Which joints move.
    pub selection: JointSelection,
    /// Values of inactive joints (rad or m).
    pub hold: Vec<(String, f64)>,
    /// The gripper (end-effector) frame.
    pub gripper: Option<String>,
    /// Names of the collision elements that are the fingers' inner contact
    /// surfaces: the only robot geometry a grasp goal lets come close to
    /// its target (see [`grasp`]).
    pub finger_pads: Vec<String>,
    /// How deep the gripper frame may lie in an object (m); `None`: from
    /// the palm's geometry (see [`GripperGeometry`]).
    pub max_grasp_depth: Option<f64>,
    /// Collision padding of the robot shapes (m).
    pub padding: f64,
    /// Where the joints' velocity, acceleration, deceleration and jerk
    /// limits came from beyond the URDF: a `joint_limits.yaml` (as given)
    /// or `builtin:franka_panda` / `builtin:franka_fr3`; `None` for the
    /// robot's own (see [`RobotModel::motion_limits`](crate::robot::RobotModel::motion_limits)).
    pub joint_limits: Option<String>,
}

/// A loaded, validated problem.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Problem name.
    pub name: String,
    /// One line for humans.
    pub description: String,
    /// Where it came from (a path, or `<builtin:NAME>`).
    pub origin: String,
    /// How the robot was loaded.
    pub robot_spec: RobotSpec,
    /// The compiled robot.
    pub robot: Arc<RobotModel>,
    /// Its SRDF, if given.
    pub srdf: Option<Srdf>,
    /// A second description whose collision geometry replaces the robot's.
    pub collision_geometry: Option<Arc<RobotDescription>>,
    /// Obstacles and objects.
    pub scene: Scene,
    /// Start configuration (rad or m).
    pub start: Vec<f64>,
    /// What the motion must achieve.
    pub goal: Goal,
    /// RRT-Connect settings.
    pub planner: PlannerSettings,
    /// Optimizer settings and objectives.
    pub optimizer: OptimizerSettings,
    /// What loading tolerated and left out, one line each naming the file
    /// and line: SRDF entries and allowed-collision-matrix names the robot
    /// and scene lack (MoveIt ignores them too). `tandem check` lists them.
    pub warnings: Vec<String>,
}

/// The problem files shipped with tandem, by name, embedded in the binary.
pub const BUILTIN_PROBLEMS: [(&str, &str); 4] = [
    ("panda_reach", include_str!("../../problems/panda_reach.toml")),
    ("panda_reach_obstacle", include_str!("../../problems/panda_reach_obstacle.toml")),
    ("panda_grasp_box", include_str!("../../problems/panda_grasp_box.toml")),
    ("planar_pick", include_str!("../../problems/planar_pick.toml")),
];

/// Context for building errors: the file and its text.
pub(crate) struct Source<'a> {
    pub(crate) origin: &'a str,
    pub(crate) text: &'a str,
    /// Folder relative paths are resolved against; `None` for builtins.
    pub(crate) base: Option<&'a Path>,
}

impl Source<'_> {
    /// An error at `path`, located by line.
    pub(crate) fn error(&self, path: &KeyPath, message: impl Into<String>) -> ProblemError {
        let key = path.to_string();
        ProblemError::Invalid {
            file: self.origin.to_string(),
            line: line_of_path(self.text, path),
            key: (!key.is_empty()).then_some(key),
            message: message.into(),
        }
    }

    /// Of the keys `keys` of the table at `table`, the one written last in
    /// the file (to point at the key that conflicts with an earlier one).
    pub(crate) fn last_in_file<'k>(&self, table: &KeyPath, keys: &[&'k str]) -> &'k str {
        keys.iter().copied().max_by_key(|k| line_of_path(self.text, &table.key(k))).unwrap_or_default()
    }

    /// A TOML syntax or serde error, with the key found from its span.
    pub(crate) fn toml_error(&self, e: &toml::de::Error) -> ProblemError {
        // A missing top-level key comes with an empty span at 0: no line or
        // key of the file is to blame (it is not the first key's fault).
        let top_level = e.message().starts_with("missing field");
        let span = e.span().filter(|s| !(top_level && s.is_empty() && s.start == 0));
        let key = span.as_ref().and_then(|s| path_at(self.text, s.start)).map(|p| p.to_string());
        ProblemError::Invalid {
            file: self.origin.to_string(),
            line: span.map(|s| line_of(self.text, s.start)),
            key: key.filter(|k| !k.is_empty()),
            message: e.message().trim().to_string(),
        }
    }

    /// `relative` resolved against the file's folder; builtins resolve the
    /// shipped Panda paths to the embedded robot.
    pub(crate) fn resolve(&self, relative: &str) -> PathBuf {
        match self.base {
            Some(base) => base.join(relative),
            None => PathBuf::from(relative),
        }
    }
}

/// A file read for parsing: its text, name and folder.
pub(crate) struct SourceFile {
    origin: String,
    text: String,
    base: PathBuf,
}

impl SourceFile {
    pub(crate) fn read(path: &Path) -> Result<SourceFile, ProblemError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProblemError::Io { path: path.into(), source })?;
        let base = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        Ok(SourceFile { origin: path.display().to_string(), text, base: base.to_path_buf() })
    }

    pub(crate) fn source(&self) -> Source<'_> {
        Source { origin: &self.origin, text: &self.text, base: Some(&self.base) }
    }
}

impl Problem {
    /// Loads and validates a problem file; relative paths in it are
    /// resolved against its folder.
    ///
    /// # Errors
    /// [`ProblemError`] naming the file, key and line.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Problem, ProblemError> {
        Problem::from_source(&SourceFile::read(path.as_ref())?.source())
    }

    /// One of the shipped problems ([`BUILTIN_PROBLEMS`]), embedded in the
    /// binary: it loads anywhere, with the embedded Panda.
    ///
    /// # Errors
    /// An unknown name.
    pub fn builtin(name: &str) -> Result<Problem, ProblemError> {
        let (_, text) = BUILTIN_PROBLEMS.iter().find(|(n, _)| *n == name).ok_or_else(|| ProblemError::Invalid {
            file: format!("<builtin:{name}>"),
            line: None,
            key: None,
            message: format!(
                "no builtin problem named '{name}' (have: {})",
                BUILTIN_PROBLEMS.map(|(n, _)| n).join(", ")
            ),
        })?;
        Problem::from_source(&Source { origin: &format!("<builtin:{name}>"), text, base: None })
    }

    /// Parses problem text as if read from `origin`, resolving relative
    /// paths against `base` (or, with `None`, mapping the shipped Panda
    /// paths to the embedded robot).
    ///
    /// # Errors
    /// As [`from_file`](Self::from_file).
    pub fn from_str_with(text: &str, origin: &str, base: Option<&Path>) -> Result<Problem, ProblemError> {
        Problem::from_source(&Source { origin, text, base })
    }

    pub(crate) fn from_source(src: &Source) -> Result<Problem, ProblemError> {
        let raw: RawProblem = toml::from_str(src.text).map_err(|e| src.toml_error(&e))?;
        raw.into_problem(src)
    }

    /// The world pose of the grasp target, for a grasp goal.
    pub fn grasp_target(&self) -> Option<IsometryMatrix3<f64>> {
        match &self.goal {
            Goal::Grasp { object, grasp } => self.scene.grasp_pose(object, grasp).ok(),
            _ => None,
        }
    }

    /// The collision model of the robot in this scene, with the SRDF's
    /// disabled pairs, the padding, the finger pads as groups of their own
    /// (named like their collision elements) and — for a grasp goal —
    /// contact between the pads and the target object allowed: every other
    /// robot shape, palm and fingers included, is checked against it.
    ///
    /// # Errors
    /// See [`CollisionModelBuilder::build`](crate::collision::CollisionModelBuilder::build).
    pub fn collision_model(&self) -> Result<CollisionModel, CollisionError> {
        self.collision_model_padded(0.0)
    }

    /// [`collision_model`](Self::collision_model) with the robot shapes
    /// padded by `extra` (m) on top of the problem's padding.
    ///
    /// # Errors
    /// As [`collision_model`](Self::collision_model).
    pub fn collision_model_padded(&self, extra: f64) -> Result<CollisionModel, CollisionError> {
        let targets: Vec<&str> = match &self.goal {
            Goal::Grasp { object, .. } => vec![object.as_str()],
            _ => vec![],
        };
        self.collision_model_grasping(&targets, extra)
    }

    /// The collision model with contact allowed between the finger pads and
    /// each of `objects` (the grasp targets; e.g. every object an operator
    /// may be reaching for), padded by `extra` (m).
    ///
    /// # Errors
    /// As [`collision_model`](Self::collision_model).
    pub fn collision_model_grasping(&self, objects: &[&str], extra: f64) -> Result<CollisionModel, CollisionError> {
        let mut scene = self.scene.clone();
        let pads = &self.robot_spec.finger_pads;
        for object in objects {
            for pad in pads {
                scene.allow_contact(pad.clone(), object.to_string());
            }
        }
        let mut builder = CollisionModel::builder(self.robot.clone())
            .scene(&scene)
            .padding(self.robot_spec.padding + extra)
            .surface_groups(pads.iter().cloned());
        if let Some(srdf) = &self.srdf {
            builder = builder.srdf(srdf);
        }
        if let Some(geometry) = &self.collision_geometry {
            builder = builder.geometry_from(geometry.clone());
        }
        builder.build()
    }

    /// The same problem with its grasp goal moved to scene object `object`:
    /// the goal grasps `object` at the grasp frame of the same name, and
    /// every objective frame of the old target (`box`, `box/approach`)
    /// names the new one (`cup`, `cup/approach`). One goal-conditioned
    /// problem per graspable object, for shared control.
    ///
    /// # Errors
    /// A goal that is not a grasp; an unknown object, or one without the
    /// goal's grasp frame.
    pub fn retarget_grasp(&self, object: &str) -> Result<Problem, ProblemError> {
        let invalid = |message: String| ProblemError::Invalid {
            file: self.origin.clone(),
            line: None,
            key: Some("goal.grasp".into()),
            message,
        };
        let Goal::Grasp { object: old, grasp } = &self.goal else {
            return Err(invalid("the goal is not a grasp: it cannot be moved to another object".into()));
        };
        let target = self.scene.object(object).ok_or_else(|| invalid(format!("no scene object named '{object}'")))?;
        if !target.grasps.iter().any(|g| &g.name == grasp) {
            return Err(invalid(format!("object '{object}' has no grasp frame '{grasp}'")));
        }
        let mut problem = self.clone();
        problem.goal = Goal::Grasp { object: object.to_string(), grasp: grasp.clone() };
        let prefix = format!("{old}/");
        for spec in &mut problem.optimizer.objectives {
            for frame in &mut spec.frames {
                if frame == old {
                    *frame = object.to_string();
                } else if let Some(rest) = frame.strip_prefix(&prefix) {
                    *frame = format!("{object}/{rest}");
                }
            }
        }
        problem.name = format!("{}@{object}", self.name);
        Ok(problem)
    }
}
