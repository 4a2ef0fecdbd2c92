//! RRT-Connect on MotionBenchMaker-style problems for robots unlike the
//! Panda (benches/support/robots.rs): a 6-DOF UR5 (`manipulator`), a TIAGo
//! planning its prismatic torso lift with its arm (`arm_torso`, 8 joints)
//! and a Baxter planning both arms at once (`both_arms`, 14 joints), each
//! with sphere-model collision geometry, in `table`, `shelf` and `cage`
//! scenes. Per robot: solved count (solved and every edge certified), and
//! median / mean / 95th percentile of planning time and of planning +
//! simplification, one seed per problem (`--seeds`), as the `motionbenchmaker` bench
//! reports the Panda's. Problem generation and loading are not timed.
//!
//!   cargo bench --bench motionbenchmaker_robots [-- --per-family N --time-limit SECONDS --robot NAME --problem FAMILY[:K] --repeats K --seeds N --no-panda --plain --joint-goals --komo]
//!
//! The target is a ratio, each robot's median against the Panda's on the
//! same machine, and this VM's speed drifts by up to 2× over seconds: a
//! robot timed in one block can land in a slow spell the Panda missed. So
//! every problem is prepared first, the Panda's 700 MotionBenchMaker
//! problems among them (`--no-panda` leaves them out), and then all are
//! planned `--repeats` times (3 by default), each round in a different
//! seeded order, so that every robot meets the same spells; a problem's
//! time is the median of its rounds (the planner is deterministic: every
//! round does the same work). The last column gives each robot's median
//! over the Panda's from these same rounds.
//!
//! The budget is the time limit alone, as MotionBenchMaker's and MoveIt's
//! are: the problems' iteration cap is lifted. `--problem shelf:6` runs
//! that one problem (of each robot chosen), `--problem shelf` that family.
//!
//! `--seeds N`: plans every problem with seeds 0 to N − 1 (default 1:
//! seed 0 alone), each (problem, seed) a run of its own in the figures.
//! With one seed, every problem of a family draws the same sample
//! stream, and a family's median then rests on that stream's luck (seeds
//! 0, 1 and 2 gave the Baxter's median 58, 119 and 96 extension rounds).
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

use mbm::{Benchmark, full_run, make_plain, median_mean, option, row};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use robots::{FAMILIES, Goals, ROBOTS};
use tandem::pipeline::{SolveSettings, solve_problem};
use tandem::plan::{PlanStatus, ProblemPlanner};

/// Plans and optimizes `problem` (T = 50, default objectives) as
/// `motionbenchmaker_komo` does the Panda's: solved when the optimizer
/// converged, every slice is within limits and the motion between slices
/// is collision-free at the validation resolution.
fn optimize(problem: &tandem::problem::Problem, name: &str, times: &mut Vec<f64>, failed: &mut Vec<String>) {
    let options = SolveSettings { seed: Some(0), ..SolveSettings::default() };
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

/// One problem ready to plan, and what its rounds measured (s).
struct Job {
    /// Index into the bench's robot names.
    robot: usize,
    name: String,
    planner: ProblemPlanner,
    /// The search's seed.
    seed: u64,
    planning: Vec<f64>,
    total: Vec<f64>,
    search: Vec<f64>,
    /// Of the first round: solved with every edge certified, its status
    /// and extension rounds (the same in every round).
    outcome: Option<(bool, PlanStatus, usize)>,
}

impl Job {
    fn run(&mut self) {
        let report = self.planner.run(self.seed).expect("plan");
        let p = report.planning_time.as_secs_f64();
        self.planning.push(p);
        self.total.push(p + report.simplify_time.as_secs_f64());
        self.search.push(report.result.time.as_secs_f64());
        let solved = report.result.status == PlanStatus::Solved && report.certified;
        self.outcome.get_or_insert((solved, report.result.status, report.result.iterations));
    }
}

/// What a robot's section reports beyond its jobs.
#[derive(Default)]
struct Extras {
    nq: usize,
    not_generated: Vec<String>,
    optimized: Vec<f64>,
    not_optimized: Vec<String>,
}

/// The robots' problems (and with `panda`, the Panda's 700), prepared.
fn prepare(args: &[String], (per_family, seeds): (u64, u64), time_limit: f64, panda: bool) -> (Vec<Job>, Vec<Extras>) {
    let plain = args.iter().any(|a| a == "--plain");
    let goals = if args.iter().any(|a| a == "--joint-goals") { Goals::Joint } else { Goals::Grasp };
    let komo = args.iter().any(|a| a == "--komo");
    let only = args.iter().position(|a| a == "--robot").and_then(|i| args.get(i + 1));
    let one = args.iter().position(|a| a == "--problem").and_then(|i| args.get(i + 1));
    let dir = tempfile::tempdir().expect("temp dir");
    let (mut jobs, mut extras) = (Vec::new(), Vec::new());
    let add = |jobs: &mut Vec<Job>, robot, name: String, problem: &tandem::problem::Problem| {
        for seed in 0..seeds {
            let mut planner = ProblemPlanner::new(problem, Some(seed)).expect("planner");
            if plain {
                make_plain(&mut planner);
            }
            let name = if seeds == 1 { name.clone() } else { format!("{name} seed {seed}") };
            let (planning, total, search) = (Vec::new(), Vec::new(), Vec::new());
            jobs.push(Job { robot, name, planner, seed, planning, total, search, outcome: None });
        }
    };
    for (r, robot) in ROBOTS.iter().enumerate() {
        let mut extra = Extras::default();
        for family in FAMILIES {
            for k in 1..=per_family {
                let name = format!("{family} {k}");
                if only.is_some_and(|o| o != robot.name)
                    || one.is_some_and(|p| *p != family && *p != format!("{family}:{k}"))
                {
                    continue;
                }
                let Some(mut problem) = robots::problem(robot, family, k, goals, dir.path()) else {
                    extra.not_generated.push(name);
                    continue;
                };
                extra.nq = problem.robot.nq();
                problem.planner.time_limit = time_limit;
                problem.planner.max_iterations = usize::MAX;
                if komo {
                    optimize(&problem, &name, &mut extra.optimized, &mut extra.not_optimized);
                }
                add(&mut jobs, r, name, &problem);
            }
        }
        extras.push(extra);
    }
    if panda {
        let benchmark = Benchmark::unpack();
        for family in mbm::FAMILIES {
            for k in 1..=100 {
                let mut problem = benchmark.problem(family, k);
                problem.planner.time_limit = time_limit;
                add(&mut jobs, ROBOTS.len(), format!("{family} {k}"), &problem);
            }
        }
    }
    (jobs, extras)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let plain = args.iter().any(|a| a == "--plain");
    let joint_goals = args.iter().any(|a| a == "--joint-goals");
    // `cargo test --all-targets` runs bench targets without `--bench`: one
    // problem per family and robot then, planned once, without the Panda.
    let per_family = if full_run() { option(&args, "--per-family").unwrap_or(100.0) as u64 } else { 1 };
    let repeats = if full_run() { option(&args, "--repeats").unwrap_or(3.0).max(1.0) as usize } else { 1 };
    let panda = full_run() && !args.iter().any(|a| a == "--no-panda");
    let time_limit = option(&args, "--time-limit").unwrap_or(10.0);
    let seeds = option(&args, "--seeds").unwrap_or(1.0).max(1.0) as u64;
    let (mut jobs, extras) = prepare(&args, (per_family, seeds), time_limit, panda);
    // Each round in its own seeded order: slow spells of the machine fall
    // on every robot alike.
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    for round in 0..repeats {
        order.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(round as u64));
        for &j in &order {
            jobs[j].run();
        }
    }
    let reference = panda.then(|| report_panda(&mut jobs));
    let mut results = serde_json::Map::new();
    for (r, (robot, extra)) in ROBOTS.iter().zip(extras).enumerate() {
        let mine: Vec<&mut Job> = jobs.iter_mut().filter(|j| j.robot == r).collect();
        if mine.is_empty() && extra.not_generated.is_empty() {
            continue;
        }
        let rounds = if repeats == 1 { "one round".to_string() } else { format!("median of {repeats} rounds") };
        println!(
            "\n{} (group {}, {} joints), sphere model, RRT-Connect ({seeds} seed(s) per problem, {time_limit} s limit, {rounds}):",
            robot.name, robot.group, extra.nq
        );
        let mut section = report_robot(mine, &extra, reference);
        section["group"] = robot.group.into();
        section["time_limit_s"] = time_limit.into();
        section["rounds"] = repeats.into();
        section["seeds"] = seeds.into();
        results.insert(robot.name.to_string(), section);
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
            if joint_goals { "_joint_goals" } else { "" }
        )),
        serde_json::Value::Object(results).to_string(),
    )
    .expect("write results");
}

/// Median of each job's rounds, per figure, over the solved jobs:
/// planning, planning + simplification, search, extension rounds and
/// time per extension round; and the unsolved jobs.
fn medians(jobs: &[&mut Job]) -> ([Vec<f64>; 5], Vec<String>) {
    let mut figures: [Vec<f64>; 5] = Default::default();
    let mut failed = Vec::new();
    for job in jobs {
        let Some((solved, status, iterations)) = job.outcome else { continue };
        if !solved {
            failed.push(format!("{}: {}", job.name, status.name()));
            continue;
        }
        let search = median_mean(&mut job.search.clone()).0;
        figures[0].push(median_mean(&mut job.planning.clone()).0);
        figures[1].push(median_mean(&mut job.total.clone()).0);
        figures[2].push(search);
        figures[3].push(iterations as f64);
        figures[4].push(search / iterations.max(1) as f64);
    }
    (figures, failed)
}

/// Prints the Panda's reference rows; returns its median planning +
/// simplification (s).
fn report_panda(jobs: &mut [Job]) -> f64 {
    let mine: Vec<&mut Job> = jobs.iter_mut().filter(|j| j.robot == ROBOTS.len()).collect();
    let ([_, mut total, ..], failed) = medians(&mine);
    println!("\nPanda, MotionBenchMaker's 700 problems (the reference, timed in the same rounds):");
    println!("| figure | median | mean | 95th pct |\n| --- | --- | --- | --- |");
    row("planning + simplification", &mut total);
    println!("| solved | {} of {} | | |", total.len(), mine.len());
    for f in &failed {
        println!("unsolved: {f}");
    }
    median_mean(&mut total).0
}

/// Prints one robot's table; returns it as JSON.
fn report_robot(jobs: Vec<&mut Job>, extra: &Extras, panda: Option<f64>) -> serde_json::Value {
    let ([mut planning, mut total, mut search, mut iterations, mut per_iteration], failed) = medians(&jobs);
    println!("| figure | median | mean | 95th pct |\n| --- | --- | --- | --- |");
    let p = row("planning time", &mut planning);
    let t = row("planning + simplification", &mut total);
    let r = row("of which the RRT search", &mut search);
    let (its, mean_its) = median_mean(&mut iterations);
    let us = median_mean(&mut per_iteration).0 * 1e6;
    println!("| RRT iterations | {its:.0} | {mean_its:.0} | |");
    println!("| time per RRT iteration | {us:.1} µs | | |");
    let ratio = panda.map(|panda| median_mean(&mut total).0 / panda);
    if let Some(ratio) = ratio {
        println!("| median planning + simplification / the Panda's | {ratio:.2}× | | |");
    }
    let count = jobs.len();
    println!("| solved | {} of {count} | | |", planning.len());
    if !extra.not_generated.is_empty() {
        println!(
            "no start and goal found in {} scene draws (not counted): {}",
            robots::SCENE_DRAWS,
            extra.not_generated.join(", ")
        );
    }
    for f in &failed {
        println!("unsolved: {f}");
    }
    let komo_row = if extra.optimized.is_empty() && extra.not_optimized.is_empty() {
        serde_json::Value::Null
    } else {
        let row = row("with the optimizer (plan + optimize + validate)", &mut extra.optimized.clone());
        println!("| optimizer solved | {} of {count} | | |", extra.optimized.len());
        for f in &extra.not_optimized {
            println!("not optimized: {f}");
        }
        serde_json::json!({"solved": extra.optimized.len(), "total": row, "unsolved": extra.not_optimized})
    };
    serde_json::json!({"joints": extra.nq, "problems": count, "solved": planning.len(),
        "planning": p, "total": t, "search": r, "median_over_panda": ratio,
        "iterations": {"median": its, "mean": mean_its}, "us_per_iteration": us, "unsolved": failed,
        "not_generated": extra.not_generated, "komo": komo_row})
}
