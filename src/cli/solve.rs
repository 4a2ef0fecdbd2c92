//! `tandem solve`: RRT-Connect, then trajectory optimization, on a problem
//! file or MoveIt inputs.

use super::plan::gripper_path_svg;
use super::refusal::{Refusal, or_goal_refusal, print_refusal, start_refusal};
use super::{Outcome, ProblemArgs};
use crate::figures::{Panel, Series, render_panels};
use crate::pipeline::{ProblemSolution, SolveSettings, solve_problem};
use crate::problem::{MAX_HORIZON, MIN_HORIZON, Problem};
use std::path::{Path, PathBuf};

/// Arguments of `tandem solve`.
#[derive(Debug, clap::Args)]
pub struct SolveArgs {
    #[command(flatten)]
    pub input: ProblemArgs,
    /// Seed of IK and RRT-Connect (default: the problem's planner.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Number of optimized configurations T, 2 to 100000 (default: the
    /// problem's optimizer.horizon).
    #[arg(long, short = 'T', value_name = "T",
          value_parser = |s: &str| super::number_in(s, MIN_HORIZON..=MAX_HORIZON))]
    pub horizon: Option<usize>,
    /// Write trajectory.csv, trajectory.parquet, joints.svg (joint values
    /// over time) and path.svg (gripper path) into this folder.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Print exactly one JSON object: {"status", "time_ms" (planning +
    /// optimization), "iterations" (Gauss-Newton steps), "cost",
    /// "eq_violation", "ineq_violation", "min_distance" (m, over the
    /// slices), "collision_free" (checked every 2 mrad between slices),
    /// "T" (optimized configurations), "joints", "trajectory" `[[q_0], …,
    /// [q_T]]` (T + 1 rows, the start first, "time_step" apart), and "plan_ms",
    /// "optimize_ms", "outer_iterations", "evaluations", "within_limits",
    /// "time_step", "reason"}. A start outside the limits or in collision,
    /// or a goal no configuration within limits reaches (or only colliding
    /// ones), is "status" "start_invalid" or "goal_invalid" with "reason"
    /// in words and no trajectory (exit 3); else "reason" is null.
    #[arg(long)]
    pub json: bool,
}

pub(super) fn run(args: &SolveArgs) -> Result<Outcome, Box<dyn std::error::Error>> {
    let problem = args.input.load()?;
    if let Some(refusal) = start_refusal(&problem)? {
        return Ok(refused(&problem, &refusal, args.json));
    }
    let options = SolveSettings { seed: args.seed, horizon: args.horizon, ..SolveSettings::default() };
    let solution = match or_goal_refusal(solve_problem(&problem, &options))? {
        Ok(solution) => solution,
        Err(refusal) => return Ok(refused(&problem, &refusal, args.json)),
    };
    if let Some(dir) = &args.out {
        write_outputs(&problem, &solution, dir)?;
    }
    if args.json {
        println!("{}", solution_json(&problem, &solution));
    } else {
        print_summary(&problem, &solution, args.out.as_deref());
    }
    Ok(if solution.converged() { Outcome::Success } else { Outcome::Unsuccessful })
}

/// The solution as a trajectory file's table: the start, then q_1 … q_T.
/// The start, then `q_1 … q_T`: the rows of every trajectory tandem writes.
fn configurations(problem: &Problem, s: &ProblemSolution) -> Vec<Vec<f64>> {
    std::iter::once(&problem.start).chain(&s.trajectory).cloned().collect()
}

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn solution_json(problem: &Problem, s: &ProblemSolution) -> serde_json::Value {
    let r = &s.report;
    let plan_ms = ms(s.plan.planning_time + s.plan.simplify_time);
    serde_json::json!({
        "status": s.status(),
        "time_ms": ms(s.total_time),
        "iterations": r.inner_steps,
        "cost": r.cost,
        "eq_violation": r.equality_violation,
        "ineq_violation": r.inequality_violation,
        "min_distance": s.validation.min_distance,
        "collision_free": s.validation.collision_free,
        "T": s.trajectory.len(),
        "joints": s.joints,
        "trajectory": configurations(problem, s),
        "plan_ms": plan_ms,
        "optimize_ms": ms(r.time),
        "outer_iterations": r.outer_iterations,
        "evaluations": r.evaluations,
        "within_limits": s.validation.within_limits,
        "time_step": s.time_step,
        "reason": null,
    })
}

/// Reports a problem that cannot be attempted (exit 3): its status and
/// reason, as JSON with every key of a solution (no trajectory) under `--json`.
fn refused(problem: &Problem, refusal: &Refusal, json: bool) -> Outcome {
    if json {
        let out = serde_json::json!({
            "status": refusal.status,
            "time_ms": 0.0,
            "iterations": 0,
            "cost": null,
            "eq_violation": null,
            "ineq_violation": null,
            "min_distance": null,
            "collision_free": false,
            "T": 0,
            "joints": problem.robot.joint_names(),
            "trajectory": [],
            "plan_ms": 0.0,
            "optimize_ms": 0.0,
            "outer_iterations": 0,
            "evaluations": 0,
            "within_limits": false,
            "time_step": null,
            "reason": refusal.reason,
        });
        print_refusal(problem, refusal, Some(out))
    } else {
        print_refusal(problem, refusal, None)
    }
}

pub(super) fn print_summary(problem: &Problem, s: &ProblemSolution, out: Option<&Path>) {
    let r = &s.report;
    println!("problem {} ({}): {}", problem.name, problem.origin, s.status());
    println!(
        "planning {:.2} ms ({}), optimization {:.2} ms: {} Gauss-Newton steps, {} evaluations, {} outer iterations",
        ms(s.plan.planning_time + s.plan.simplify_time),
        s.plan.result.status.name(),
        ms(r.time),
        r.inner_steps,
        r.evaluations,
        r.outer_iterations
    );
    println!(
        "cost {:.4}, equality violation {:.1e}, inequality violation {:.1e}",
        r.cost, r.equality_violation, r.inequality_violation
    );
    let v = &s.validation;
    let clearance = v.min_distance.map_or("no collision model".into(), |d| format!("{:.1} mm", d * 1e3));
    println!(
        "{} slices every {:.3} s; collision-free between slices (every {} rad): {}; within limits: {}; clearance {clearance}",
        s.trajectory.len(),
        s.time_step,
        v.resolution,
        if v.collision_free { "yes" } else { "NO" },
        if v.within_limits { "yes" } else { "NO" },
    );
    if let Some(dir) = out {
        println!("wrote trajectory.csv, trajectory.parquet, joints.svg and path.svg to {}", dir.display());
    }
}

pub(super) fn write_outputs(
    problem: &Problem,
    s: &ProblemSolution,
    dir: &Path,
) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let trajectory = s.reference(&problem.start)?;
    trajectory.write_csv(&dir.join("trajectory.csv"))?;
    trajectory.write_parquet(&dir.join("trajectory.parquet"))?;
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    write("joints.svg", joints_svg(problem, s)?)?;
    let path = crate::plan::resample(&configurations(problem, s), 200);
    write("path.svg", gripper_path_svg(problem, &path, "optimized path")?)?;
    Ok(())
}

/// Every joint's value over time, the start at t = 0.
fn joints_svg(problem: &Problem, s: &ProblemSolution) -> Result<String, crate::figures::FigureError> {
    let rows = configurations(problem, s);
    let kinds: Vec<&str> = (0..problem.robot.nq()).filter_map(|j| problem.robot.joint_unit(j)).collect();
    let unit = match (kinds.contains(&"m"), kinds.contains(&"rad")) {
        (true, true) => "rad or m",
        (true, false) => "m",
        _ => "rad",
    };
    let mut panel = Panel::new("joint values", "time (s)", &format!("joint value ({unit})"));
    for (k, name) in s.joints.iter().enumerate() {
        let points: Vec<(f64, f64)> = rows.iter().enumerate().map(|(t, q)| (t as f64 * s.time_step, q[k])).collect();
        panel = panel.with(Series::line(name, &points, k));
    }
    render_panels(&format!("{}: joint trajectories", problem.name), &[panel], 760, 480)
}
