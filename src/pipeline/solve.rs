//! Plan → optimize → validate for one problem ([`solve_problem`]), and
//! the solution as a reference and a tracking policy.

use super::PipelineError;
use super::validate::{Validation, validate};
use crate::control::{ControlError, GainSchedule, TrackingPolicy, TrackingWeights};
use crate::komo::{
    Initialization, KomoError, TrajectoryOptimizer, TrajectoryProblem, TrajectoryResult, stiff_solver_settings,
    trajectory_solver_settings,
};
use crate::plan::{PlanReport, PlanStatus, ProblemPlanner};
use crate::problem::Problem;
use crate::trajectory::{JointTrajectory, TrajectoryError};
use std::time::{Duration, Instant};
use tandem_solvers::least_squares::{SolveReport, SolverSettings, Termination};

/// Settings of [`solve_problem`].
#[derive(Debug, Clone, PartialEq)]
pub struct SolveSettings {
    /// Seed of IK and RRT-Connect (default: the problem's planner seed).
    pub seed: Option<u64>,
    /// Overrides the problem's horizon T.
    pub horizon: Option<usize>,
    /// Joint step of the final collision check between slices (rad).
    pub validation_resolution: f64,
    /// What the optimizer starts from.
    pub initial_guess: InitialGuess,
}

impl Default for SolveSettings {
    fn default() -> Self {
        SolveSettings { seed: None, horizon: None, validation_resolution: 0.002, initial_guess: InitialGuess::Planned }
    }
}

/// What the trajectory optimizer starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum InitialGuess {
    /// RRT-Connect's shortcut path, to whichever goal configuration its
    /// trees reached first (the straight line to the first goal
    /// configuration when planning fails).
    #[default]
    Planned,
    /// The straight joint-space line to the goal configuration nearest the
    /// start (usually IK's descent from the start); the planned path only
    /// when the optimizer does not converge collision-free from it. The
    /// motion is then a function of the task, not of the planner's seed
    /// (which of the redundant arm's goal configurations, which way around
    /// an obstacle): a network fitted to motions that differ by seed learns
    /// their mean.
    Straight,
}

/// The outcome of planning and optimizing one problem.
#[derive(Debug, Clone)]
pub struct ProblemSolution {
    /// The RRT-Connect run; it seeded the optimizer unless the straight
    /// [`InitialGuess`] converged.
    pub plan: PlanReport,
    /// `q_1 … q_T`.
    pub trajectory: Vec<Vec<f64>>,
    /// Active joint names, the order of each configuration.
    pub joints: Vec<String>,
    /// Seconds between slices.
    pub time_step: f64,
    /// How the solve went.
    pub report: SolveReport,
    /// Checks of the result between slices.
    pub validation: Validation,
    /// Preparation, planning, optimization and validation.
    pub total_time: Duration,
}

impl ProblemSolution {
    /// Converged with every constraint within tolerance, collision-free at
    /// the validation resolution, within limits.
    pub fn converged(&self) -> bool {
        succeeded(&self.report, &self.validation)
    }

    /// `converged`, `in_collision`, `plan_failed`, or the solver's
    /// termination (`infeasible`, `iteration_limit`, …).
    pub fn status(&self) -> &'static str {
        match self.report.termination {
            Termination::Converged if !self.validation.collision_free => "in_collision",
            Termination::Converged if !self.validation.within_limits => "outside_limits",
            t if self.plan.result.status != PlanStatus::Solved && t != Termination::Converged => "plan_failed",
            t => t.as_str(),
        }
    }
}

impl ProblemSolution {
    /// The trajectory as a reference for tracking: `start` (the problem's
    /// start configuration, which the optimizer holds fixed), then `q_1 …
    /// q_T`, `time_step` apart.
    ///
    /// # Errors
    /// A `start` of the wrong length or with non-finite values.
    pub fn reference(&self, start: &[f64]) -> Result<JointTrajectory, TrajectoryError> {
        let mut waypoints = Vec::with_capacity(self.trajectory.len() + 1);
        waypoints.push(start.to_vec());
        waypoints.extend(self.trajectory.iter().cloned());
        JointTrajectory::new(self.joints.clone(), self.time_step, &waypoints)
    }

    /// An LQR tracking policy of [`reference`](Self::reference) in one call.
    ///
    /// # Errors
    /// As [`reference`](Self::reference) and [`TrackingPolicy::new`].
    pub fn tracking_policy(
        &self,
        start: &[f64],
        weights: TrackingWeights,
        schedule: GainSchedule,
    ) -> Result<TrackingPolicy, ControlError> {
        TrackingPolicy::new(self.reference(start)?, weights, schedule)
    }
}

/// The report of a solve continued by another: counts and time add up,
/// the rest is the last solve's.
fn combine(first: &SolveReport, last: SolveReport) -> SolveReport {
    SolveReport {
        outer_iterations: first.outer_iterations + last.outer_iterations,
        inner_steps: first.inner_steps + last.inner_steps,
        evaluations: first.evaluations + last.evaluations,
        time: first.time + last.time,
        ..last
    }
}

/// Converged with every constraint within tolerance, collision-free at
/// the validation resolution, within limits.
fn succeeded(report: &SolveReport, validation: &Validation) -> bool {
    report.termination == Termination::Converged && validation.collision_free && validation.within_limits
}

/// Optimizes `problem` from `init` with `settings` and validates the
/// result; a converged result that collides between slices is re-solved
/// from itself with collision rows between slices (1, 3, 7, then 15 per
/// interval) until it does not.
fn optimize_and_refine(
    problem: &TrajectoryProblem,
    settings: &SolverSettings,
    init: Initialization,
    resolution: f64,
) -> Result<(TrajectoryResult, Validation), PipelineError> {
    let mut optimizer = TrajectoryOptimizer::new(problem.clone(), settings.clone());
    let mut result = optimizer.solve(init)?;
    let mut validation = validate(optimizer.problem(), &result.trajectory, resolution)?;
    // Only a converged result is worth refining; a failed solve is reported.
    for substeps in [1, 3, 7, 15] {
        if validation.collision_free || result.report.termination != Termination::Converged {
            break;
        }
        let mut refined = TrajectoryOptimizer::new(problem.clone().with_collision_substeps(substeps), settings.clone());
        let next = refined.solve(Initialization::Warm(&result.trajectory))?;
        result.report = combine(&result.report, next.report);
        result.trajectory = next.trajectory;
        validation = validate(refined.problem(), &result.trajectory, resolution)?;
    }
    Ok((result, validation))
}

/// Plans `problem` with RRT-Connect, then optimizes from the shortcut path
/// (from the straight line to the first goal configuration when planning
/// fails; first of all, to the goal configuration nearest the start, with
/// [`InitialGuess::Straight`]), and validates
/// the result; a result that collides between slices
/// is re-optimized with collision checks between slices (1, 3, 7, then 15 per
/// interval). When that fails (not converged, or still colliding) from a
/// planned path, all of it runs once more with [`stiff_solver_settings`];
/// the report counts the evaluations and time of both tries.
///
/// # Errors
/// Objectives or goals the problem cannot resolve, unreachable IK goals.
pub fn solve_problem(problem: &Problem, settings: &SolveSettings) -> Result<ProblemSolution, PipelineError> {
    let began = Instant::now();
    // One build of the collision model for the optimizer and the planner.
    let model = problem.collision_model().map_err(KomoError::from)?;
    let mut problem_t = TrajectoryProblem::from_problem_and_model(problem, model.clone())?;
    if let Some(horizon) = settings.horizon {
        problem_t = problem_t.with_horizon(horizon)?;
    }
    let mut planner = ProblemPlanner::with_model(problem, model, settings.seed)?;
    let plan = planner.run(settings.seed.unwrap_or(problem.planner.seed))?;
    let solver = SolverSettings { max_evaluations: problem.optimizer.max_iterations, ..trajectory_solver_settings() };
    let init = match (plan.path.is_empty(), plan.goals.first()) {
        (false, _) => Initialization::Path(&plan.path),
        (true, Some(goal)) => Initialization::Interpolate(goal),
        (true, None) => Initialization::Interpolate(&problem.start),
    };
    let resolution = settings.validation_resolution;
    // The goal configuration nearest the start, for the straight guess only.
    let nearest_goal = || {
        let from_start = |q: &[f64]| q.iter().zip(&problem.start).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
        plan.goals.iter().min_by(|a, b| from_start(a).total_cmp(&from_start(b)))
    };
    let straight = match settings.initial_guess {
        InitialGuess::Straight => match nearest_goal() {
            Some(goal) => {
                Some(optimize_and_refine(&problem_t, &solver, Initialization::Interpolate(goal), resolution)?)
            }
            None => None,
        },
        InitialGuess::Planned => None,
    };
    let tried = match straight {
        Some(tried) if succeeded(&tried.0.report, &tried.1) => tried,
        straight => {
            let mut tried = optimize_and_refine(&problem_t, &solver, init, resolution)?;
            // From a collision-free path, a failure is worth a second, stiffer try.
            if !succeeded(&tried.0.report, &tried.1) && !plan.path.is_empty() {
                let second = optimize_and_refine(&problem_t, &stiff_solver_settings(&solver), init, resolution)?;
                let (kept, other) =
                    if succeeded(&second.0.report, &second.1) { (second, tried) } else { (tried, second) };
                // Counts and time of both tries; the rest of the one kept.
                tried = (TrajectoryResult { report: combine(&other.0.report, kept.0.report), ..kept.0 }, kept.1);
            }
            // A straight guess that failed counts too.
            if let Some((first, _)) = straight {
                tried.0.report = combine(&first.report, tried.0.report);
            }
            tried
        }
    };
    let (result, validation) = tried;
    let total_time = began.elapsed();
    Ok(ProblemSolution {
        joints: problem.robot.joint_names().to_vec(),
        time_step: problem_t.time_step(),
        trajectory: result.trajectory,
        report: result.report,
        validation,
        total_time,
        plan,
    })
}
