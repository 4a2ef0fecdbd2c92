//! Problems a command cannot attempt: a start outside the limits or in
//! collision, a goal no configuration within limits reaches or whose every
//! configuration collides. `plan`, `solve` and `arbitrate` report them as
//! unsuccessful runs (exit 3) with a status and the reason — on stdout,
//! as JSON under `--json` — not as errors (exit 1): the files were valid,
//! the problem has no solution.

use crate::arbitration::ArbitrationError;
use crate::collision::CollisionWorkspace;
use crate::pipeline::PipelineError;
use crate::plan::PlanError;
use crate::problem::Problem;

/// Why a problem cannot be attempted.
pub(super) struct Refusal {
    /// `start_invalid` or `goal_invalid`.
    pub status: &'static str,
    /// In words, naming the limit or the colliding pair.
    pub reason: String,
}

/// Why the planner refused configuration `q` as a start or goal: outside
/// a limit, in collision, or (with `clearance`) closer to something than
/// the planner's clearance. `None` when it is none of these.
pub(super) fn why_invalid(
    problem: &Problem,
    q: &[f64],
    clearance: bool,
) -> Result<Option<String>, Box<dyn std::error::Error>> {
    if let Err(e) = problem.robot.check_within_limits(q) {
        return Ok(Some(e.to_string()));
    }
    let model = problem.collision_model()?;
    let mut ws = CollisionWorkspace::new(&model);
    let Some(closest) = model.min_distance(&mut ws, q)? else {
        return Ok(None);
    };
    let (a, b) = model.pair_names(closest.pair);
    // A cloud names its point, the one to look for in the file.
    let b = match model.nearest_cloud_point(&ws, &closest) {
        Some((i, p)) => format!("{b} (point {i}, at [{:.3}, {:.3}, {:.3}] m)", p[0], p[1], p[2]),
        None => b.to_string(),
    };
    let d = closest.signed.distance;
    let margin = problem.planner.clearance;
    Ok(if d < 0.0 {
        Some(format!("in collision: {a} and {b} penetrate by {:.4} m", -d))
    } else if clearance && d < margin {
        Some(format!("{a} and {b} are {d:.5} m apart, closer than the planner clearance of {margin} m"))
    } else {
        None
    })
}

/// The problem's start, refused: outside a limit or in collision.
pub(super) fn start_refusal(problem: &Problem) -> Result<Option<Refusal>, Box<dyn std::error::Error>> {
    Ok(why_invalid(problem, &problem.start, false)?
        .map(|why| Refusal { status: "start_invalid", reason: format!("start: {why}") }))
}

/// The goal's refusal inside `error`, if that is what it is: inverse
/// kinematics found no configuration within limits that reaches the goal,
/// or only colliding ones.
fn goal_refusal(error: &(dyn std::error::Error + 'static)) -> Option<Refusal> {
    fn pipeline(e: &PipelineError) -> Option<&PlanError> {
        match e {
            PipelineError::Plan(plan) => Some(plan),
            _ => None,
        }
    }
    let plan = error
        .downcast_ref::<PlanError>()
        .or_else(|| error.downcast_ref::<PipelineError>().and_then(pipeline))
        .or_else(|| match error.downcast_ref::<ArbitrationError>() {
        Some(ArbitrationError::Pipeline(e)) => pipeline(e),
        _ => None,
    })?;
    match plan {
        PlanError::Ik(ik) => Some(Refusal { status: "goal_invalid", reason: format!("goal: {ik}") }),
        _ => None,
    }
}

/// `result`'s value; or, when its error is a goal's refusal
/// ([`goal_refusal`]), that refusal; or the error.
pub(super) fn or_goal_refusal<T, E: Into<Box<dyn std::error::Error>>>(
    result: Result<T, E>,
) -> Result<Result<T, Refusal>, Box<dyn std::error::Error>> {
    match result {
        Ok(value) => Ok(Ok(value)),
        Err(e) => {
            let e: Box<dyn std::error::Error> = e.into();
            goal_refusal(&*e).map(Err).ok_or(e)
        }
    }
}

/// Prints a refusal of `plan` or `solve`: `json` (the command's keys,
/// without a path) when given, else the status and reason as text.
/// Exit status 3.
pub(super) fn print_refusal(problem: &Problem, refusal: &Refusal, json: Option<serde_json::Value>) -> super::Outcome {
    match json {
        Some(out) => println!("{out}"),
        None => {
            println!("problem {} ({}): {}", problem.name, problem.origin, refusal.status);
            println!("{}", refusal.reason);
        }
    }
    super::Outcome::Unsuccessful
}
