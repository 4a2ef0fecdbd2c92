//! Runs tandem's planner (RRT-Connect + shortcutting + certification) on
//! one problem for seeds `first..first + seeds` and prints one JSON object:
//! `{problem, planner, seeds, solved, median_ms, mean_ms, p95_ms,
//! median_planning_ms, median_simplify_ms, ...}`. Times are per call of
//! `ProblemPlanner::run` (preparation — collision models, IK for pose and
//! grasp goals — is done once, before the timing); failed runs count with
//! the time they took. `median_cpu_ms` is the process CPU time of a run,
//! which waiting for a busy CPU does not inflate.
//!
//! With `--scene FILE` it also writes what the peer planners of
//! `benches/peers/compare_planning.sh` need to solve the same problem: the
//! search's collision model in the "collision scene exchange" format (URDF
//! collision elements by link and index, obstacles by shape and pose, every
//! checked pair), its padding, the start, the joint goals the planner aims
//! at (IK solutions for a grasp goal), the joint limits, the planner
//! settings, and `--checks` seeded random configurations with tandem's
//! verdicts, so a peer can check that its validity checker agrees.
//!
//! ```text
//! cargo run --release --example plan_seeds -- problems/panda_reach_obstacle.toml --seeds 50 --scene scene.json
//! ```

#[path = "../support/timing.rs"]
mod timing;
use clap::Parser;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::{Duration, Instant};
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::plan::{PlanStatus, ProblemPlanner};
use tandem::problem::Problem;
use timing::{cpu_time_ms, median};

#[derive(Debug, Parser)]
#[command(about = "Plan one problem for many seeds; print timing statistics as JSON")]
struct Args {
    /// A problem file (TOML), or the name of a shipped problem.
    problem: String,
    /// Number of seeds.
    #[arg(long, default_value_t = 50)]
    seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    first: u64,
    /// Write the problem for the peer planners to this JSON file.
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Random configurations written with the scene (and timed).
    #[arg(long, default_value_t = 1000)]
    checks: usize,
}

fn main() {
    if let Err(e) = run(&Args::parse()) {
        eprintln!("plan_seeds: error: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    if args.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    let end = args.first.checked_add(args.seeds).ok_or("--first + --seeds overflows u64")?;
    // A file, else a shipped problem by name: from its file in this
    // checkout (so its URDF is on disk for the peers), else the embedded copy.
    let path = PathBuf::from(&args.problem);
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems").join(format!("{}.toml", args.problem));
    let problem = match (path.is_file(), shipped.is_file()) {
        (true, _) => Problem::from_file(&path)?,
        (false, true) => Problem::from_file(&shipped)?,
        (false, false) => Problem::builtin(&args.problem)?,
    };
    let mut planner = ProblemPlanner::new(&problem, None)?;
    if let Some(file) = &args.scene {
        let scene = peer_scene(&problem, &planner, args.checks)?;
        std::fs::write(file, serde_json::to_string_pretty(&scene)?)
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
    }
    // One untimed run first (page faults, lazy allocations), outside the seed range.
    planner.run(end)?;
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let (mut total, mut cpu, mut planning, mut simplify) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut iterations, mut nodes, mut waypoints) = (Vec::new(), Vec::new(), Vec::new());
    let (mut solved, mut certified, mut attempts) = (0, 0, 0);
    for seed in args.first..end {
        let (began, cpu_began) = (Instant::now(), cpu_time_ms());
        let report = planner.run(seed)?;
        total.push(ms(began.elapsed()));
        cpu.push(cpu_time_ms() - cpu_began);
        planning.push(ms(report.planning_time));
        simplify.push(ms(report.simplify_time));
        iterations.push(report.result.iterations as f64);
        nodes.push(report.result.nodes as f64);
        attempts += report.attempts;
        if report.result.status == PlanStatus::Solved {
            solved += 1;
            waypoints.push(report.path.len() as f64);
        }
        certified += usize::from(report.certified);
    }
    let out = json!({
        "problem": problem.name,
        "planner": "tandem RRT-Connect",
        "seeds": args.seeds,
        "solved": solved,
        "median_ms": median(&mut total),
        "mean_ms": total.iter().sum::<f64>() / total.len() as f64,
        "p95_ms": percentile(&mut total, 0.95),
        "median_planning_ms": median(&mut planning),
        "median_simplify_ms": median(&mut simplify),
        "median_cpu_ms": median(&mut cpu),
        "simplified": true,
        "certified": certified,
        "runs": attempts,
        "median_iterations": median(&mut iterations),
        "median_nodes": median(&mut nodes),
        "median_waypoints": if waypoints.is_empty() { Value::Null } else { json!(median(&mut waypoints)) },
        "step": problem.planner.step,
        "resolution": problem.planner.resolution,
        "resolution_norm": "max",
        "clearance": problem.planner.clearance,
    });
    println!("{out}");
    Ok(())
}

/// The problem as the peers see it (see the module documentation).
fn peer_scene(problem: &Problem, planner: &ProblemPlanner, checks: usize) -> Result<Value, Box<dyn std::error::Error>> {
    // The search runs on shapes padded by the clearance: so do the peers.
    let model = problem.collision_model_padded(problem.planner.clearance)?;
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let limits = model.robot().limits();
    let configs: Vec<Vec<f64>> =
        (0..checks).map(|_| limits.iter().map(|l| rng.random_range(l.lower..=l.upper)).collect()).collect();
    let (free, check_ns) = verdicts(&model, &configs)?;
    let urdf = problem.robot_spec.collision_urdf.as_ref().unwrap_or(&problem.robot_spec.urdf);
    let urdf = std::fs::canonicalize(urdf).map_err(|e| format!("robot URDF {}: {e}", urdf.display()))?;
    let exchange = model
        .to_exchange_json(&urdf, &[], &configs)
        .ok_or("the collision model has shapes the exchange format cannot describe")?;
    let p = &problem.planner;
    Ok(json!({
        "problem": problem.name,
        "origin": problem.origin,
        "padding": model.padding(),
        "start": problem.start,
        "goals": planner.goals(),
        "joint_limits": limits.iter().map(|l| [l.lower, l.upper]).collect::<Vec<_>>(),
        "planner": {
            "step": p.step,
            "resolution": p.resolution,
            "resolution_norm": "max",
            "clearance": p.clearance,
            "time_limit": p.time_limit,
            "max_iterations": p.max_iterations,
        },
        "free": free,
        "tandem_check_ns": check_ns,
        "exchange": exchange,
    }))
}

/// Whether each configuration is collision-free, and the median time of
/// one check (ns) over 5 passes.
fn verdicts(model: &CollisionModel, configs: &[Vec<f64>]) -> Result<(Vec<bool>, f64), Box<dyn std::error::Error>> {
    let mut ws = CollisionWorkspace::new(model);
    let free = configs.iter().map(|q| model.collision_free(&mut ws, q)).collect::<Result<Vec<_>, _>>()?;
    let mut per_check = Vec::new();
    for _ in 0..5 {
        let began = Instant::now();
        for q in configs {
            std::hint::black_box(model.collision_free(&mut ws, std::hint::black_box(q))?);
        }
        per_check.push(began.elapsed().as_secs_f64() * 1e9 / configs.len().max(1) as f64);
    }
    Ok((free, median(&mut per_check)))
}

/// Nearest-rank percentile (`p` in 0..=1).
fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let rank = (p * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}
