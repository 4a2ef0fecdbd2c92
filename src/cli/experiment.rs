//! `tandem experiment`: the dissertation's shared-control experiments in
//! one command each, all run by [`crate::experiments::run`]: the arguments
//! become the experiment's settings and the harness's, nothing more.

use super::harness::run_in_harness;
use crate::experiments::{PlanarSettings, ReachGraspSettings, Simulator};
use crate::sim::Arm;
use crate::sim::PhysicsSettings;
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
    /// Table 4.1: planar pick-and-place (the dissertation's chapter 4 task)
    /// with the simulated users of §6.5. A gripper over a 50 × 50 cm table
    /// picks one of two cylinders past a pole and brings it to a place
    /// position; users straight, noisy-0.5, noisy-1.0, biased (5 cm/s) with
    /// methods direct (no collision avoidance), natural-gradient-joint,
    /// blend-timid, avoid, at 30 Hz. Reports duration, travel distance,
    /// smallest distance to the pole and the cosine distance between the
    /// user's and the executed command (mean ± std), success and collisions.
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
    /// timeouts (20 s; the dissertation's policy reached 92–97 %, §3.3.3),
    /// with why each rollout ended (reasons; collisions by phase and pair).
    /// With --data: the training data's joint values against the limits (Fig. 3.8),
    /// success by the start's distance from the data, DAgger rounds (--rounds:
    /// follow fresh tasks, optimize expert trajectories from where the
    /// policy failed and where the data is thin, retrain) and shared
    /// control (the approach operator through constrained and
    /// sum-of-squares arbitration, judged by the same grasp judge) on top
    /// of either policy. Figures go to --out.
    ///
    /// Without --policy it evaluates the policy tandem ships
    /// (policies/panda_grasp_family.safetensors, embedded; its provenance in
    /// policies/panda_grasp_family.json); --train generates a dataset
    /// (--train-count) and trains a policy in --out first.
    ///
    /// Examples:
    ///   tandem experiment policy --tasks 1000
    ///   tandem experiment policy --train --train-count 2000 --epochs 30
    ///   tandem experiment policy --policy policy.safetensors --data grasps/ --tasks 500 --rounds 3 --json
    #[command(verbatim_doc_comment)]
    Policy(super::experiment_policy::PolicyExperimentArgs),
    /// Table 6.1: the learned arbiters (combined reward, environment-only
    /// reward; DDPG, the dissertation's chapter 6) beside direct control (no
    /// collision avoidance, as in the dissertation) with the users noisy-0.5,
    /// noisy-1.0, straight and biased (5 cm/s, 30 Hz) on the planar reach
    /// task: the gripper starts behind a pole and reaches the user's cylinder
    /// (1 cm) within 20 s. Reports success, collisions and travel
    /// (mean ± std), Fig. 6.4 (training curves over --train-seeds seeds)
    /// and Fig. 6.5 (distance of the executed command to the user's and to
    /// the predicted sub-policy over the episode). Trains the actors first
    /// unless --combined and --environment give them.
    ///
    /// Examples:
    ///   tandem experiment learned --episodes 100 --out results/
    ///   tandem experiment learned --combined c.safetensors --environment e.safetensors --json
    #[command(verbatim_doc_comment)]
    Learned(super::learned_arbitration::LearnedExperimentArgs),
    /// Table 7.3: traded control from predicted intent (the dissertation's
    /// chapter 7). A simulated person mimics reaching for one of three boxes
    /// on the table, from the top or the side (minimum-jerk hand motion at
    /// 180 Hz with trial-to-trial variability and a slow start; users Normal,
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
    /// (`episodes/<arm>-<task>.parquet`).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// What moves the arm: `kinematic` (tandem's simulator; success is the
    /// grasp judge's) or `mujoco` (MuJoCo physics, a build with `--features
    /// mujoco`; the fingers close and success is the box lifted 5 cm and
    /// held 1 s). See docs/physics.md.
    #[arg(long, default_value = "kinematic", value_parser = ["kinematic", "mujoco"])]
    pub physics: String,
    /// Control rate (Hz, 15 … 1000; default 15 as in §5.6 of the
    /// dissertation). Laggy operators lag by ticks, so their delay in
    /// seconds shrinks as the rate grows.
    #[arg(long, default_value_t = 15.0, value_parser = rate_hz)]
    pub rate: f64,
    /// With `--physics mujoco`: write the first task's MuJoCo scene (MJCF)
    /// here, for MuJoCo's viewer.
    #[arg(long, value_name = "FILE")]
    pub scene_xml: Option<PathBuf>,
    /// The arbiter's centres (constrained and sum-of-squares).
    #[command(flatten)]
    pub centers: super::arbiter_args::CenterArgs,
    #[command(flatten)]
    pub motion: super::arbiter_args::MotionLimitArgs,
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
    let settings = ReachGraspSettings {
        tasks: args.tasks as usize,
        seed: args.seed,
        arms,
        record_dir: args.out.as_ref().map(|d| d.join("episodes")),
        arbiter: args.motion.apply(args.centers.arbiter_settings(1.0 / args.rate)),
        simulator: match args.physics.as_str() {
            "mujoco" => Simulator::Mujoco(PhysicsSettings::default()),
            _ => Simulator::Kinematic,
        },
        ..ReachGraspSettings::default()
    };
    if let Some(path) = &args.scene_xml {
        write_scene_xml(&settings, path)?;
    }
    run_in_harness(&settings, args.threads, args.json, args.out.clone())
}

fn planar(args: &PlanarArgs) -> Result<(), Box<dyn std::error::Error>> {
    let settings = PlanarSettings { tasks: args.tasks as usize, seed: args.seed, ..PlanarSettings::default() };
    run_in_harness(&settings, args.threads, args.json, args.out.clone())
}

/// Writes the first task's MuJoCo scene to `path` (before the run, so a
/// bad path fails early).
fn write_scene_xml(settings: &ReachGraspSettings, path: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let Simulator::Mujoco(physics) = &settings.simulator else {
        return Err("--scene-xml needs --physics mujoco".into());
    };
    #[cfg(feature = "mujoco")]
    {
        let base = crate::problem::Problem::builtin("panda_grasp_box")?;
        let arm = settings.arms.first().copied().unwrap_or(crate::sim::Arm::Right);
        let task = crate::sim::sample_task(&base, arm, settings.seed, 0)?;
        let scene = crate::sim::mujoco::PhysicsScene::new(&task.goal.problem, settings.arbiter.period, physics)
            .map_err(|e| crate::experiments::ExperimentError::Physics(e.to_string()))?;
        std::fs::write(path, scene.mjcf()).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        eprintln!("wrote the MuJoCo scene of task 0 ({}) to {}", arm.as_str(), path.display());
        Ok(())
    }
    #[cfg(not(feature = "mujoco"))]
    {
        let _ = (physics, path);
        Err(crate::experiments::ExperimentError::Physics(
            "this tandem was built without MuJoCo: build with `--features mujoco` (see docs/physics.md)".into(),
        )
        .into())
    }
}

/// A control rate in Hz between 15 and 1000.
fn rate_hz(text: &str) -> Result<f64, String> {
    let rate: f64 = text.parse().map_err(|_| format!("'{text}' is not a number"))?;
    if (15.0..=1000.0).contains(&rate) { Ok(rate) } else { Err(format!("{rate} Hz is outside 15 … 1000")) }
}
