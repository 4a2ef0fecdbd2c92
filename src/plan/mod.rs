//! Collision-free seeds for the optimizer: inverse kinematics for pose and
//! grasp goals, RRT-Connect in the active joint space, shortcutting and
//! resampling to the optimizer's horizon.
//!
//! ```
//! use tandem::plan::plan_problem;
//! use tandem::problem::Problem;
//! let problem = Problem::builtin("panda_reach_obstacle").unwrap();
//! let report = plan_problem(&problem, Some(1)).unwrap();
//! assert_eq!(report.result.status, tandem::plan::PlanStatus::Solved);
//! println!("{} waypoints, {:.2} rad", report.path.len(), tandem::plan::path_length(&report.path));
//! ```

mod ik;
mod nearest;
mod postprocess;
mod rrt;

pub use ik::{IkError, IkSettings, IkTarget, solve_ik};
pub use postprocess::{MIN_GAIN, path_length, resample, shortcut};
pub use rrt::{EdgeCheck, LazySearch, PlanResult, PlanStatus, rrt_connect, rrt_connect_lazy};

use crate::collision::{CollisionError, CollisionModel, CollisionWorkspace};
use crate::problem::{Goal, PlannerSettings, Problem};
use crate::robot::RobotError;
use std::time::{Duration, Instant};
use thiserror::Error;

/// Errors planning a problem (a failed search is not an error: see [`PlanStatus`]).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PlanError {
    #[error(transparent)]
    /// The collision model cannot be built.
    Collision(#[from] CollisionError),
    #[error("goal: {0}")]
    /// Inverse kinematics of the goal failed.
    Ik(#[from] IkError),
    #[error(transparent)]
    /// A robot-side error.
    Robot(#[from] RobotError),
    /// A grasp goal names no gripper frame.
    #[error("the problem's goal needs robot.gripper")]
    NoGripper,
}

/// A planned problem.
#[derive(Debug, Clone)]
pub struct PlanReport {
    /// The raw RRT-Connect result.
    pub result: PlanResult,
    /// The goal configurations the planner aimed at.
    pub goals: Vec<Vec<f64>>,
    /// The shortcut path (empty unless solved).
    pub path: Vec<Vec<f64>>,
    /// Time of IK + planning, and of shortcutting (and certification).
    pub planning_time: Duration,
    /// Time of shortcutting and certification.
    pub simplify_time: Duration,
    /// Whether every edge of `path` passed the certified check (see
    /// [`CollisionModel::motion_free_certified`]; with the planner
    /// clearance on the sphere fast path, half of it otherwise); false
    /// also when the clearance is 0 (not asked).
    pub certified: bool,
    /// Planner runs (seeds) it took: off the sphere fast path, a search
    /// whose path fails certification is redone with the next seed, up to
    /// 4 times.
    pub attempts: usize,
}

/// Resolution (rad or m) of the lazy search's discrete edge checks
/// ([`LazySearch`]) in [`ProblemPlanner::run`]. Instructions of planning
/// and simplification (callgrind) against certifying every edge searched:
/// Panda's 699 −2 %, TIAGo `table` −13.5 %, Baxter `shelf` −9 % at 0.1;
/// 0.07 and 0.14 saved less (finer: dearer checks; coarser: more
/// branches cut when their edges fail certification).
const LAZY_RESOLUTION: f64 = 0.1;

/// Random shortcut attempts after planning (after the greedy pass; on a
/// MotionBenchMaker sample, 50 give paths 0.5 % longer than 100 in three
/// quarters of the time).
const SHORTCUTS: usize = 50;

/// Number of IK solutions sought for pose and grasp goals.
const GOAL_SOLUTIONS: usize = 4;

/// Goal configurations of `problem`: its joint goal, or IK solutions for a
/// pose or grasp goal (gripper frame onto the grasp frame).
///
/// # Errors
/// IK failures, with the reason.
pub fn goal_configurations(
    problem: &Problem,
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    seed: u64,
) -> Result<Vec<Vec<f64>>, PlanError> {
    let robot = &problem.robot;
    let target = match &problem.goal {
        Goal::Joints(q) => return Ok(vec![q.clone()]),
        Goal::Pose { frame, position, orientation, axis_alignment } => IkTarget {
            frame: robot.frame_id(frame)?,
            position: *position,
            orientation: *orientation,
            axis_alignment: *axis_alignment,
        },
        Goal::Grasp { .. } => {
            let gripper = problem.robot_spec.gripper.as_deref().ok_or(PlanError::NoGripper)?;
            let pose = problem.grasp_target().ok_or(PlanError::NoGripper)?;
            IkTarget {
                frame: robot.frame_id(gripper)?,
                position: pose.translation.vector,
                orientation: Some(pose.rotation),
                axis_alignment: None,
            }
        }
    };
    let settings = IkSettings { seed, ..IkSettings::default() };
    Ok(solve_ik(model, ws, &target, &problem.start, GOAL_SOLUTIONS, &settings)?)
}

/// A problem made ready to plan: its collision models (exact, and padded
/// by the clearance for the search), workspaces and goal configurations.
/// Build once, then [`run`](Self::run) with as many seeds as wanted.
pub struct ProblemPlanner {
    model: CollisionModel,
    ws: CollisionWorkspace,
    search: CollisionModel,
    search_ws: CollisionWorkspace,
    start: Vec<f64>,
    goals: Vec<Vec<f64>>,
    settings: PlannerSettings,
}

impl ProblemPlanner {
    /// Prepares `problem`; pose and grasp goals are solved by IK here,
    /// seeded with `seed` (default: the problem's planner seed).
    ///
    /// # Errors
    /// A collision model that cannot be built, unreachable goals.
    pub fn new(problem: &Problem, seed: Option<u64>) -> Result<ProblemPlanner, PlanError> {
        ProblemPlanner::with_model(problem, problem.collision_model()?, seed)
    }

    /// As [`new`](Self::new), with `problem`'s collision model built
    /// already ([`Problem::collision_model`]; the pipeline builds it once
    /// for the planner and the optimizer).
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn with_model(
        problem: &Problem,
        model: CollisionModel,
        seed: Option<u64>,
    ) -> Result<ProblemPlanner, PlanError> {
        let mut ws = CollisionWorkspace::new(&model);
        // The search runs on shapes padded by the clearance, so the discrete
        // edge samples keep a margin that the certification can rely on.
        let search = problem.collision_model_padded(problem.planner.clearance)?;
        let search_ws = CollisionWorkspace::new(&search);
        let mut settings = problem.planner.clone();
        settings.seed = seed.unwrap_or(settings.seed);
        let goals = goal_configurations(problem, &model, &mut ws, settings.seed)?;
        let start = problem.start.clone();
        Ok(ProblemPlanner { model, ws, search, search_ws, start, goals, settings })
    }

    /// The planner's settings (the problem's), to tune before
    /// [`run`](Self::run) (for instance dynamic-domain sampling or
    /// balancing off, as plain RRT-Connect); the seed is `run`'s, and the
    /// clearance was fixed by [`new`](Self::new) (its padded shapes).
    pub fn search_settings_mut(&mut self) -> &mut PlannerSettings {
        &mut self.settings
    }

    /// The goal configurations the planner aims at.
    pub fn goals(&self) -> &[Vec<f64>] {
        &self.goals
    }

    /// Plans with `seed`, shortcuts, and certifies the path (clearance > 0).
    /// On the sphere fast path the search is lazy ([`rrt_connect_lazy`]):
    /// its trees grow on discrete checks of the shapes padded by the
    /// clearance, and the edges of the path found are certified
    /// ([`EdgeCheck::Certified`] with the planner clearance: every
    /// configuration keeps half of it), as is every shortcut. Otherwise edges are sampled
    /// at the planner resolution on shapes padded by the clearance, the
    /// final path is certified, and a search whose path fails is redone
    /// with the next seed, up to 4 runs. Times exclude the preparation in
    /// [`new`](Self::new).
    ///
    /// # Errors
    /// Bad configurations (none for a validated problem).
    pub fn run(&mut self, seed: u64) -> Result<PlanReport, PlanError> {
        let clearance = self.settings.clearance;
        if clearance > 0.0 && self.model.has_fast_path() {
            return self.run_certified(seed);
        }
        let began = Instant::now();
        let mut simplify_time = Duration::ZERO;
        let mut attempts = 0;
        // The search samples its edges on the padded shapes (clearance 0);
        // the path found is certified with the clearance after.
        let mut search = PlannerSettings { clearance: 0.0, ..self.settings.clone() };
        loop {
            search.seed = seed.wrapping_add(attempts as u64);
            attempts += 1;
            let result = rrt_connect(&self.search, &mut self.search_ws, &self.start, &self.goals, &search)?;
            let planning_time = began.elapsed() - simplify_time;
            let (mut path, mut certified) = (Vec::new(), false);
            if result.status == PlanStatus::Solved {
                let t = Instant::now();
                let (edge, s) = (EdgeCheck::of(&search), search.seed);
                path = shortcut(&self.search, &mut self.search_ws, &result.path, edge, SHORTCUTS, s)?;
                certified = clearance > 0.0 && certify(&self.model, &mut self.ws, &path, clearance / 2.0)?;
                simplify_time += t.elapsed();
            }
            let done = result.status != PlanStatus::Solved || certified || clearance == 0.0 || attempts >= 4;
            if done {
                let goals = self.goals.clone();
                return Ok(PlanReport { result, goals, path, planning_time, simplify_time, certified, attempts });
            }
        }
    }

    /// [`run`](Self::run) with certified edges throughout.
    fn run_certified(&mut self, seed: u64) -> Result<PlanReport, PlanError> {
        let settings = PlannerSettings { seed, ..self.settings.clone() };
        let edge = EdgeCheck::of(&settings);
        let began = Instant::now();
        let lazy = LazySearch { padded: &self.search, ws: &mut self.search_ws, resolution: LAZY_RESOLUTION };
        let result = rrt_connect_lazy(&self.model, &mut self.ws, lazy, &self.start, &self.goals, &settings)?;
        let planning_time = began.elapsed();
        let solved = result.status == PlanStatus::Solved;
        let path =
            if solved { shortcut(&self.model, &mut self.ws, &result.path, edge, SHORTCUTS, seed)? } else { Vec::new() };
        let simplify_time = began.elapsed() - planning_time;
        let goals = self.goals.clone();
        Ok(PlanReport { result, goals, path, planning_time, simplify_time, certified: solved, attempts: 1 })
    }
}

/// Plans `problem` with its planner settings (seed overridden by `seed`):
/// [`ProblemPlanner::new`] then [`ProblemPlanner::run`]; the reported
/// planning time includes the preparation (IK, collision models).
///
/// # Errors
/// A collision model that cannot be built, unreachable goals.
pub fn plan_problem(problem: &Problem, seed: Option<u64>) -> Result<PlanReport, PlanError> {
    let began = Instant::now();
    let mut planner = ProblemPlanner::new(problem, seed)?;
    let prepared = began.elapsed();
    let mut report = planner.run(planner.settings.seed)?;
    report.planning_time += prepared;
    Ok(report)
}

/// Whether every edge of `path` passes the certified motion check.
fn certify(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    path: &[Vec<f64>],
    clearance: f64,
) -> Result<bool, RobotError> {
    for w in path.windows(2) {
        if !model.motion_free_certified(ws, &w[0], &w[1], clearance)? {
            return Ok(false);
        }
    }
    Ok(true)
}
