//! A problem family's samples for the peer generator
//! (benches/peers/rai_generate.py, run by benches/peers/compare_generate.sh),
//! and tandem's yardstick on the peer's and on tandem's own trajectories.
//!
//! **Export** (default): for ids `0 .. --count` of the family with run seed
//! `--seed` and horizon `-T`, samples the problem exactly as `tandem
//! generate` does (`ProblemFamily::sample(seed, id)`) and writes
//! `OUT/sample_NNNNN.json` in the exchange format of
//! `examples/komo_seeds.rs --export` (`support/peer_problem.rs`: the
//! optimizer's collision model — URDF collision spheres by link, obstacles
//! by shape and world pose, checked pairs —, start, joints and limits,
//! horizon, objectives resolved with frames and slices; `inits` empty)
//! plus what the generator needs beyond the optimizer:
//! - `planner`: tandem's planner settings (step, resolution, clearance,
//!   `max_iterations`; the search pads the robot by `search_padding`),
//! - `goal`: the goal as posed (grasp: the gripper frame and the world pose
//!   of the grasp frame) and the acceptance tolerances of `tandem generate`,
//! - `tandem_goals`: the goal configurations tandem's IK finds for this
//!   sample (`ProblemPlanner::new` with the sample's seed, as
//!   `solve_problem` does; up to 4, or empty with `ik_error`) and the time
//!   that IK took (`tandem_ik_ms`). A peer may use them (it then gets IK
//!   for free) or solve its own IK.
//!
//! **Measure** (`--measure FILE`): reads a peer's result (`{"samples":
//! [{"id", "trajectory" (q_1 … q_T or null), "converged", …}]}`), re-samples
//! each id's problem and judges every trajectory as `tandem generate`
//! accepts its own, and with the KOMO peers' yardstick:
//! `TrajectoryProblem::measure` (cost, largest equality and inequality
//! violation, ≤ `--tolerance`), `TrajectoryOptimizer::validate` (collision
//! free between slices at `--resolution`, joint limits) and the goal check
//! of `tandem generate` (q_T within 1 mm and 10 mrad of the goal). Prints
//! the peer's JSON with those keys and `success` added to each sample.
//!
//! **Dataset** (`--dataset DIR`): the same verdict on the accepted rows of a
//! `tandem generate` dataset (its Parquet parts), so both sides are judged
//! by the same code; rejected ids come out with their reason.
//!
//! ```text
//! cargo run --release --example family_export -- problems/panda_grasp_family.toml --count 100 -T 50 --out target/peers/generate/samples
//! cargo run --release --example family_export -- problems/panda_grasp_family.toml --count 100 -T 50 --measure rai.json
//! cargo run --release --example family_export -- problems/panda_grasp_family.toml --count 100 -T 50 --dataset DIR
//! ```

#[path = "../support/peer_problem.rs"]
mod peer_problem;

use arrow_array::{Array, FixedSizeListArray, Float64Array, UInt64Array};
use clap::Parser;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;
use tandem::komo::{TrajectoryOptimizer, TrajectoryProblem, trajectory_solver_settings};
use tandem::pipeline::{PipelineSettings, goal_miss};
use tandem::plan::ProblemPlanner;
use tandem::problem::{Goal, Problem, ProblemFamily};

#[derive(Debug, Parser)]
#[command(about = "Export a family's samples for the peer generator, or measure trajectories with tandem's yardstick")]
struct Args {
    /// The problem family file (TOML).
    family: PathBuf,
    /// Samples 0 … N−1.
    #[arg(long, default_value_t = 100)]
    count: u64,
    /// Run seed (as `tandem generate --seed`).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Horizon T (default: the family's base problem's).
    #[arg(long, short = 'T')]
    horizon: Option<usize>,
    /// Export: write sample_NNNNN.json files into this folder.
    #[arg(long, value_name = "DIR", required_unless_present_any = ["measure", "dataset"])]
    out: Option<PathBuf>,
    /// Measure a peer's trajectories (JSON) instead of exporting.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["out", "dataset"])]
    measure: Option<PathBuf>,
    /// Measure the accepted rows of a `tandem generate` dataset folder.
    #[arg(long, value_name = "DIR", conflicts_with = "out")]
    dataset: Option<PathBuf>,
    /// Joint step of the collision check between slices (rad).
    #[arg(long, default_value_t = 0.002)]
    resolution: f64,
    /// Largest measured equality / inequality violation of a success.
    #[arg(long, default_value_t = 1e-4)]
    tolerance: f64,
}

type Error = Box<dyn std::error::Error>;

fn main() {
    if let Err(e) = run(&Args::parse()) {
        eprintln!("family_export: error: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<(), Error> {
    let family = ProblemFamily::from_file(&args.family)?;
    if let Some(file) = &args.measure {
        let text = std::fs::read_to_string(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        let mut peer: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", file.display()))?;
        measure_peer(args, &family, &mut peer)?;
        println!("{peer}");
    } else if let Some(dir) = &args.dataset {
        println!("{}", measure_dataset(args, &family, dir)?);
    } else if let Some(dir) = &args.out {
        export(args, &family, dir)?;
    }
    Ok(())
}

/// Sample `id` as `tandem generate` poses it, with its sample seed.
fn sample(args: &Args, family: &ProblemFamily, id: u64) -> Result<(Problem, u64, usize), Error> {
    let s = family.sample(args.seed, id)?;
    let mut problem = s.problem;
    if let Some(t) = args.horizon {
        problem.optimizer.horizon = t;
    }
    Ok((problem, s.seed, s.skipped_obstacles))
}

fn export(args: &Args, family: &ProblemFamily, dir: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let settings = PipelineSettings::default();
    for id in 0..args.count {
        let (problem, seed, skipped) = sample(args, family, id)?;
        let tp = TrajectoryProblem::from_problem(&problem)?;
        let mut out = peer_problem::problem_json(&problem, &tp)?;
        let began = Instant::now();
        let (goals, ik_error) = match ProblemPlanner::new(&problem, Some(seed)) {
            Ok(planner) => (planner.goals().to_vec(), None),
            Err(e) => (Vec::new(), Some(e.to_string())),
        };
        let ik_ms = began.elapsed().as_secs_f64() * 1e3;
        let p = &problem.planner;
        let search = problem.collision_model_padded(p.clearance)?;
        out.insert("id".into(), json!(id));
        out.insert("seed".into(), json!(seed));
        out.insert("run_seed".into(), json!(args.seed));
        out.insert("family".into(), json!(family.name));
        out.insert("skipped_obstacles".into(), json!(skipped));
        out.insert(
            "planner".into(),
            json!({
                "step": p.step,
                "resolution": p.resolution,
                "resolution_norm": "max",
                "clearance": p.clearance,
                "max_iterations": p.max_iterations,
                "search_padding": search.padding(),
            }),
        );
        out.insert("goal".into(), goal_json(&problem, &settings)?);
        out.insert("tandem_goals".into(), json!(goals));
        out.insert("tandem_ik_ms".into(), json!(ik_ms));
        out.insert("ik_error".into(), json!(ik_error));
        out.insert("inits".into(), json!([]));
        out.insert("tolerance".into(), json!(args.tolerance));
        out.insert("resolution".into(), json!(args.resolution));
        let file = dir.join(format!("sample_{id:05}.json"));
        std::fs::write(&file, serde_json::to_string(&Value::Object(out))?)
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
    }
    eprintln!("family_export: wrote {} samples to {}", args.count, dir.display());
    Ok(())
}

/// The goal as posed, with the acceptance tolerances of `tandem generate`.
fn goal_json(problem: &Problem, settings: &PipelineSettings) -> Result<Value, Error> {
    let tolerances = json!({"distance": settings.goal_tolerance, "angle": settings.goal_angle_tolerance});
    Ok(match &problem.goal {
        Goal::Grasp { object, grasp } => {
            let pose = problem.grasp_target().ok_or("the grasp goal has no target pose")?;
            let r = pose.rotation.matrix();
            json!({
                "kind": "grasp",
                "object": object,
                "grasp": grasp,
                "gripper": problem.robot_spec.gripper,
                "translation": pose.translation.vector.as_slice(),
                "rotation": (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect::<Vec<_>>(),
                "checked": "gripper position within distance of the grasp frame, gripper z within angle of its z",
                "tolerance": tolerances,
            })
        }
        Goal::Joints(q) => json!({"kind": "joints", "q": q, "tolerance": tolerances}),
        Goal::Pose { frame, position, .. } => {
            json!({"kind": "pose", "frame": frame, "position": position.as_slice(), "tolerance": tolerances})
        }
    })
}

/// Tandem's verdict on one trajectory of sample `problem`, as keys.
fn verdict(args: &Args, problem: &Problem, trajectory: &[Vec<f64>]) -> Result<serde_json::Map<String, Value>, Error> {
    let tp = TrajectoryProblem::from_problem(problem)?;
    if trajectory.len() != tp.horizon() {
        return Err(format!("a trajectory has {} slices, the horizon is {}", trajectory.len(), tp.horizon()).into());
    }
    let measures = tp.measure(trajectory)?;
    let optimizer = TrajectoryOptimizer::new(tp, trajectory_solver_settings());
    let v = tandem::pipeline::validate(optimizer.problem(), trajectory, args.resolution)?;
    let settings = PipelineSettings::default();
    let last = trajectory.last().ok_or("an empty trajectory")?;
    let miss = goal_miss(problem, last)?;
    let goal_reached = miss.distance <= settings.goal_tolerance && miss.angle <= settings.goal_angle_tolerance;
    let feasible = measures.equality_violation <= args.tolerance
        && measures.inequality_violation <= args.tolerance
        && v.collision_free
        && v.within_limits;
    let mut out = serde_json::Map::new();
    out.insert("cost".into(), json!(measures.cost));
    out.insert("eq".into(), json!(measures.equality_violation));
    out.insert("ineq".into(), json!(measures.inequality_violation));
    out.insert("collision_free".into(), json!(v.collision_free));
    out.insert("within_limits".into(), json!(v.within_limits));
    out.insert("min_distance".into(), json!(v.min_distance));
    out.insert("goal_distance".into(), json!(miss.distance));
    out.insert("goal_angle".into(), json!(miss.angle));
    out.insert("goal_reached".into(), json!(goal_reached));
    out.insert("feasible".into(), json!(feasible));
    Ok(out)
}

/// The measure mode: every sample of a peer's file, judged by tandem.
fn measure_peer(args: &Args, family: &ProblemFamily, peer: &mut Value) -> Result<(), Error> {
    let samples = peer.get_mut("samples").and_then(Value::as_array_mut).ok_or("the peer file has no samples array")?;
    let mut successes = 0;
    for s in samples.iter_mut() {
        let s = s.as_object_mut().ok_or("a sample is not an object")?;
        let id = s.get("id").and_then(Value::as_u64).ok_or("a sample has no id")?;
        let trajectory: Option<Vec<Vec<f64>>> =
            s.get("trajectory").and_then(|t| serde_json::from_value(t.clone()).ok());
        let converged = s.get("converged").and_then(Value::as_bool).unwrap_or(false);
        let success = match trajectory {
            Some(t) => {
                let (problem, _, _) = sample(args, family, id)?;
                let v = verdict(args, &problem, &t)?;
                let ok = converged && v["feasible"] == json!(true) && v["goal_reached"] == json!(true);
                s.extend(v);
                ok
            }
            None => false,
        };
        successes += usize::from(success);
        s.insert("success".into(), json!(success));
        s.remove("trajectory");
    }
    peer["successes"] = json!(successes);
    peer["tolerance"] = json!(args.tolerance);
    peer["resolution"] = json!(args.resolution);
    Ok(())
}

/// The dataset mode: tandem's accepted rows judged by the same code.
fn measure_dataset(args: &Args, family: &ProblemFamily, dir: &Path) -> Result<Value, Error> {
    let mut parts: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "parquet"))
        .collect();
    parts.sort();
    let (mut samples, mut successes) = (Vec::new(), 0);
    for part in &parts {
        let file = std::fs::File::open(part).map_err(|e| format!("cannot open {}: {e}", part.display()))?;
        let builder = ParquetRecordBatchReaderBuilder::try_new(file)?;
        let rejected = builder
            .metadata()
            .file_metadata()
            .key_value_metadata()
            .and_then(|kv| kv.iter().find(|k| k.key == "tandem.rejected"))
            .and_then(|k| k.value.as_deref())
            .map(serde_json::from_str::<Vec<Value>>)
            .transpose()?
            .unwrap_or_default();
        for r in rejected {
            samples.push(json!({"id": r["id"], "accepted": false, "reason": r["reason"], "success": false}));
        }
        for batch in builder.build()? {
            let batch = batch?;
            let ids = column::<UInt64Array>(&batch, "id")?;
            let q = column::<FixedSizeListArray>(&batch, "q")?;
            for row in 0..batch.num_rows() {
                let id = ids.value(row);
                // q holds q_0 (the start) … q_T; the verdict takes q_1 … q_T.
                let trajectory = nested_rows(q.value(row).as_ref())?.split_off(1);
                let (problem, _, _) = sample(args, family, id)?;
                let mut s = verdict(args, &problem, &trajectory)?;
                let success = s["feasible"] == json!(true) && s["goal_reached"] == json!(true);
                successes += usize::from(success);
                s.insert("id".into(), json!(id));
                s.insert("accepted".into(), json!(true));
                s.insert("success".into(), json!(success));
                samples.push(Value::Object(s));
            }
        }
    }
    samples.sort_by_key(|s| s["id"].as_u64());
    Ok(json!({
        "solver": "tandem generate",
        "samples": samples,
        "successes": successes,
        "tolerance": args.tolerance,
        "resolution": args.resolution,
    }))
}

fn column<'a, T: 'static>(batch: &'a arrow_array::RecordBatch, name: &str) -> Result<&'a T, Error> {
    batch
        .column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<T>())
        .ok_or_else(|| format!("the dataset has no column {name} of the expected type").into())
}

/// A fixed-size list of fixed-size lists of f64 as rows.
fn nested_rows(array: &dyn Array) -> Result<Vec<Vec<f64>>, Error> {
    let outer = array.as_any().downcast_ref::<FixedSizeListArray>().ok_or("q is not a list of lists")?;
    (0..outer.len())
        .map(|t| {
            let inner = outer.value(t);
            let values = inner.as_any().downcast_ref::<Float64Array>().ok_or("q holds no f64 values")?;
            Ok(values.values().to_vec())
        })
        .collect()
}
