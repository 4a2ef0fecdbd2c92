//! `tandem experiment`: the seed's shared-control experiments in one
//! command each.

use crate::data::Progress;
use crate::figures::{Panel, Series, render_panels};
use crate::sim::{
    Arm, Method, OperatorKind, Outcome, PlanarResults, PlanarSettings, ReachGraspResults, ReachGraspSettings, mean_std,
    percentiles, run_planar, run_reach_grasp,
};
use std::path::PathBuf;

/// Arguments of `tandem experiment`.
#[derive(Debug, clap::Args)]
pub struct ExperimentArgs {
    #[command(subcommand)]
    pub experiment: Experiment,
}

/// The experiments.
#[derive(Debug, clap::Subcommand)]
pub enum Experiment {
    /// Table 5.1: reach-and-grasp with simulated operators. Two Pandas side
    /// by side, a 6 × 6 × 12 cm box at a random pose on the table, a random
    /// start; every operator (straightline, approach, noisy-0.1, noisy-0.2,
    /// biased, laggy-5, laggy-10; 10 cm/s, linear velocity only) with every
    /// method (noassist, constrained, sos, natural-gradient-joint,
    /// blend-timid, avoid) on the same tasks. Success: the operator stops at
    /// the grasp point with the box between the finger pads, the fingertip
    /// centre over it, the gripper within 0.2 rad of pointing down, and
    /// neither palm nor fingers touching it; collision: anything touched
    /// before; timeout: 20 s. Deterministic per seed whatever the threads.
    ///
    /// Examples:
    ///   tandem experiment reach-grasp
    ///   tandem experiment reach-grasp --tasks 20 --arm right --json --out results/
    #[command(verbatim_doc_comment)]
    ReachGrasp(ReachGraspArgs),
    /// Table 4.1: planar pick-and-place (the seed's chapter 4 task) with the
    /// simulated users of §6.5. A gripper over a 50 × 50 cm table picks one
    /// of two cylinders past a pole and brings it to a place position;
    /// users straight, noisy-0.5, noisy-1.0, biased (5 cm/s) with methods
    /// direct (no collision avoidance), natural-gradient-joint, blend-timid,
    /// avoid, at 30 Hz. Reports duration, travel distance, smallest distance
    /// to the pole and the cosine distance between the user's and the
    /// executed command (mean ± std), success and collisions.
    ///
    /// Examples:
    ///   tandem experiment planar
    ///   tandem experiment planar --tasks 10 --json --out results/
    #[command(verbatim_doc_comment)]
    Planar(PlanarArgs),
    /// Follow a learned policy alone from random starts of the family's
    /// reach-and-grasp tasks (kinematic steps at 15 Hz, a collision check
    /// each step, the grasp judged by tandem's grasp judge: object between
    /// the finger pads, gripper within 0.1 rad of the approach axis, palm
    /// and fingers clear), beside the LQR tracking policy of a reference
    /// optimized from each start, and report success, collisions and
    /// timeouts (20 s; the seed reached 92–97 %, §3.3.3). Also: the
    /// training data's joint values against the limits (Fig. 3.8), success
    /// by the start's distance from the data, DAgger rounds (--rounds:
    /// follow fresh tasks, optimize expert trajectories from where the
    /// policy failed and where the data is thin, retrain) and shared
    /// control (the approach operator through constrained and
    /// sum-of-squares arbitration, judged by the same grasp judge) on top
    /// of either policy. Figures go to --out.
    ///
    /// Without --policy it generates a dataset (--train-count) and trains
    /// a policy in --out first.
    ///
    /// Examples:
    ///   tandem experiment policy --tasks 100
    ///   tandem experiment policy --policy policy.safetensors --data grasps/ --tasks 500 --rounds 3 --json
    #[command(verbatim_doc_comment)]
    Policy(super::experiment_policy::PolicyExperimentArgs),
    /// Table 6.1: the learned arbiters (combined reward, environment-only
    /// reward; DDPG, seed chapter 6) beside direct control (no collision
    /// avoidance, as the seed's) with the users noisy-0.5, noisy-1.0,
    /// straight and biased (5 cm/s, 30 Hz) on the planar reach task: the
    /// gripper starts behind a pole and reaches the user's cylinder (1 cm)
    /// within 20 s. Reports success, collisions and travel (mean ± std),
    /// Fig. 6.4 (training curves over --train-seeds seeds) and Fig. 6.5
    /// (distance of the executed command to the user's and to the
    /// predicted sub-policy over the episode). Trains the actors first
    /// unless --combined and --environment give them.
    ///
    /// Examples:
    ///   tandem experiment learned --episodes 100 --out results/
    ///   tandem experiment learned --combined c.safetensors --environment e.safetensors --json
    #[command(verbatim_doc_comment)]
    Learned(super::learned_arbitration::LearnedExperimentArgs),
    /// Table 7.3: traded control from predicted intent (seed chapter 7).
    /// A simulated person mimics reaching for one of three boxes on the
    /// table, from the top or the side (minimum-jerk hand motion at 180 Hz
    /// with trial-to-trial variability and a slow start; users Normal,
    /// Noisy: Gaussian noise each frame, Biased: a constant offset per
    /// demonstration). A classifier (trained first, on demonstrations
    /// seeded apart) names the object and the grasp direction from eight
    /// hand features each frame; a prediction held for --commit-steps
    /// frames after the first --discard-steps commits the target; the
    /// Panda then plans (IK, RRT-Connect, shortcut) and grasps and
    /// retrieves it. Modes: Early (plan on commit), Late (plan after the
    /// demonstration), Continuous (re-plan on every change). Reports time
    /// until execution, episode duration (three picks), goal and direction
    /// accuracy and planning time per user × mode, and Fig. 7.9 (accuracy
    /// over normalised time) with --out. Object poses are given (no
    /// perception).
    ///
    /// Examples:
    ///   tandem experiment traded
    ///   tandem experiment traded --episodes 100 --seed 1 --json
    ///   tandem experiment traded --planning-latency 2.0 --out results/
    #[command(verbatim_doc_comment)]
    Traded(super::experiment_traded::TradedArgs),
}

/// Arguments of `tandem experiment planar`.
#[derive(Debug, clap::Args)]
pub struct PlanarArgs {
    /// Tasks (1 … 100000).
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub tasks: u32,
    /// Seed of the tasks and of the users' randomness.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores); results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object: {"tasks", "results": [{"operator", "method",
    /// "success", "collision", "duration_s": [mean, std], "travel_cm",
    /// "proximity_cm", "cosine_distance"}, ...]}.
    #[arg(long)]
    pub json: bool,
    /// Folder for the Fig. 4.5-style figure (planar.svg) and the results (planar.json).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Arguments of `tandem experiment reach-grasp`.
#[derive(Debug, clap::Args)]
pub struct ReachGraspArgs {
    /// Tasks per arm (1 … 100000).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub tasks: u32,
    /// Which arm does the tasks.
    #[arg(long, default_value = "both", value_parser = ["right", "left", "both"])]
    pub arm: String,
    /// Seed of the tasks and of the operators' randomness.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores); results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object: {"tasks", "results": [{"arm", "operator",
    /// "method", "success", "collision", "timeout", "failed", "cos_sim":
    /// [x, y, z]}], ...}.
    #[arg(long)]
    pub json: bool,
    /// Folder for the Fig. 5.4-style figure (reach_grasp.svg), the results
    /// (reach_grasp.json) and every episode tick by tick
    /// (episodes/<arm>-<task>.parquet).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

pub(super) fn run(args: &ExperimentArgs) -> Result<(), Box<dyn std::error::Error>> {
    match &args.experiment {
        Experiment::ReachGrasp(a) => reach_grasp(a),
        Experiment::Planar(a) => planar(a),
        Experiment::Policy(a) => super::experiment_policy::run_policy(a),
        Experiment::Learned(a) => super::learned_arbitration::experiment_learned(a),
        Experiment::Traded(a) => super::experiment_traded::traded(a),
    }
}

fn reach_grasp(args: &ReachGraspArgs) -> Result<(), Box<dyn std::error::Error>> {
    let arms = match args.arm.as_str() {
        "right" => vec![Arm::Right],
        "left" => vec![Arm::Left],
        _ => vec![Arm::Right, Arm::Left],
    };
    let record_dir = args.out.as_ref().map(|d| d.join("episodes"));
    if let Some(dir) = &record_dir {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let settings = ReachGraspSettings {
        tasks: args.tasks as usize,
        seed: args.seed,
        arms,
        record_dir,
        ..ReachGraspSettings::default()
    };
    let total = (settings.tasks * settings.arms.len()) as u64;
    let progress = if args.json { Progress::quiet() } else { Progress::auto() }.start_counting(total, "tasks", false);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(args.threads.unwrap_or(0)).build()?;
    let results = pool.install(|| run_reach_grasp(&settings, &|| progress.sample_done(true)))?;
    progress.finish();
    let json = results_json(&results);
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
        };
        write("reach_grasp.json", serde_json::to_string_pretty(&json)?)?;
        write("reach_grasp.svg", figure(&results)?)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_table(&results);
        if let Some(dir) = &args.out {
            println!(
                "wrote reach_grasp.json, reach_grasp.svg and episodes/<arm>-<task>.parquet (every tick) to {}",
                dir.display()
            );
        }
    }
    Ok(())
}

fn results_json(r: &ReachGraspResults) -> serde_json::Value {
    let s = &r.settings;
    let mut rows = vec![];
    for &arm in &s.arms {
        for (o, op) in s.operators.iter().enumerate() {
            for (m, method) in s.methods.iter().enumerate() {
                let c = r.cell(arm, o, m);
                rows.push(serde_json::json!({
                    "arm": arm.as_str(), "operator": op.name(), "method": method.name(),
                    "success": c.success, "collision": c.collision, "timeout": c.timeout, "failed": c.failed,
                    "cos_sim": c.cos, "hard_violations": c.hard_violations,
                }));
            }
        }
    }
    let ticks: Vec<f64> = r.episodes.iter().flat_map(|e| e.tick_us.iter().copied()).collect();
    let (median, p99, max) = percentiles(&ticks);
    serde_json::json!({
        "tasks": s.tasks,
        "seed": s.seed,
        "results": rows,
        "resampled_tasks": r.tasks.iter().map(|t| t.resampled).sum::<usize>(),
        "seconds": {"wall": r.wall_seconds, "prepare_cpu": r.prepare_seconds, "episodes_cpu": r.episode_seconds},
        "tick_us": {"median": median, "p99": p99, "max": max},
    })
}

/// Table 5.1's layout: per arm, a row per method, collision / timeout /
/// failed / success per operator, and the average cosine similarities.
fn print_table(r: &ReachGraspResults) {
    let s = &r.settings;
    for &arm in &s.arms {
        print!("\n{:<24}", arm.as_str().to_uppercase());
        for op in &s.operators {
            print!("{:^18}", op.name());
        }
        println!("   avg. cos sim");
        print!("{:<24}", "");
        for _ in &s.operators {
            print!("{:^18}", "col  to fail succ");
        }
        println!("   x     y     z");
        for (m, method) in s.methods.iter().enumerate() {
            print!("{:<24}", method.name());
            for o in 0..s.operators.len() {
                let c = r.cell(arm, o, m);
                print!(" {:>3} {:>3} {:>3} {:>4}  ", c.collision, c.timeout, c.failed, c.success);
            }
            let cos = r.method_cos(arm, m);
            println!("  {:.2}  {:.2}  {:.2}", cos[0], cos[1], cos[2]);
        }
    }
    let resampled: usize = r.tasks.iter().map(|t| t.resampled).sum();
    println!(
        "\n{} tasks per arm ({} resampled: reference not converged), {} episodes in {:.1} s \
         (task preparation {:.1} s and episodes {:.1} s of CPU)",
        s.tasks,
        resampled,
        r.episodes.len(),
        r.wall_seconds,
        r.prepare_seconds,
        r.episode_seconds
    );
    let violations: usize = r.episodes.iter().map(|e| e.hard_violations).sum();
    println!("hard-constraint violations: {violations}");
}

/// Fig. 5.4: the first task's gripper paths (top views) per operator, for
/// NoAssist and the seed's two methods, with the robot's reference.
fn figure(r: &ReachGraspResults) -> Result<String, Box<dyn std::error::Error>> {
    let s = &r.settings;
    let arm = s.arms[0];
    let task = r.tasks.iter().find(|t| t.arm == arm && t.index == 0).ok_or("no first task")?;
    let robot = &task.goal.problem.robot;
    let gripper = robot.frame_id(task.goal.problem.robot_spec.gripper.as_deref().unwrap_or_default())?;
    let mut kin = crate::robot::KinematicsWorkspace::new(robot);
    let reference = task.goal.policy.reference();
    let mut planned = vec![];
    for i in 0..reference.len() {
        robot.forward_kinematics(&mut kin, reference.position(i))?;
        let p = robot.frame_pose(&kin, gripper).translation.vector;
        planned.push((p.x, p.y));
    }
    let shown = [
        Method::NoAssist,
        s.methods.get(1).copied().unwrap_or(Method::NoAssist),
        s.methods.get(2).copied().unwrap_or(Method::NoAssist),
    ];
    let operators: Vec<(usize, &OperatorKind)> = s.operators.iter().enumerate().take(4).collect();
    let panels: Vec<Panel> = operators
        .iter()
        .map(|&(o, op)| {
            let mut panel =
                Panel::new(&op.name(), "x (m)", "y (m)").with(Series::dashed("reference", &planned, 7)).equal();
            for (k, method) in shown.iter().enumerate() {
                let Some(m) = s.methods.iter().position(|x| x == method) else { continue };
                if let Some(e) =
                    r.episodes.iter().find(|e| e.arm == arm && e.task == 0 && e.operator == o && e.method == m)
                {
                    let path: Vec<(f64, f64)> = e.path.iter().map(|p| (p[0], p[1])).collect();
                    panel = panel.with(Series::line(&format!("{} ({})", method.name(), e.outcome.as_str()), &path, k));
                }
            }
            let goal = task.goal.position;
            panel.with(Series::points("grasp point", &[(goal[0], goal[1])], 3))
        })
        .collect();
    Ok(render_panels(
        &format!("reach-and-grasp, {} arm, task 0: gripper paths (top view)", arm.as_str()),
        &panels,
        380,
        420,
    )?)
}

fn planar(args: &PlanarArgs) -> Result<(), Box<dyn std::error::Error>> {
    let settings = PlanarSettings { tasks: args.tasks as usize, seed: args.seed, ..PlanarSettings::default() };
    let progress = if args.json { Progress::quiet() } else { Progress::auto() }.start_counting(
        settings.tasks as u64,
        "tasks",
        false,
    );
    let pool = rayon::ThreadPoolBuilder::new().num_threads(args.threads.unwrap_or(0)).build()?;
    let results = pool.install(|| run_planar(&settings, &|| progress.sample_done(true)))?;
    progress.finish();
    let json = planar_json(&results);
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
        };
        write("planar.json", serde_json::to_string_pretty(&json)?)?;
        write("planar.svg", planar_figure(&results)?)?;
    }
    if args.json {
        println!("{json}");
        return Ok(());
    }
    println!(
        "\n{:<12} {:<24} {:>8} {:>9} {:>14} {:>15} {:>15} {:>17}",
        "user", "method", "success", "collision", "duration (s)", "travel (cm)", "proximity (cm)", "cos dist (1e-2)"
    );
    for row in json["results"].as_array().into_iter().flatten() {
        let pm = |key: &str, scale: f64| {
            let v = &row[key];
            format!(
                "{:.1} ± {:.1}",
                v[0].as_f64().unwrap_or(f64::NAN) * scale,
                v[1].as_f64().unwrap_or(f64::NAN) * scale
            )
        };
        println!(
            "{:<12} {:<24} {:>8} {:>9} {:>14} {:>15} {:>15} {:>17}",
            row["operator"].as_str().unwrap_or_default(),
            row["method"].as_str().unwrap_or_default(),
            format!("{}/{}", row["success"], settings.tasks),
            row["collision"],
            pm("duration_s", 1.0),
            pm("travel_cm", 1.0),
            pm("proximity_cm", 1.0),
            pm("cosine_distance", 100.0),
        );
    }
    let violations: usize = results.episodes.iter().map(|e| e.hard_violations).sum();
    println!(
        "\n{} episodes in {:.1} s; hard-constraint violations: {violations}",
        results.episodes.len(),
        results.wall_seconds
    );
    if let Some(dir) = &args.out {
        println!("wrote planar.json and planar.svg to {}", dir.display());
    }
    Ok(())
}

fn planar_json(r: &PlanarResults) -> serde_json::Value {
    let s = &r.settings;
    let mut rows = vec![];
    for (u, user) in s.users.iter().enumerate() {
        for (m, method) in s.methods.iter().enumerate() {
            let cell: Vec<_> = r.episodes.iter().filter(|e| e.user == u && e.method == m).collect();
            let count = |o: Outcome| cell.iter().filter(|e| e.outcome == o).count();
            rows.push(serde_json::json!({
                "operator": user.name(),
                "method": method.as_str(),
                "success": count(Outcome::Success),
                "collision": count(Outcome::Collision),
                "timeout": count(Outcome::Timeout),
                "failed": count(Outcome::Failed),
                "duration_s": mean_std(cell.iter().map(|e| e.duration)),
                "travel_cm": mean_std(cell.iter().map(|e| e.travel_cm)),
                "proximity_cm": mean_std(cell.iter().map(|e| e.proximity_cm)),
                "cosine_distance": mean_std(cell.iter().map(|e| e.cosine_distance)),
                "hard_violations": cell.iter().map(|e| e.hard_violations).sum::<usize>(),
            }));
        }
    }
    serde_json::json!({"tasks": s.tasks, "seed": s.seed, "results": rows, "seconds": r.wall_seconds})
}

/// Fig. 4.5: the first task's gripper paths, one panel per method, every user.
fn planar_figure(r: &PlanarResults) -> Result<String, Box<dyn std::error::Error>> {
    use crate::figures::SeriesKind;
    let s = &r.settings;
    let task = r.tasks.first().ok_or("no task")?;
    let problem = &task.reach[task.target].problem;
    let pole = problem.scene.obstacle("pole").map(|o| (o.pose.translation.x, o.pose.translation.y)).unwrap_or_default();
    let objects: Vec<(f64, f64)> = task.reach.iter().map(|g| (g.position[0], g.position[1])).collect();
    let place = (task.place.position[0], task.place.position[1]);
    let panels: Vec<Panel> = s
        .methods
        .iter()
        .enumerate()
        .map(|(m, method)| {
            let mut panel = Panel::new(method.as_str(), "x (m)", "y (m)").ranges((0.0, 0.5), (0.0, 0.5)).equal();
            for (u, user) in s.users.iter().enumerate() {
                if let Some(e) = r.episodes.iter().find(|e| e.task == task.index && e.user == u && e.method == m) {
                    panel = panel.with(Series::line(&format!("{} ({})", user.name(), e.outcome.as_str()), &e.path, u));
                }
            }
            panel
                .with(Series { label: None, points: vec![pole], color: 7, kind: SeriesKind::Circles(0.03) })
                .with(Series::points("cylinders", &objects, 3))
                .with(Series::points("place", &[place], 2))
        })
        .collect();
    Ok(render_panels("planar pick-and-place, task 0: gripper paths by method (top view)", &panels, 360, 400)?)
}
