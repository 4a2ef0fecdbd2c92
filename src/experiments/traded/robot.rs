//! The robot side of traded control (§7.3.1 of the dissertation): three
//! 6 × 6 × 12 cm boxes on the table of `panda_grasp_box`, each with a top and
//! a side grasp frame; a committed `(object, direction)` becomes a grasp
//! problem that is planned (IK of the grasp frame → RRT-Connect →
//! shortcutting, [`plan_problem`]) and executed: along the path, the gripper
//! closes, and back (retrieval).
//!
//! Execution time is the path timed at [`JOINT_SPEED`] on the joint that
//! moves most per segment, twice (there and back), plus [`GRIPPER_SECONDS`].
//!
//! ```no_run
//! use tandem::experiments::traded::{GraspDirection, TradedScene};
//! let scene = TradedScene::new(&[[0.5, -0.2, 0.06], [0.55, 0.0, 0.06], [0.5, 0.2, 0.06]])?;
//! let grasp = scene.plan(&[true; 3], 1, GraspDirection::Side, 7)?;
//! println!("planned in {:.3} s, executes in {:.1} s", grasp.planning_seconds, grasp.execution_seconds);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::hand::GraspDirection;
use crate::plan::{PlanError, PlanStatus, plan_problem};
use crate::problem::{Goal, Problem, ProblemError};
use crate::scene::SceneError;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use thiserror::Error;

/// Joint speed of execution (rad/s; the Panda allows 2.1–2.6).
pub const JOINT_SPEED: f64 = 1.0;

/// Time to close the gripper on the object (s).
pub const GRIPPER_SECONDS: f64 = 0.5;

/// Errors setting up or planning a traded grasp.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum TradedError {
    /// The base problem cannot be loaded or retargeted.
    #[error(transparent)]
    Problem(#[from] ProblemError),
    /// An object cannot be placed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Planning failed outright (not a failed search).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The classifier failed.
    #[error(transparent)]
    Learn(#[from] crate::learn::LearnError),
    /// A setting out of range.
    #[error(transparent)]
    InvalidSetting(#[from] crate::settings::InvalidSetting),
    /// Objects that cannot be placed as asked (off the table, other than the
    /// scene's).
    #[error("traded control: {0}")]
    Placement(String),
}

/// A planned grasp.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedGrasp {
    /// Whether RRT-Connect found a path.
    pub solved: bool,
    /// Wall-clock IK + planning + shortcutting (s).
    pub planning_seconds: f64,
    /// Grasp and retrieval (s); `NaN` when not solved.
    pub execution_seconds: f64,
}

/// The table with the three boxes.
#[derive(Debug, Clone)]
pub struct TradedScene {
    base: Problem,
    objects: Vec<[f64; 3]>,
}

/// Box names on the table.
fn object_name(i: usize) -> String {
    format!("box{i}")
}

impl TradedScene {
    /// Boxes centred at `objects` (world, m), upright.
    ///
    /// # Errors
    /// The builtin problem fails to load (a build defect).
    pub fn new(objects: &[[f64; 3]]) -> Result<TradedScene, TradedError> {
        let base = Problem::builtin("panda_grasp_box")?;
        Ok(TradedScene { base, objects: objects.to_vec() })
    }

    /// Object centres (world, m).
    pub fn objects(&self) -> &[[f64; 3]] {
        &self.objects
    }

    /// The grasp problem of `object` from `direction` with the objects
    /// `present` on the table.
    ///
    /// # Errors
    /// `object` out of range or not present; scene errors.
    pub fn problem(&self, present: &[bool], object: usize, direction: GraspDirection) -> Result<Problem, TradedError> {
        if object >= self.objects.len() || !present.get(object).copied().unwrap_or(false) {
            return Err(TradedError::Placement(format!("object {object} is not on the table")));
        }
        let template = self
            .base
            .scene
            .object("box")
            .cloned()
            .ok_or_else(|| TradedError::Placement("panda_grasp_box has no box".into()))?;
        let mut problem = self.base.clone();
        problem.scene = crate::scene::Scene::new();
        for o in self.base.scene.obstacles() {
            problem.scene.add_obstacle(o.clone())?;
        }
        for (a, b) in self.base.scene.allowed_contacts() {
            problem.scene.allow_contact(a.clone(), b.clone());
        }
        for (i, c) in self.objects.iter().enumerate().filter(|(i, _)| present[*i]) {
            let mut obj = template.clone();
            obj.name = object_name(i);
            obj.pose = IsometryMatrix3::from_parts(Translation3::new(c[0], c[1], c[2]), Rotation3::identity());
            // Side grasp: the gripper's z along world +x into the box, its x
            // down, fingers closing along y; 14 mm into the box's near face,
            // 2 cm above its centre.
            let side = Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
            obj.add_grasp("side", IsometryMatrix3::from_parts(Translation3::new(-0.016, 0.0, 0.02), side));
            problem.scene.add_object(obj)?;
        }
        let grasp = match direction {
            GraspDirection::Top => "grasp",
            GraspDirection::Side => "side",
        };
        problem.goal = Goal::Grasp { object: "box".into(), grasp: grasp.into() };
        // retarget_grasp renames the optimizer's frames too.
        Ok(problem.retarget_grasp(&object_name(object))?)
    }

    /// Plans the grasp of `object` from `direction` with the objects
    /// `present`, RRT seed `seed`.
    ///
    /// # Errors
    /// See [`problem`](Self::problem); planner setup errors.
    pub fn plan(
        &self,
        present: &[bool],
        object: usize,
        direction: GraspDirection,
        seed: u64,
    ) -> Result<PlannedGrasp, TradedError> {
        let problem = self.problem(present, object, direction)?;
        let report = plan_problem(&problem, Some(seed))?;
        let solved = report.result.status == PlanStatus::Solved && !report.path.is_empty();
        let planning_seconds = report.planning_time.as_secs_f64() + report.simplify_time.as_secs_f64();
        let execution_seconds = if solved { 2.0 * timed(&report.path) + GRIPPER_SECONDS } else { f64::NAN };
        Ok(PlannedGrasp { solved, planning_seconds, execution_seconds })
    }
}

/// Duration of `path` (rad) at [`JOINT_SPEED`] on its fastest joint per
/// segment (s).
fn timed(path: &[Vec<f64>]) -> f64 {
    path.windows(2).map(|w| w[0].iter().zip(&w[1]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / JOINT_SPEED).sum()
}
