//! The accepted solve of one problem, as bulk generation and DAgger run
//! it: [`solve_problem`] up to [`PipelineSettings::attempts`] times (odd
//! attempts with the grasp turned about its approach axis, each with
//! another planner seed), each result held to the acceptance checks
//! ([`validate`](fn@super::validate), [`goal_miss`], [`judge_grasp`]).
//! Budgets are evaluations, never seconds, so that the outcome depends on
//! the problem, the seed and the settings only.

use super::PipelineError;
use super::solve::{InitialGuess, ProblemSolution, SolveSettings, solve_problem};
use super::validate::{GoalMiss, goal_miss, judge_grasp};
use crate::plan::{IkError, PlanError};
use crate::problem::{Goal, GraspReport, MAX_HORIZON, MIN_HORIZON, Problem, sample_seed};
use crate::settings::{InvalidSetting, check, positive};
use std::borrow::Cow;
use std::time::Duration;

/// Most attempts per problem ([`PipelineSettings::attempts`]).
pub const MAX_ATTEMPTS: u32 = 100;
/// Largest evaluation budget of one optimizer solve
/// ([`PipelineSettings::max_evaluations`]).
pub const MAX_EVALUATIONS: usize = 1_000_000;

/// How one problem is solved and accepted; every field decides the outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct PipelineSettings {
    /// Horizon T (default: the problem's).
    pub horizon: Option<usize>,
    /// IK + planning + optimization attempts, each with another planner
    /// seed, before the problem is rejected (1 … [`MAX_ATTEMPTS`]).
    pub attempts: u32,
    /// Evaluation budget of each optimizer solve (the problem's
    /// `optimizer.max_iterations` is replaced; 1 … [`MAX_EVALUATIONS`]): a
    /// problem that needs more is better retried with the flipped grasp
    /// than pushed on.
    pub max_evaluations: usize,
    /// Joint step of the final collision check between slices (rad).
    pub validation_resolution: f64,
    /// q_T within this distance (m) of the goal.
    pub goal_tolerance: f64,
    /// q_T within this angle (rad) of the goal orientation.
    pub goal_angle_tolerance: f64,
    /// What each attempt's optimizer starts from.
    pub initial_guess: InitialGuess,
}

impl Default for PipelineSettings {
    fn default() -> Self {
        PipelineSettings {
            horizon: None,
            attempts: 3,
            max_evaluations: 200,
            validation_resolution: SolveSettings::default().validation_resolution,
            goal_tolerance: 1e-3,
            goal_angle_tolerance: 1e-2,
            initial_guess: InitialGuess::Planned,
        }
    }
}

impl PipelineSettings {
    /// Checks every setting against its bound; settings the command line
    /// gives are named by their option (`--attempts`).
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        if let Some(t) = self.horizon.filter(|t| !(MIN_HORIZON..=MAX_HORIZON).contains(t)) {
            return Err(InvalidSetting::new("--horizon", t, format!("between {MIN_HORIZON} and {MAX_HORIZON}")));
        }
        if !(1..=MAX_ATTEMPTS).contains(&self.attempts) {
            return Err(InvalidSetting::new("--attempts", self.attempts, format!("between 1 and {MAX_ATTEMPTS}")));
        }
        if !(1..=MAX_EVALUATIONS).contains(&self.max_evaluations) {
            let expected = format!("between 1 and {MAX_EVALUATIONS}");
            return Err(InvalidSetting::new("--max-evaluations", self.max_evaluations, expected));
        }
        let min = crate::collision::MIN_RESOLUTION;
        let r = self.validation_resolution;
        check("validation_resolution", r, r >= min && r.is_finite(), &format!("finite and at least {min} rad"))?;
        positive("goal_tolerance", self.goal_tolerance, "m")?;
        positive("goal_angle_tolerance", self.goal_angle_tolerance, "rad")
    }
}

/// A solution that passed every check.
#[derive(Debug, Clone)]
pub struct Accepted {
    /// The problem solved: the one given with the settings' budgets, its
    /// grasp turned about the approach axis when an odd attempt succeeded.
    pub problem: Problem,
    /// The solution.
    pub solution: ProblemSolution,
    /// The attempt that produced it (0 = the first).
    pub attempt: u32,
    /// How far q_T is from the goal.
    pub goal_miss: GoalMiss,
    /// The grasp at q_T, for grasp goals of a gripper with finger pads.
    pub grasp: Option<GraspReport>,
}

/// Why no solution was accepted.
#[derive(Debug, Clone, PartialEq)]
pub struct Rejected {
    /// Stable snake_case reason: `ik_unreachable`, `ik_in_collision`,
    /// `plan_failed`, `in_collision`, `outside_limits`, `goal_missed`,
    /// `grasp_failed` (see [`GraspReport::failure`]), a solver termination
    /// (`infeasible`, `iteration_limit`, …) or `error`.
    pub reason: &'static str,
    /// A human-readable explanation, naming the attempt.
    pub detail: String,
}

/// The problem of attempt `attempt`: odd attempts of a grasp turn the grasp
/// frame by π about its approach axis
/// ([`Scene::flip_grasp`](crate::scene::Scene::flip_grasp)), an equivalent
/// grasp whose wrist motion can avoid what blocked the first.
fn attempt_problem(problem: &Problem, attempt: u32) -> Cow<'_, Problem> {
    match &problem.goal {
        Goal::Grasp { object, grasp } if attempt % 2 == 1 => {
            let mut flipped = problem.clone();
            match flipped.scene.flip_grasp(object, grasp) {
                Ok(()) => Cow::Owned(flipped),
                Err(_) => Cow::Borrowed(problem),
            }
        }
        _ => Cow::Borrowed(problem),
    }
}

/// Solves `problem` with random stream `seed` until a solution passes
/// every check, up to `settings.attempts` times: attempt `a` seeds IK and
/// RRT-Connect with `sample_seed(seed, a)` (`seed` itself for a = 0), so a
/// retry explores another goal configuration and initial path. The
/// planner's time budget is lifted (its iteration budget bounds the work)
/// so that machine load cannot change the outcome. Returns the outcome and
/// the time spent planning (IK, RRT-Connect, shortcutting).
pub fn solve_accepted(
    mut problem: Problem,
    seed: u64,
    settings: &PipelineSettings,
) -> (Result<Accepted, Rejected>, Duration) {
    problem.planner.time_limit = UNLIMITED_SECONDS;
    problem.optimizer.max_iterations = settings.max_evaluations;
    let mut plan_time = Duration::ZERO;
    let mut rejected = Rejected { reason: "error", detail: "no attempt was made".into() };
    for attempt in 0..settings.attempts.max(1) {
        let variant = attempt_problem(&problem, attempt);
        let (outcome, planned) = solve_attempt(&variant, seed, attempt, settings);
        plan_time += planned;
        match outcome {
            Ok((solution, goal_miss, grasp)) => {
                let problem = match variant {
                    Cow::Owned(flipped) => flipped,
                    Cow::Borrowed(_) => problem,
                };
                return (Ok(Accepted { problem, solution, attempt, goal_miss, grasp }), plan_time);
            }
            Err(r) => rejected = r,
        }
    }
    (Err(rejected), plan_time)
}

/// A solution that passed the checks, how far it is from the goal, and
/// its grasp.
type Checked = (ProblemSolution, GoalMiss, Option<GraspReport>);

/// Planner budget of an accepted solve (s): effectively none.
const UNLIMITED_SECONDS: f64 = 1e6;

/// One IK + planning + optimization attempt and its checks.
fn solve_attempt(
    problem: &Problem,
    seed: u64,
    attempt: u32,
    settings: &PipelineSettings,
) -> (Result<Checked, Rejected>, Duration) {
    let reject = |reason: &'static str, detail: String| Rejected {
        reason,
        detail: format!("attempt {}: {detail}", attempt + 1),
    };
    let planner_seed = if attempt == 0 { seed } else { sample_seed(seed, u64::from(attempt)) };
    let solve = SolveSettings {
        seed: Some(planner_seed),
        horizon: settings.horizon,
        validation_resolution: settings.validation_resolution,
        initial_guess: settings.initial_guess,
    };
    let solution = match solve_problem(problem, &solve) {
        Ok(s) => s,
        Err(e) => return (Err(reject(error_reason(&e), e.to_string())), Duration::ZERO),
    };
    let plan_time = solution.plan.planning_time + solution.plan.simplify_time;
    let outcome = match solution.status() {
        "converged" => accept(problem, attempt, solution, settings),
        status => Err(reject(status, format!("the solve ended {status}: {}", describe(&solution)))),
    };
    (outcome, plan_time)
}

fn error_reason(e: &PipelineError) -> &'static str {
    match e {
        PipelineError::Plan(e) => match **e {
            PlanError::Ik(IkError::Unreachable { .. }) => "ik_unreachable",
            PlanError::Ik(IkError::InCollision { .. }) => "ik_in_collision",
            _ => "error",
        },
        _ => "error",
    }
}

fn describe(s: &ProblemSolution) -> String {
    format!(
        "plan {}, eq {:.1e}, ineq {:.1e}, min distance {:.2e} m",
        s.plan.result.status.name(),
        s.report.equality_violation,
        s.report.inequality_violation,
        s.validation.min_distance.unwrap_or(f64::INFINITY)
    )
}

/// The checks of a converged solution: q_T at the goal, and the grasp.
fn accept(
    problem: &Problem,
    attempt: u32,
    solution: ProblemSolution,
    settings: &PipelineSettings,
) -> Result<Checked, Rejected> {
    let error =
        |e: &dyn std::fmt::Display| Rejected { reason: "error", detail: format!("attempt {}: {e}", attempt + 1) };
    let last = solution.trajectory.last().map(Vec::as_slice).unwrap_or(&problem.start);
    let miss = goal_miss(problem, last).map_err(|e| error(&e))?;
    if miss.distance > settings.goal_tolerance || miss.angle > settings.goal_angle_tolerance {
        let detail = format!("q_T misses the goal by {:.2e} m, {:.2e} rad", miss.distance, miss.angle);
        return Err(Rejected { reason: "goal_missed", detail });
    }
    let grasp = match judge_grasp(problem, last, settings.goal_angle_tolerance) {
        Ok(Some((report, criteria))) => match report.failure(&criteria) {
            Some(why) => {
                let detail = format!("attempt {}: at q_T {why}", attempt + 1);
                return Err(Rejected { reason: "grasp_failed", detail });
            }
            None => Some(report),
        },
        Ok(None) => None,
        Err(e) => return Err(error(&format!("cannot judge the grasp: {e}"))),
    };
    Ok((solution, miss, grasp))
}
