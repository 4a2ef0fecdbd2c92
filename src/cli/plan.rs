//! `tandem plan`: RRT-Connect on a problem file or MoveIt inputs.

use super::refusal::{Refusal, or_goal_refusal, print_refusal, why_invalid};
use super::{Outcome, ProblemArgs};
use crate::experiments::figures::with_scene;
use crate::figures::{Color, Marker, Panel, Series, render_panels};
use crate::plan::{PlanStatus, path_length, plan_problem};
use crate::problem::Problem;
use std::path::PathBuf;

/// Arguments of `tandem plan`.
#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    #[command(flatten)]
    pub input: ProblemArgs,
    /// Seed of the planner (default: the problem's planner.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Print exactly one JSON object: {"status", "time_ms", "iterations",
    /// "joints" (the waypoints' columns), "waypoints" `[[q], ...]` (after shortcutting), "path_length" (rad,
    /// joint space), "simplify_ms", "nodes", "raw_waypoints", "certified"
    /// (every edge passed the certified clearance check), "attempts",
    /// "reason" (why the start or goal was refused, else null)}; "status"
    /// is "start_invalid" or "goal_invalid" when the start or every goal
    /// configuration is outside the limits or collides, or no
    /// configuration within limits reaches the goal. Exit status 3 unless
    /// "status" is "solved".
    #[arg(long)]
    pub json: bool,
    /// Write an SVG of the gripper (or last link) path seen from above and
    /// from the side.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

pub(super) fn run(args: &PlanArgs) -> Result<Outcome, Box<dyn std::error::Error>> {
    let problem = args.input.load()?;
    let report = match or_goal_refusal(plan_problem(&problem, args.seed))? {
        Ok(report) => report,
        Err(refusal) => return Ok(refused(&problem, &refusal, args.json)),
    };
    let invalid = |q: &[f64]| -> Result<String, Box<dyn std::error::Error>> {
        Ok(why_invalid(&problem, q, true)?
            .unwrap_or_else(|| "refused by the planner (no collision pair to blame)".into()))
    };
    let reason = match report.result.status {
        PlanStatus::StartInvalid => Some(format!("start: {}", invalid(&problem.start)?)),
        PlanStatus::GoalInvalid => Some(match report.goals.first() {
            Some(goal) => format!("goal: {}", invalid(goal)?),
            None => "no goal configuration".to_string(),
        }),
        _ => None,
    };
    if let Some(file) = &args.svg {
        let dense = crate::plan::resample(&report.path, 200);
        std::fs::write(file, gripper_path_svg(&problem, &dense, "path")?)
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
    }
    let r = &report.result;
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    if args.json {
        let out = serde_json::json!({
            "status": r.status.name(),
            "time_ms": ms(report.planning_time),
            "iterations": r.iterations,
            "joints": problem.robot.joint_names(),
            "waypoints": report.path,
            "path_length": path_length(&report.path).max(0.0),
            "simplify_ms": ms(report.simplify_time),
            "nodes": r.nodes,
            "raw_waypoints": r.path.len(),
            "certified": report.certified,
            "attempts": report.attempts,
            "reason": reason,
        });
        println!("{out}");
    } else {
        println!("problem {} ({}): {}", problem.name, problem.origin, r.status.name());
        if let Some(reason) = &reason {
            println!("{reason}");
        }
        if r.status == PlanStatus::Solved {
            let clearance = problem.planner.clearance;
            match report.certified {
                true => println!("every edge certified to keep {:.1} mm of clearance", clearance * 500.0),
                false => println!("edges checked every {} rad, not certified", problem.planner.resolution),
            }
        }
        println!(
            "planning {:.2} ms ({} iterations, {} nodes, {} goal configurations), shortcutting {:.2} ms",
            ms(report.planning_time),
            r.iterations,
            r.nodes,
            report.goals.len(),
            ms(report.simplify_time)
        );
        if !report.path.is_empty() {
            println!(
                "path: {} waypoints, {:.3} rad (raw: {} waypoints, {:.3} rad)",
                report.path.len(),
                path_length(&report.path),
                r.path.len(),
                path_length(&r.path)
            );
            for q in &report.path {
                let v: Vec<String> = q.iter().map(|x| format!("{x:.4}")).collect();
                println!("  [{}]", v.join(", "));
            }
        }
    }
    Ok(if r.status == PlanStatus::Solved { Outcome::Success } else { Outcome::Unsuccessful })
}

/// Reports a problem that cannot be attempted (exit 3): the status and the
/// reason, as JSON with every key of a plan (no path) under `--json`.
fn refused(problem: &Problem, refusal: &Refusal, json: bool) -> Outcome {
    if json {
        let out = serde_json::json!({
            "status": refusal.status,
            "time_ms": 0.0,
            "iterations": 0,
            "joints": problem.robot.joint_names(),
            "waypoints": [],
            "path_length": 0.0,
            "simplify_ms": 0.0,
            "nodes": 0,
            "raw_waypoints": 0,
            "certified": false,
            "attempts": 0,
            "reason": refusal.reason,
        });
        print_refusal(problem, refusal, Some(out))
    } else {
        print_refusal(problem, refusal, None)
    }
}

/// Top (x, y) and side (x, z) views of the end-effector path through
/// `configurations` (dense enough to draw as a line).
pub(super) fn gripper_path_svg(
    problem: &Problem,
    configurations: &[Vec<f64>],
    what: &str,
) -> Result<String, Box<dyn std::error::Error>> {
    let robot = &problem.robot;
    let frame = match &problem.robot_spec.gripper {
        Some(g) => robot.frame_id(g)?,
        None => robot.link_frame(robot.description().links().len() - 1),
    };
    let points = robot.frame_path(frame, configurations.iter().map(Vec::as_slice))?;
    let title = format!("{}: {} {what}", problem.name, robot.frame_name(frame));
    let view = |title: &str, b: usize, y_label: &str| {
        let path: Vec<(f64, f64)> = points.iter().map(|p| (p[0], p[b])).collect();
        let panel = Panel::new(title, "x (m)", y_label)
            .with(Series::line(&format!("{} path", robot.frame_name(frame)), &path, 0))
            .with(Series::markers("start", &path[..path.len().min(1)], Color::Reference, Marker::Dot))
            .with(Series::markers("end", &path[path.len().saturating_sub(1)..], Color::Reference, Marker::Ring))
            .equal();
        with_scene(panel, &problem.scene, (0, b))
    };
    let panels = [view("from above", 1, "y (m)"), view("from the side", 2, "z (m)")];
    Ok(render_panels(&title, &panels, 480, 440)?)
}
