//! RRT-Connect on MotionBenchMaker-style problems for robots unlike the
//! Panda (benches/support/robots.rs): a 6-DOF UR5 (`manipulator`), a TIAGo
//! planning its prismatic torso lift with its arm (`arm_torso`, 8 joints)
//! and a Baxter planning both arms at once (`both_arms`, 14 joints), each
//! with sphere-model collision geometry, in `table`, `shelf` and `cage`
//! scenes. Per robot: solved count (solved and every edge certified), and
//! median / mean / 95th percentile of planning time and of planning +
//! simplification, one seed per problem, as the `motionbenchmaker` bench
//! reports the Panda's. Problem generation and loading are not timed.
//!
//!   cargo bench --bench motionbenchmaker_robots [-- --per-family N --time-limit SECONDS --robot NAME --problem FAMILY[:K] --plain --joint-goals --komo]
//!
//! The budget is the time limit alone, as MotionBenchMaker's and MoveIt's
//! are: the problems' iteration cap is lifted. `--problem shelf:6` runs
//! that one problem (of each robot chosen), `--problem shelf` that family.
//!
//! `--komo`: also plans and optimizes every problem (T = 50, as
//! `motionbenchmaker_komo` does the Panda's) and reports how many the
//! optimizer solves and the total time.
//!
//! `--joint-goals`: goals drawn in joint space near home rather than
//! grasps solved by IK (`robots::Goals::Joint`, the first generator).
//!
//! `--plain`: plain RRT-Connect (step 0.5 rad, no balancing, no
//! dynamic-domain sampling), the planner before those were added.
//!
//! Writes target/peers/motionbenchmaker_robots.json (`_plain` and
//! `_joint_goals` added to the name with those options).

#[allow(dead_code)]
#[path = "support/mbm.rs"]
mod mbm;
#[path = "support/robots.rs"]
mod robots;

use mbm::{full_run, make_plain, median_mean, row};
use robots::{FAMILIES, Goals, ROBOTS};
use tandem::komo::{SolveOptions, solve_problem};
use tandem::plan::{PlanStatus, ProblemPlanner};

fn option(args: &[String], name: &str) -> Option<f64> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok())
}

/// Plans and optimizes `problem` (T = 50, default objectives) as
/// `motionbenchmaker_komo` does the Panda's: solved when the optimizer
/// converged, every slice is within limits and the motion between slices
/// is collision-free at the validation resolution.
fn optimize(problem: &tandem::scene::Problem, name: &str, times: &mut Vec<f64>, failed: &mut Vec<String>) {
    let options = SolveOptions { seed: Some(0), ..SolveOptions::default() };
    match solve_problem(problem, &options) {
        Ok(s) if s.converged() => times.push(s.total_time.as_secs_f64()),
        Ok(s) => failed.push(format!(
            "{name}: {} (path {:.2} rad in {} waypoints; violations: equality {:.2e}, inequality {:.2e}; {} evaluations)",
            s.status(),
            tandem::plan::path_length(&s.plan.path),
            s.plan.path.len(),
            s.report.equality_violation,
            s.report.inequality_violation,
            s.report.evaluations
        )),
        Err(e) => failed.push(format!("{name}: {e}")),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let plain = args.iter().any(|a| a == "--plain");
    let goals = if args.iter().any(|a| a == "--joint-goals") { Goals::Joint } else { Goals::Grasp };
    let komo = args.iter().any(|a| a == "--komo");
    // `cargo test --all-targets` runs bench targets without `--bench`: one
    // problem per family and robot then.
    let per_family = if full_run() { option(&args, "--per-family").unwrap_or(100.0) as u64 } else { 1 };
    let time_limit = option(&args, "--time-limit").unwrap_or(10.0);
    let dir = tempfile::tempdir().expect("temp dir");
    let mut results = serde_json::Map::new();
    let only = args.iter().position(|a| a == "--robot").and_then(|i| args.get(i + 1));
    let one = args.iter().position(|a| a == "--problem").and_then(|i| args.get(i + 1));
    for robot in ROBOTS.iter().filter(|r| only.is_none_or(|name| name == r.name)) {
        let (mut planning, mut total, mut failed) = (Vec::new(), Vec::new(), Vec::new());
        // Where planning time goes: the RRT search (its iterations, and the
        // time per iteration) against the rest (goal IK, setup).
        let (mut search, mut iterations, mut per_iteration) = (Vec::new(), Vec::new(), Vec::new());
        let mut not_generated = Vec::new();
        let (mut optimized, mut not_optimized) = (Vec::new(), Vec::new());
        let mut nq = 0;
        for family in FAMILIES {
            for k in 1..=per_family {
                if one.is_some_and(|p| *p != family && *p != format!("{family}:{k}")) {
                    continue;
                }
                let Some(mut problem) = robots::problem(robot, family, k, goals, dir.path()) else {
                    not_generated.push(format!("{family} {k}"));
                    continue;
                };
                nq = problem.robot.nq();
                problem.planner.time_limit = time_limit;
                problem.planner.max_iterations = usize::MAX;
                if komo {
                    optimize(&problem, &format!("{family} {k}"), &mut optimized, &mut not_optimized);
                }
                let mut planner = ProblemPlanner::new(&problem, Some(0)).expect("planner");
                if plain {
                    make_plain(&mut planner);
                }
                let report = planner.run(0).expect("plan");
                if report.result.status == PlanStatus::Solved && report.certified {
                    let p = report.planning_time.as_secs_f64();
                    planning.push(p);
                    total.push(p + report.simplify_time.as_secs_f64());
                    let searched = report.result.time.as_secs_f64();
                    search.push(searched);
                    iterations.push(report.result.iterations as f64);
                    per_iteration.push(searched / report.result.iterations.max(1) as f64);
                } else {
                    failed.push(format!("{family} {k}: {}", report.result.status.name()));
                }
            }
        }
        println!(
            "\n{} (group {}, {nq} joints), sphere model, RRT-Connect (one seed per problem, {time_limit} s limit):",
            robot.name, robot.group
        );
        println!("| figure | median | mean | 95th pct |\n| --- | --- | --- | --- |");
        let p = row("planning time", &mut planning);
        let t = row("planning + simplification", &mut total);
        let r = row("of which the RRT search", &mut search);
        let (its, mean_its) = median_mean(&mut iterations);
        let us = median_mean(&mut per_iteration).0 * 1e6;
        println!("| RRT iterations | {its:.0} | {mean_its:.0} | |");
        println!("| time per RRT iteration | {us:.1} µs | | |");
        let count = planning.len() + failed.len();
        println!("| solved | {} of {count} | | |", planning.len());
        if !not_generated.is_empty() {
            println!(
                "no start and goal found in {} scene draws (not counted): {}",
                robots::SCENE_DRAWS,
                not_generated.join(", ")
            );
        }
        for f in &failed {
            println!("unsolved: {f}");
        }
        let komo_row = if komo {
            let row = row("with the optimizer (plan + optimize + validate)", &mut optimized);
            println!("| optimizer solved | {} of {count} | | |", optimized.len());
            for f in &not_optimized {
                println!("not optimized: {f}");
            }
            serde_json::json!({"solved": optimized.len(), "total": row, "unsolved": not_optimized})
        } else {
            serde_json::Value::Null
        };
        results.insert(
            robot.name.to_string(),
            serde_json::json!({"group": robot.group, "joints": nq, "problems": count, "solved": planning.len(),
                "planning": p, "total": t, "search": r,
                "iterations": {"median": its, "mean": mean_its}, "us_per_iteration": us, "unsolved": failed, "not_generated": not_generated,
                "komo": komo_row,
                "time_limit_s": time_limit}),
        );
    }
    if !full_run() {
        return;
    }
    let peers = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/peers");
    std::fs::create_dir_all(&peers).expect("target/peers");
    std::fs::write(
        peers.join(format!(
            "motionbenchmaker_robots{}{}.json",
            if plain { "_plain" } else { "" },
            if goals == Goals::Joint { "_joint_goals" } else { "" }
        )),
        serde_json::Value::Object(results).to_string(),
    )
    .expect("write results");
}
