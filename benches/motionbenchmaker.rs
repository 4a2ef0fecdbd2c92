//! RRT-Connect on all 700 MotionBenchMaker Panda problems
//! (../shared/benchmarks/mbm) with the spherized Panda and its SRDF: solved
//! count and the median / mean / 95th percentile of planning time and of
//! planning + simplification (shortcutting and certification), one seed
//! per problem, in the layout of the reference table of the benchmark's
//! README. Problem loading and collision-model building are not timed.
//!
//!   cargo bench --bench motionbenchmaker [-- --time-limit SECONDS]
//!
//! Writes target/peers/motionbenchmaker.json.

use std::path::PathBuf;
use std::process::Command;
use tandem::plan::{PlanStatus, ProblemPlanner};
use tandem::scene::Problem;

const FAMILIES: [&str; 7] =
    ["bookshelf_small", "bookshelf_tall", "bookshelf_thin", "box", "cage", "table_pick", "table_under_pick"];

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn row(label: &str, times: &mut [f64]) -> serde_json::Value {
    times.sort_by(f64::total_cmp);
    let us = |s: f64| s * 1e6;
    let (median, mean, p95) =
        (percentile(times, 0.5), times.iter().sum::<f64>() / times.len() as f64, percentile(times, 0.95));
    println!("| {label} | {:.0} µs | {:.0} µs | {:.0} µs |", us(median), us(mean), us(p95));
    serde_json::json!({"median_us": us(median), "mean_us": us(mean), "p95_us": us(p95)})
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // `cargo test --all-targets` runs bench targets without `--bench`: a
    // smoke run of one problem per family then, not the whole benchmark.
    let per_family = if args.iter().any(|a| a == "--bench") { 100 } else { 1 };
    let time_limit = args
        .iter()
        .position(|a| a == "--time-limit")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(10.0);
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mbm = repo.join("../shared/benchmarks/mbm");
    let dir = std::env::temp_dir().join("tandem_mbm");
    std::fs::create_dir_all(&dir).expect("temp dir");
    let unpacked = Command::new("tar").arg("xjf").arg(mbm.join("panda_problems.tar.bz2")).arg("-C").arg(&dir).status();
    assert!(unpacked.expect("run tar").success(), "cannot unpack the problems");
    let (urdf, srdf) = (mbm.join("panda_spherized.urdf"), mbm.join("panda.srdf"));
    let (mut planning, mut total, mut failed) = (Vec::new(), Vec::new(), Vec::new());
    for family in FAMILIES {
        for k in 1..=per_family {
            let folder = dir.join(format!("problems/{family}_panda"));
            let at = |f: &str| folder.join(format!("{f}{k:04}.yaml"));
            let mut problem = Problem::from_moveit(&urdf, &srdf, &at("scene"), &at("request")).expect("valid problem");
            problem.planner.time_limit = time_limit;
            let mut planner = ProblemPlanner::new(&problem, Some(0)).expect("planner");
            let report = planner.run(0).expect("plan");
            if report.result.status == PlanStatus::Solved && report.certified {
                let p = report.planning_time.as_secs_f64();
                planning.push(p);
                total.push(p + report.simplify_time.as_secs_f64());
            } else {
                failed.push(format!("{family} {k}: {}", report.result.status.name()));
            }
        }
    }
    println!("MotionBenchMaker, Panda, spherized geometry, RRT-Connect (one seed per problem, {time_limit} s limit):");
    println!("| figure | median | mean | 95th pct |\n| --- | --- | --- | --- |");
    let p = row("planning time", &mut planning);
    let t = row("planning + simplification", &mut total);
    println!("| solved | {} of {} | | |", planning.len(), per_family * FAMILIES.len());
    for f in &failed {
        println!("unsolved: {f}");
    }
    let out = serde_json::json!({"solved": planning.len(), "planning": p, "total": t, "unsolved": failed,
        "time_limit_s": time_limit});
    if per_family < 100 {
        return;
    }
    let peers = repo.join("target/peers");
    std::fs::create_dir_all(&peers).expect("target/peers");
    std::fs::write(peers.join("motionbenchmaker.json"), out.to_string()).expect("write results");
}
