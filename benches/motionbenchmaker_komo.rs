//! RRT-Connect + trajectory optimization end to end on all 700
//! MotionBenchMaker Panda problems (problems/motionbenchmaker) with the
//! spherized Panda and its SRDF: joint-space goals, minimal acceleration,
//! joint limits, collision avoidance (default objectives: the problems list
//! none), T = 50 over 5 s. A problem counts as solved when the optimizer
//! converged (constraints within 1e-5), every slice is within limits and
//! the motion between slices is collision-free at 2 mrad. One seed per
//! problem; loading the problem is not timed, everything else is (planning
//! preparation, planning, shortcutting, optimization, validation).
//!
//!   cargo bench --bench motionbenchmaker_komo
//!
//! Writes target/peers/motionbenchmaker_komo.json. The anchor: cuRobo's
//! published 99.85 % success and 31 ms median motion generation (RTX 6000
//! Ada GPU) on these problem sets.

#[path = "support/mbm.rs"]
#[allow(dead_code)]
mod mbm_common;

use mbm_common::{Benchmark, FAMILIES, full_run, row};
use tandem::pipeline::{SolveSettings, solve_problem};

fn main() {
    // Under `cargo test --all-targets`: one problem per family.
    let per_family = if full_run() { 100 } else { 1 };
    let benchmark = Benchmark::unpack();
    let (mut total, mut optimize, mut failed) = (Vec::new(), Vec::new(), Vec::new());
    for family in FAMILIES {
        for k in 1..=per_family {
            let problem = benchmark.problem(family, k);
            let solution = match solve_problem(&problem, &SolveSettings { seed: Some(0), ..SolveSettings::default() }) {
                Ok(s) => s,
                Err(e) => {
                    failed.push(format!("{family} {k}: {e}"));
                    continue;
                }
            };
            if solution.converged() {
                total.push(solution.total_time.as_secs_f64());
                optimize.push(solution.report.time.as_secs_f64());
            } else {
                failed.push(format!("{family} {k}: {}", solution.status()));
            }
        }
    }
    let count = per_family * FAMILIES.len();
    println!("MotionBenchMaker, Panda, spherized geometry, RRT-Connect + optimizer (T = 50), one seed per problem:");
    println!("| figure | median | mean | 95th pct |\n| --- | --- | --- | --- |");
    let t = row("total (plan + optimize + validate)", &mut total);
    let o = row("optimization", &mut optimize);
    println!("| solved | {} of {count} ({:.2} %) | | |", total.len(), 100.0 * total.len() as f64 / count as f64);
    for f in &failed {
        println!("unsolved: {f}");
    }
    if !full_run() {
        return;
    }
    let out = serde_json::json!({"solved": total.len(), "problems": count, "total": t, "optimization": o,
        "unsolved": failed});
    let peers = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/peers");
    std::fs::create_dir_all(&peers).expect("target/peers");
    std::fs::write(peers.join("motionbenchmaker_komo.json"), out.to_string()).expect("write results");
}
