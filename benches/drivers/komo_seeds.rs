//! tandem's trajectory optimizer on one problem at one horizon, for the
//! side-by-side comparison with RAI's KOMO and casadi + IPOPT
//! (`benches/peers/compare_komo.sh`).
//!
//! **Run** (default): plans `--inits K` initial paths with RRT-Connect
//! (seeds `--first .. --first + K`, shortcut, as `solve_problem` does),
//! resamples each to `q_1 … q_T` (the straight line to the first goal
//! configuration when planning fails) and optimizes from each `--reps R`
//! times as `solve_problem` does: with its settings, a cold start (no
//! multipliers kept from the previous repetition), validation of the result
//! at `--resolution`, and, when the motion between slices collides, the
//! re-solves from the result with collision rows between slices (1, 3, then
//! 7 per interval). The time of a run covers all of that (initialisation,
//! optimization, clamping into the limits, validation, re-solves); planning
//! and building the optimizers (also the refined ones) are not timed;
//! `solve_ms` is the first optimization alone. Each final trajectory is
//! measured with `TrajectoryProblem::measure` of the problem as written
//! (cost, largest equality and inequality violation; no rows between
//! slices) and checked with `TrajectoryOptimizer::validate` (collisions
//! between slices at `--resolution`, joint limits). Prints one JSON object:
//! per initialisation the times, the solver's report, the measures and the
//! trajectory; overall the median time and the successes.
//!
//! **Export** (`--export FILE`, with a run): writes what the peers need to
//! pose the same problem — the optimizer's collision model in the collision
//! scene exchange format (URDF collision spheres by link and index,
//! obstacles by shape and world pose, every checked pair; no padding), the
//! start, joint names and limits, horizon, order, duration, every objective
//! resolved (feature, frames — robot frames by name, fixed frames by world
//! pose —, axes, kind, scale, target, order, slices, margin) and the
//! initialisations with tandem's measures of them.
//!
//! **Measure** (`--measure FILE`): reads a peer's result (`{"solver", "runs":
//! [{"init", "trajectory", "converged", …}]}`), measures and validates every
//! trajectory exactly as tandem's own, and prints the peer's JSON with
//! `cost`, `eq`, `ineq`, `collision_free`, `within_limits`, `min_distance`
//! and `success` added to each run (no optimization is run).
//!
//! A run succeeds when the solver says it converged, the measured equality
//! and inequality violations are at most `--tolerance` (1e-4) and the
//! trajectory is collision-free at the validation resolution and within the
//! joint limits.
//!
//! ```text
//! cargo run --release --example komo_seeds -- problems/panda_grasp_box.toml --horizon 50 --export init.json
//! cargo run --release --example komo_seeds -- problems/panda_grasp_box.toml --horizon 50 --measure rai.json
//! ```

#[path = "../support/peer_problem.rs"]
mod peer_problem;

#[path = "../support/timing.rs"]
mod timing;
use clap::Parser;
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;
use tandem::komo::{Initialization, Measures, TrajectoryOptimizer, TrajectoryProblem, trajectory_solver_settings};
use tandem::plan::{PlanStatus, ProblemPlanner, resample};
use tandem::problem::Problem;
use tandem_solvers::least_squares::{SolveReport, SolverSettings, Termination};
use timing::{cpu_time_ms, median};

#[derive(Debug, Parser)]
#[command(about = "Optimize one problem from several initialisations, many times; print JSON")]
struct Args {
    /// A problem file (TOML), or the name of a shipped problem.
    problem: String,
    /// Horizon T (default: the problem's).
    #[arg(long)]
    horizon: Option<usize>,
    /// Number of initial paths (RRT-Connect seeds).
    #[arg(long, default_value_t = 5)]
    inits: u64,
    /// First RRT-Connect seed.
    #[arg(long, default_value_t = 0)]
    first: u64,
    /// Timed solves per initialisation.
    #[arg(long, default_value_t = 10)]
    reps: usize,
    /// Write the problem and the initialisations for the peers to this JSON file.
    #[arg(long, value_name = "FILE")]
    export: Option<PathBuf>,
    /// Measure the trajectories of a peer's result file instead of optimizing.
    #[arg(long, value_name = "FILE", conflicts_with = "export")]
    measure: Option<PathBuf>,
    /// Joint step of the collision check between slices (rad).
    #[arg(long, default_value_t = 0.002)]
    resolution: f64,
    /// Largest measured equality / inequality violation of a success.
    #[arg(long, default_value_t = 1e-4)]
    tolerance: f64,
    /// Leave the trajectories out of the printed JSON.
    #[arg(long)]
    brief: bool,
}

fn main() {
    if let Err(e) = run(&Args::parse()) {
        eprintln!("komo_seeds: error: {e}");
        std::process::exit(1);
    }
}

type Error = Box<dyn std::error::Error>;

fn run(args: &Args) -> Result<(), Error> {
    if args.inits == 0 || args.reps == 0 {
        return Err("--inits and --reps must be at least 1".into());
    }
    let problem = load_problem(&args.problem, args.horizon)?;
    let trajectory_problem = TrajectoryProblem::from_problem(&problem)?;
    let settings = SolverSettings { max_evaluations: problem.optimizer.max_iterations, ..trajectory_solver_settings() };
    // The re-solves of `solve_problem` with collision rows between slices
    // (its substeps, copied: keep in sync with src/komo/solve.rs).
    let mut refined: Vec<TrajectoryOptimizer> = [1, 3, 7]
        .iter()
        .map(|&s| TrajectoryOptimizer::new(trajectory_problem.clone().with_collision_substeps(s), settings.clone()))
        .collect();
    let mut optimizer = TrajectoryOptimizer::new(trajectory_problem, settings);
    let out = match &args.measure {
        Some(file) => measure_file(args, &optimizer, file)?,
        None => optimize(args, &problem, &mut optimizer, &mut refined)?,
    };
    println!("{out}");
    Ok(())
}

/// A file, else a shipped problem by name: from its file in this checkout
/// (so its URDF is on disk for the peers), else the embedded copy; with the
/// horizon overridden.
fn load_problem(name: &str, horizon: Option<usize>) -> Result<Problem, Error> {
    let path = PathBuf::from(name);
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems").join(format!("{name}.toml"));
    let mut problem = match (path.is_file(), shipped.is_file()) {
        (true, _) => Problem::from_file(&path)?,
        (false, true) => Problem::from_file(&shipped)?,
        (false, false) => Problem::builtin(name)?,
    };
    if let Some(t) = horizon {
        problem.optimizer.horizon = t;
    }
    Ok(problem)
}

/// The verdict of tandem's yardstick on one trajectory.
struct Verdict {
    measures: Measures,
    collision_free: bool,
    within_limits: bool,
    min_distance: Option<f64>,
}

impl Verdict {
    fn of(args: &Args, optimizer: &TrajectoryOptimizer, trajectory: &[Vec<f64>]) -> Result<Verdict, Error> {
        let measures = optimizer.problem().measure(trajectory)?;
        let v = tandem::pipeline::validate(optimizer.problem(), trajectory, args.resolution)?;
        Ok(Verdict {
            measures,
            collision_free: v.collision_free,
            within_limits: v.within_limits,
            min_distance: v.min_distance,
        })
    }

    /// Feasible within `tolerance`, collision-free, within the limits.
    fn feasible(&self, tolerance: f64) -> bool {
        self.measures.equality_violation <= tolerance
            && self.measures.inequality_violation <= tolerance
            && self.collision_free
            && self.within_limits
    }

    /// The measured keys of a run.
    fn write(&self, run: &mut serde_json::Map<String, Value>) {
        run.insert("cost".into(), json!(self.measures.cost));
        run.insert("eq".into(), json!(self.measures.equality_violation));
        run.insert("ineq".into(), json!(self.measures.inequality_violation));
        run.insert("collision_free".into(), json!(self.collision_free));
        run.insert("within_limits".into(), json!(self.within_limits));
        run.insert("min_distance".into(), json!(self.min_distance));
    }
}

/// The outcome of [`solve_like_solve_problem`].
struct Solved {
    trajectory: Vec<Vec<f64>>,
    /// Counts and time summed over the solves; the rest is the last one's.
    report: SolveReport,
    /// Re-solves with collision rows between slices.
    resolves: usize,
    /// Time of the first optimization alone (ms).
    solve_ms: f64,
}

/// One solve as `solve_problem` does it, from `init` (`q_1 … q_T`), cold:
/// optimize, validate, re-solve with collision rows between slices while
/// the motion between slices collides.
fn solve_like_solve_problem(
    args: &Args,
    optimizer: &mut TrajectoryOptimizer,
    refined: &mut [TrajectoryOptimizer],
    init: &[Vec<f64>],
    x: &mut [f64],
) -> Result<Solved, Error> {
    let n = optimizer.problem().nq();
    let began = Instant::now();
    optimizer.initialize(Initialization::Warm(init), x)?;
    let mut report = optimizer.solve_in_place(x)?;
    let solve_ms = began.elapsed().as_secs_f64() * 1e3;
    let mut trajectory: Vec<Vec<f64>> = x.chunks(n).map(<[f64]>::to_vec).collect();
    let mut validation = tandem::pipeline::validate(optimizer.problem(), &trajectory, args.resolution)?;
    let mut resolves = 0;
    for next in refined.iter_mut() {
        if validation.collision_free {
            break;
        }
        next.initialize(Initialization::Warm(&trajectory), x)?;
        let last = next.solve_in_place(x)?;
        report = SolveReport {
            outer_iterations: report.outer_iterations + last.outer_iterations,
            inner_steps: report.inner_steps + last.inner_steps,
            evaluations: report.evaluations + last.evaluations,
            time: report.time + last.time,
            ..last
        };
        trajectory = x.chunks(n).map(<[f64]>::to_vec).collect();
        validation = tandem::pipeline::validate(next.problem(), &trajectory, args.resolution)?;
        resolves += 1;
    }
    Ok(Solved { trajectory, report, resolves, solve_ms })
}

/// The run mode: plan the initialisations, optimize from each, measure.
fn optimize(
    args: &Args,
    problem: &Problem,
    optimizer: &mut TrajectoryOptimizer,
    refined: &mut [TrajectoryOptimizer],
) -> Result<Value, Error> {
    let horizon = optimizer.problem().horizon();
    let mut planner = ProblemPlanner::new(problem, None)?;
    let mut inits = Vec::new();
    for seed in args.first..args.first + args.inits {
        let plan = planner.run(seed)?;
        let init: Vec<Vec<f64>> = if plan.result.status == PlanStatus::Solved && !plan.path.is_empty() {
            resample(&plan.path, horizon + 1).split_off(1)
        } else {
            let goal = plan.goals.first().unwrap_or(&problem.start);
            (1..=horizon)
                .map(|t| {
                    let f = t as f64 / horizon as f64;
                    problem.start.iter().zip(goal).map(|(a, b)| a + (b - a) * f).collect()
                })
                .collect()
        };
        inits.push((seed, plan.result.status == PlanStatus::Solved, init));
    }
    let mut x = vec![0.0; horizon * optimizer.problem().nq()];
    // One untimed solve first (page faults, lazy allocations).
    solve_like_solve_problem(args, optimizer, refined, &inits[0].2, &mut x)?;
    let (mut all_ms, mut all_cpu, mut all_solve) = (Vec::new(), Vec::new(), Vec::new());
    let (mut runs, mut successes) = (Vec::new(), 0);
    for (index, (seed, planned, init)) in inits.iter().enumerate() {
        let (mut times, mut cpu, mut solve_times, mut last) = (Vec::new(), Vec::new(), Vec::new(), None);
        for _ in 0..args.reps {
            let (began, cpu_began) = (Instant::now(), cpu_time_ms());
            let result = solve_like_solve_problem(args, optimizer, refined, init, &mut x)?;
            times.push(began.elapsed().as_secs_f64() * 1e3);
            cpu.push(cpu_time_ms() - cpu_began);
            solve_times.push(result.solve_ms);
            last = Some(result);
        }
        let Solved { trajectory, report: r, resolves, .. } = last.ok_or("no solve ran")?;
        let verdict = Verdict::of(args, optimizer, &trajectory)?;
        let converged = r.termination == Termination::Converged;
        let success = converged && verdict.feasible(args.tolerance);
        successes += usize::from(success);
        let mut run = serde_json::Map::new();
        run.insert("init".into(), json!(index));
        run.insert("seed".into(), json!(seed));
        run.insert("planned".into(), json!(planned));
        run.insert("median_ms".into(), json!(median(&mut times.clone())));
        run.insert("median_cpu_ms".into(), json!(median(&mut cpu.clone())));
        run.insert("median_solve_ms".into(), json!(median(&mut solve_times.clone())));
        run.insert("times_ms".into(), json!(times));
        run.insert("status".into(), json!(r.termination.as_str()));
        run.insert("converged".into(), json!(converged));
        run.insert("resolves".into(), json!(resolves));
        run.insert("outer_iterations".into(), json!(r.outer_iterations));
        run.insert("inner_steps".into(), json!(r.inner_steps));
        run.insert("evaluations".into(), json!(r.evaluations));
        run.insert("own".into(), json!({"cost": r.cost, "eq": r.equality_violation, "ineq": r.inequality_violation}));
        verdict.write(&mut run);
        run.insert("success".into(), json!(success));
        if !args.brief {
            run.insert("trajectory".into(), json!(trajectory));
        }
        runs.push(Value::Object(run));
        all_ms.extend(times);
        all_cpu.extend(cpu);
        all_solve.extend(solve_times);
    }
    if let Some(file) = &args.export {
        let export = export_json(args, problem, optimizer, &inits)?;
        std::fs::write(file, serde_json::to_string(&export)?)
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
    }
    Ok(json!({
        "solver": "tandem",
        "problem": problem.name,
        "horizon": horizon,
        "duration": problem.optimizer.duration,
        "inits": args.inits,
        "reps": args.reps,
        "tolerance": args.tolerance,
        "resolution": args.resolution,
        "timed": "as solve_problem: init + optimize + clamp + validate + re-solves with rows between slices; cold",
        "median_ms": median(&mut all_ms),
        "median_cpu_ms": median(&mut all_cpu),
        "median_solve_ms": median(&mut all_solve),
        "successes": successes,
        "runs": runs,
    }))
}

/// The problem as the peers see it (see the module documentation): the
/// shared keys of `support/peer_problem.rs` plus the initialisations with
/// tandem's measures of them.
fn export_json(
    args: &Args,
    problem: &Problem,
    optimizer: &TrajectoryOptimizer,
    inits: &[(u64, bool, Vec<Vec<f64>>)],
) -> Result<Value, Error> {
    let mut out = peer_problem::problem_json(problem, optimizer.problem())?;
    let mut init_values = Vec::new();
    for (index, (seed, planned, init)) in inits.iter().enumerate() {
        let v = Verdict::of(args, optimizer, init)?;
        init_values.push(json!({
            "init": index,
            "seed": seed,
            "planned": planned,
            "trajectory": init,
            "cost": v.measures.cost,
            "eq": v.measures.equality_violation,
            "ineq": v.measures.inequality_violation,
            "collision_free": v.collision_free,
        }));
    }
    out.insert("inits".into(), json!(init_values));
    out.insert("tolerance".into(), json!(args.tolerance));
    out.insert("resolution".into(), json!(args.resolution));
    Ok(Value::Object(out))
}

/// The measure mode: tandem's verdict on every trajectory of a peer's file.
fn measure_file(args: &Args, optimizer: &TrajectoryOptimizer, file: &PathBuf) -> Result<Value, Error> {
    let text = std::fs::read_to_string(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let mut peer: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", file.display()))?;
    let horizon = optimizer.problem().horizon();
    let runs = peer.get_mut("runs").and_then(Value::as_array_mut).ok_or("the peer file has no runs array")?;
    let mut successes = 0;
    for run in runs.iter_mut() {
        let run = run.as_object_mut().ok_or("a run is not an object")?;
        let trajectory: Option<Vec<Vec<f64>>> =
            run.get("trajectory").and_then(|t| serde_json::from_value(t.clone()).ok());
        let converged = run.get("converged").and_then(Value::as_bool).unwrap_or(false);
        let success = match trajectory {
            Some(t) if t.len() == horizon => {
                let verdict = Verdict::of(args, optimizer, &t)?;
                verdict.write(run);
                converged && verdict.feasible(args.tolerance)
            }
            Some(t) => return Err(format!("a trajectory has {} slices, the horizon is {horizon}", t.len()).into()),
            None => false,
        };
        successes += usize::from(success);
        run.insert("success".into(), json!(success));
        if args.brief {
            run.remove("trajectory");
        }
    }
    peer["successes"] = json!(successes);
    peer["tolerance"] = json!(args.tolerance);
    peer["resolution"] = json!(args.resolution);
    Ok(peer)
}
