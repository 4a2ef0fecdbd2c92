//! Running the optimizer: initialisation, the solve, and the trajectory
//! problem of a problem file. Planning the seed, validating the result and
//! accepting it are the [pipeline](crate::pipeline)'s.

use super::KomoError;
use super::objective::{Objective, default_objectives, objective_from_spec};
use super::problem::{Evaluator, TrajectoryProblem, TrajectoryWorkspace};
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::plan::resample;
use crate::problem::{Goal, Problem};
use tandem_solvers::least_squares::{AugmentedLagrangian, SolveError, SolveReport, SolverSettings};

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

/// The settings of [`solve_problem`](crate::pipeline::solve_problem)'s second try: from `settings`, a
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
        TrajectoryProblem::from_problem_and_model(problem, problem.collision_model()?)
    }

    /// As [`from_problem`](Self::from_problem), with `problem`'s collision
    /// model ([`Problem::collision_model`]) built already.
    ///
    /// # Errors
    /// As [`from_problem`](Self::from_problem).
    pub fn from_problem_and_model(problem: &Problem, model: CollisionModel) -> Result<TrajectoryProblem, KomoError> {
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
