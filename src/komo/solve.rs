//! Running the optimizer: initialisation, the solve, validation of the
//! result at fine resolution, and the whole plan-then-optimize pipeline
//! for a problem file.

use super::KomoError;
use super::objective::{Objective, default_objectives, objective_from_spec};
use super::problem::{Evaluator, TrajectoryProblem, TrajectoryWorkspace};
use crate::collision::CollisionWorkspace;
use crate::control::{ControlError, GainSchedule, TrackingPolicy, TrackingWeights};
use crate::plan::{PlanReport, PlanStatus, ProblemPlanner, resample};
use crate::problem::{Goal, Problem};
use crate::trajectory::{JointTrajectory, TrajectoryError};
use std::time::{Duration, Instant};
use tandem_solvers::least_squares::{AugmentedLagrangian, SolveError, SolveReport, SolverSettings, Termination};

/// Where the optimization starts.
#[derive(Debug, Clone, Copy)]
pub enum Initialization<'a> {
    /// A path from the start (e.g. RRT-Connect's), resampled by arc length
    /// to `T + 1` configurations; the first (the start) is dropped.
    Path(&'a [Vec<f64>]),
    /// The straight joint-space line from the start to this configuration.
    Interpolate(&'a [f64]),
    /// `q_1 … q_T` of an earlier solution (a warm start; the optimizer also
    /// keeps the multipliers of its own last solve).
    Warm(&'a [Vec<f64>]),
}

/// Checks of a trajectory beyond the solver's own measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Validation {
    /// No collision on the straight joint-space motions start → q_1 → … →
    /// q_T, checked so that no joint moves more than `resolution` between
    /// checks.
    pub collision_free: bool,
    /// Smallest signed distance over the slices (m); `None` without a
    /// collision model.
    pub min_distance: Option<f64>,
    /// Every slice within the joint limits.
    pub within_limits: bool,
    /// The resolution of the collision check (rad or m).
    pub resolution: f64,
}

/// An optimized trajectory and how the solve went.
#[derive(Debug, Clone)]
pub struct TrajectoryResult {
    /// `q_1 … q_T`.
    pub trajectory: Vec<Vec<f64>>,
    /// How the solve went.
    pub report: SolveReport,
}

/// A [`TrajectoryProblem`] with its workspace and solver, ready to solve
/// again and again (e.g. with warm starts) without allocating.
pub struct TrajectoryOptimizer {
    problem: TrajectoryProblem,
    workspace: TrajectoryWorkspace,
    solver: AugmentedLagrangian,
    x: Vec<f64>,
}

/// Solver settings suited to trajectories: constraints to 1e-5 (m, rad),
/// steps bounded to 0.5 rad per joint per iteration, and an inner loop
/// that stops once a step gains less than 1e-4 of the cost.
///
/// Measured on `panda_grasp_family.toml` (150 samples, T = 50): polishing
/// the cost to 1e-10 crawls (Gauss-Newton converges linearly on curved
/// constraints) for a mean of 26.7 evaluations instead of 17.8, and the
/// mean cost moves by less than 1e-4 of itself; a 0.3 rad bound takes 15 %
/// more evaluations for the same costs, 0.8 reaches worse local optima.
pub fn trajectory_solver_settings() -> SolverSettings {
    SolverSettings { max_step: 0.5, step_tolerance: 1e-5, cost_tolerance: 1e-4, ..SolverSettings::default() }
}

/// The settings of [`solve_problem`]'s second try: from `settings`, a
/// penalty 100 times stiffer from the start and steps of at most 0.25
/// rad, so that the collision constraints the planner's path meets stay
/// met while the cost pulls.
///
/// Why a second try: with few slices, the smoothness pull can move the
/// motion through a thin obstacle (a cage's 2–3 cm walls and bars) before
/// the penalty has grown: the first solve converges, the validation finds
/// the collision, and the refinement with collision rows between slices
/// cannot pull the motion back out. On the Baxter's `cage` problems of
/// `motionbenchmaker_robots` (both arms in one cage, T = 50), 4 of 30
/// ended `infeasible` that way (1.4–2.6 cm deep), and all 4 converge
/// collision-free with these settings. They are kept for the second try,
/// so that every problem the first settings solve is solved as before.
pub fn stiff_solver_settings(settings: &SolverSettings) -> SolverSettings {
    SolverSettings { initial_penalty: 100.0 * settings.initial_penalty, max_step: 0.25, ..settings.clone() }
}

impl TrajectoryOptimizer {
    /// Allocates the workspace and solver for `problem`.
    pub fn new(problem: TrajectoryProblem, settings: SolverSettings) -> TrajectoryOptimizer {
        let workspace = TrajectoryWorkspace::new(&problem);
        let dimension = problem.horizon() * problem.nq();
        let solver = AugmentedLagrangian::new(dimension, problem.bandwidth(), settings);
        TrajectoryOptimizer { problem, workspace, solver, x: vec![0.0; dimension] }
    }

    /// The trajectory problem it solves.
    pub fn problem(&self) -> &TrajectoryProblem {
        &self.problem
    }

    /// Solver settings (take effect at the next solve).
    pub fn settings_mut(&mut self) -> &mut SolverSettings {
        self.solver.settings_mut()
    }

    /// Writes the stacked `q_1 … q_T` of `init` into `x`.
    ///
    /// # Errors
    /// [`KomoError::Initialization`] for wrong lengths or non-finite values.
    pub fn initialize(&self, init: Initialization, x: &mut [f64]) -> Result<(), KomoError> {
        let (n, horizon, start) = (self.problem.nq(), self.problem.horizon(), self.problem.start());
        let bad = |m: String| Err(KomoError::Initialization(m));
        if x.len() != n * horizon {
            return bad(format!("x has {} values, expected T·nq = {}", x.len(), n * horizon));
        }
        let rows: Vec<Vec<f64>> = match init {
            Initialization::Path([]) => return bad("the path is empty".into()),
            Initialization::Path(path) => resample(path, horizon + 1).split_off(1),
            Initialization::Interpolate(goal) => (1..=horizon)
                .map(|t| start.iter().zip(goal).map(|(a, b)| a + (b - a) * t as f64 / horizon as f64).collect())
                .collect(),
            Initialization::Warm(trajectory) => trajectory.to_vec(),
        };
        if rows.len() != horizon || rows.iter().any(|r| r.len() != n) {
            return bad(format!("expected {horizon} configurations of {n} joints"));
        }
        for (t, row) in rows.iter().enumerate() {
            if let Some(k) = row.iter().position(|v| !v.is_finite()) {
                return bad(format!("configuration {} has a non-finite value at joint {k}", t + 1));
            }
            x[t * n..(t + 1) * n].copy_from_slice(row);
        }
        Ok(())
    }

    /// Optimizes from `init`.
    ///
    /// # Errors
    /// A bad initialisation, or a configuration the robot model rejects.
    pub fn solve(&mut self, init: Initialization) -> Result<TrajectoryResult, KomoError> {
        let mut x = std::mem::take(&mut self.x);
        let warm = matches!(init, Initialization::Warm(_));
        let result = self.initialize(init, &mut x).and_then(|()| self.run(&mut x, warm));
        let trajectory = x.chunks(self.problem.nq()).map(<[f64]>::to_vec).collect();
        self.x = x;
        Ok(TrajectoryResult { trajectory, report: result? })
    }

    /// Optimizes the stacked `q_1 … q_T` in `x` in place, then clamps it
    /// into the joint limits (moving it by at most the inequality
    /// tolerance). Allocates nothing once the row counts have been seen.
    ///
    /// # Errors
    /// A configuration the robot model rejects (wrong size, not finite).
    pub fn solve_in_place(&mut self, x: &mut [f64]) -> Result<SolveReport, KomoError> {
        self.run(x, false)
    }

    /// The solve; `warm` keeps the last solve's multipliers and penalty.
    fn run(&mut self, x: &mut [f64], warm: bool) -> Result<SolveReport, KomoError> {
        let mut evaluator = Evaluator { problem: &self.problem, workspace: &mut self.workspace };
        let solved = match warm {
            true => self.solver.solve_warm(&mut evaluator, x),
            false => self.solver.solve(&mut evaluator, x),
        };
        let report = solved.map_err(|e| match e {
            SolveError::Evaluation(e) => KomoError::Robot(e),
            other => KomoError::Initialization(other.to_string()),
        })?;
        let limits = self.problem.robot().limits();
        for q in x.chunks_mut(self.problem.nq()) {
            for (v, l) in q.iter_mut().zip(limits) {
                *v = v.clamp(l.lower, l.upper);
            }
        }
        Ok(report)
    }

    /// Checks `trajectory` (`q_1 … q_T`) for collisions between slices at
    /// `resolution` and for joint limits.
    ///
    /// # Errors
    /// Configurations the model rejects; a bad resolution.
    pub fn validate(&self, trajectory: &[Vec<f64>], resolution: f64) -> Result<Validation, KomoError> {
        let robot = self.problem.robot();
        let within_limits = trajectory.iter().all(|q| robot.within_limits(q));
        let (mut collision_free, mut min_distance) = (true, None);
        if let Some(model) = self.problem.collision_model() {
            let mut ws = CollisionWorkspace::new(model);
            let mut previous = self.problem.start();
            for q in trajectory {
                collision_free &= model.motion_free(&mut ws, previous, q, resolution)?;
                // Only pairs closer than the closest so far matter.
                let below = min_distance.unwrap_or(f64::INFINITY);
                if let Some(d) = model.min_distance_below(&mut ws, q, below)? {
                    min_distance = Some(d.signed.distance);
                }
                previous = q;
            }
        }
        Ok(Validation { collision_free, min_distance, within_limits, resolution })
    }
}

impl TrajectoryProblem {
    /// The trajectory problem of a problem file: its optimizer settings and
    /// objectives, or [`default_objectives`] when it lists none (collision
    /// margin: 5 mm, or less when the start or a joint goal is closer).
    ///
    /// # Errors
    /// Objectives the problem cannot resolve; a collision model that cannot
    /// be built.
    pub fn from_problem(problem: &Problem) -> Result<TrajectoryProblem, KomoError> {
        let model = problem.collision_model()?;
        let objectives: Vec<Objective> = if problem.optimizer.objectives.is_empty() {
            let mut ws = CollisionWorkspace::new(&model);
            let mut margin: f64 = 0.005;
            let mut ends = vec![problem.start.as_slice()];
            if let Goal::Joints(goal) = &problem.goal {
                ends.push(goal);
            }
            for q in ends {
                if let Some(d) = model.min_distance(&mut ws, q)? {
                    margin = margin.min(0.5 * d.signed.distance.max(0.0));
                }
            }
            default_objectives(problem, margin)?
        } else {
            problem
                .optimizer
                .objectives
                .iter()
                .map(|spec| objective_from_spec(problem, spec))
                .collect::<Result<_, _>>()?
        };
        let settings = &problem.optimizer;
        TrajectoryProblem::new(
            problem.robot.clone(),
            Some(model),
            objectives,
            settings.horizon,
            settings.order as usize,
            settings.duration,
            problem.start.clone(),
        )
    }
}

/// Options of [`solve_problem`].
#[derive(Debug, Clone, PartialEq)]
pub struct SolveOptions {
    /// Seed of IK and RRT-Connect (default: the problem's planner seed).
    pub seed: Option<u64>,
    /// Overrides the problem's horizon T.
    pub horizon: Option<usize>,
    /// Joint step of the final collision check between slices (rad).
    pub validation_resolution: f64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions { seed: None, horizon: None, validation_resolution: 0.002 }
    }
}

/// The outcome of planning and optimizing one problem.
#[derive(Debug, Clone)]
pub struct ProblemSolution {
    /// The RRT-Connect run that seeded the optimizer.
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
) -> Result<(TrajectoryResult, Validation), KomoError> {
    let mut optimizer = TrajectoryOptimizer::new(problem.clone(), settings.clone());
    let mut result = optimizer.solve(init)?;
    let mut validation = optimizer.validate(&result.trajectory, resolution)?;
    // Only a converged result is worth refining; a failed solve is reported.
    for substeps in [1, 3, 7, 15] {
        if validation.collision_free || result.report.termination != Termination::Converged {
            break;
        }
        let mut refined = TrajectoryOptimizer::new(problem.clone().with_collision_substeps(substeps), settings.clone());
        let next = refined.solve(Initialization::Warm(&result.trajectory))?;
        result.report = combine(&result.report, next.report);
        result.trajectory = next.trajectory;
        validation = refined.validate(&result.trajectory, resolution)?;
    }
    Ok((result, validation))
}

/// Plans `problem` with RRT-Connect, then optimizes from the shortcut path
/// (from the straight line to the first goal configuration when planning
/// fails), and validates the result; a result that collides between slices
/// is re-optimized with collision checks between slices (1, 3, 7, then 15 per
/// interval). When that fails (not converged, or still colliding) from a
/// planned path, all of it runs once more with [`stiff_solver_settings`];
/// the report counts the evaluations and time of both tries.
///
/// # Errors
/// Objectives or goals the problem cannot resolve, unreachable IK goals.
pub fn solve_problem(problem: &Problem, options: &SolveOptions) -> Result<ProblemSolution, KomoError> {
    let began = Instant::now();
    let mut problem_t = TrajectoryProblem::from_problem(problem)?;
    if let Some(horizon) = options.horizon {
        problem_t = problem_t.with_horizon(horizon)?;
    }
    let mut planner = ProblemPlanner::new(problem, options.seed)?;
    let plan = planner.run(options.seed.unwrap_or(problem.planner.seed))?;
    let settings = SolverSettings { max_evaluations: problem.optimizer.max_iterations, ..trajectory_solver_settings() };
    let init = match (plan.path.is_empty(), plan.goals.first()) {
        (false, _) => Initialization::Path(&plan.path),
        (true, Some(goal)) => Initialization::Interpolate(goal),
        (true, None) => Initialization::Interpolate(&problem.start),
    };
    let resolution = options.validation_resolution;
    let mut tried = optimize_and_refine(&problem_t, &settings, init, resolution)?;
    // From a collision-free path, a failure is worth a second, stiffer try.
    if !succeeded(&tried.0.report, &tried.1) && !plan.path.is_empty() {
        let second = optimize_and_refine(&problem_t, &stiff_solver_settings(&settings), init, resolution)?;
        let (kept, other) = if succeeded(&second.0.report, &second.1) { (second, tried) } else { (tried, second) };
        // Counts and time of both tries; the rest of the one kept.
        tried = (TrajectoryResult { report: combine(&other.0.report, kept.0.report), ..kept.0 }, kept.1);
    }
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
