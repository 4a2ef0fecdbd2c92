//! `tandem demo`: the main job on the embedded default robot — shared
//! control of a reach-and-grasp, then the reference behind it and where
//! the files are.

use crate::robot::{KinematicsWorkspace, ReferenceFrame, RobotModel};
use nalgebra::Matrix6xX;
use std::time::Instant;

/// Arguments of `tandem demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Folder for the figures (shared_control.svg, path.svg, joints.svg)
    /// and the optimized reference (trajectory.csv, trajectory.parquet).
    #[arg(long, value_name = "DIR", default_value = "tandem-demo")]
    pub out: std::path::PathBuf,
    /// Also time forward kinematics and the gripper Jacobian, and print the
    /// clearance to the table and the box along a forward lean.
    #[arg(long)]
    pub verbose: bool,
    /// With --verbose: configurations in the forward lean (panda_joint2
    /// from the start to 1.9 rad further), 2 to 1000.
    #[arg(long, default_value_t = 7, value_parser = |s: &str| super::number_in(s, 2usize..=1000))]
    pub steps: usize,
}

/// The Panda's usual "ready" pose (rad).
pub const PANDA_READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

pub(super) fn run(args: &DemoArgs) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(&args.out).map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    println!(
        "tandem demo: a Franka Panda reaches for a 6 × 6 × 12 cm box on a table. A simulated operator\n\
         steers only the gripper's linear velocity; every tick, the arbiter blends that command with\n\
         an LQR policy tracking an optimized grasp, under joint limits, distances and certified steps."
    );
    let figure = shared_control(&args.out)?;
    reach_and_grasp(&args.out)?;
    if args.verbose {
        let panda = RobotModel::panda();
        println!(
            "\nembedded Panda: {} active joints ({}), {} frames, gripper frame panda_hand_tcp",
            panda.nq(),
            panda.joint_names().join(", "),
            panda.frames().len()
        );
        kinematics_timing(&panda)?;
        collision_sweep(args.steps)?;
    }
    println!("\nopen {} (the gripper's path under each mode, top and side views)", figure.display());
    Ok(())
}

/// FK + gripper Jacobian per call, averaged (criterion benches give medians).
fn kinematics_timing(panda: &RobotModel) -> Result<(), Box<dyn std::error::Error>> {
    let tcp = panda.frame_id("panda_hand_tcp")?;
    let mut ws = KinematicsWorkspace::new(panda);
    let mut jac = Matrix6xX::zeros(panda.nq());
    let n = 200_000;
    let start = Instant::now();
    let mut checksum = 0.0;
    for i in 0..n {
        let mut q = PANDA_READY;
        q[1] += 1e-6 * i as f64;
        panda.forward_kinematics(&mut ws, &q)?;
        panda.frame_jacobian(&ws, tcp, ReferenceFrame::WorldAligned, &mut jac)?;
        checksum += jac[(2, 1)];
    }
    let per_call = start.elapsed().as_secs_f64() / f64::from(n) * 1e9;
    println!("FK + gripper Jacobian: {per_call:.0} ns per call over {n} calls (checksum {checksum:.3})");
    Ok(())
}

/// The seed's reach-and-grasp task end to end: RRT-Connect, trajectory
/// optimization, checks of the result, files and plots.
fn reach_and_grasp(out: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let problem = crate::problem::Problem::builtin("panda_grasp_box")?;
    println!(
        "\nthe robot's reference ({}): planned with RRT-Connect, then optimized over {} slices:",
        problem.name, problem.optimizer.horizon
    );
    let solution = crate::pipeline::solve_problem(&problem, &crate::pipeline::SolveSettings::default())?;
    super::solve::print_summary(&problem, &solution, None);
    if let (Some(last), Some(target)) = (solution.trajectory.last(), problem.grasp_target()) {
        let robot = &problem.robot;
        let mut ws = KinematicsWorkspace::new(robot);
        robot.forward_kinematics(&mut ws, last)?;
        let pose = robot.frame_pose(&ws, robot.frame_id("panda_hand_tcp")?);
        let miss = (pose.translation.vector - target.translation.vector).norm();
        let tilt = (pose.rotation * nalgebra::Vector3::z()).angle(&-nalgebra::Vector3::z());
        println!(
            "final gripper pose: {:.3} mm from the grasp point, {:.3} mrad from pointing down",
            miss * 1e3,
            tilt * 1e3
        );
        let judge = crate::problem::GraspJudge::new(&problem)?;
        let criteria = crate::problem::GraspCriteria::default();
        if let Some(object) = problem.scene.object("box") {
            let g = judge.judge(&mut ws, last, object, &criteria)?;
            println!(
                "grasp (sphere model): box between the finger pads: {}, palm {:.1} mm and fingers {:.1} mm from it: {}",
                if g.between_pads { "yes" } else { "no" },
                g.palm_clearance * 1e3,
                g.finger_clearance * 1e3,
                g.failure(&criteria).unwrap_or_else(|| "a grasp".into())
            );
        }
    }
    super::solve::write_outputs(&problem, &solution, out)?;
    println!("wrote trajectory.csv, trajectory.parquet, joints.svg and path.svg to {}", out.display());
    Ok(())
}

/// The embedded reach-and-grasp problem: clearance along the elbow sweep.
fn collision_sweep(steps: usize) -> Result<(), Box<dyn std::error::Error>> {
    let problem = crate::problem::Problem::builtin("panda_grasp_box")?;
    let model = problem.collision_model()?;
    let mut ws = crate::collision::CollisionWorkspace::new(&model);
    println!(
        "problem {}: {} ({} object pairs checked); leaning forward (panda_joint2), the closest scene object:",
        problem.name,
        problem.description,
        model.pair_count()
    );
    for s in 0..steps {
        // Leaning forward from the start: the gripper comes down to the table.
        let mut q = problem.start.clone();
        q[1] += 1.9 * s as f64 / (steps - 1) as f64;
        let free = model.collision_free(&mut ws, &q)?;
        // The scene's clearance, not the arm's own (self pairs are in the check above).
        let is_scene = |pair: usize| {
            !matches!(model.object_source(model.pair_objects(pair).1), crate::collision::ObjectSource::RobotLink { .. })
        };
        let closest = model
            .distances(&mut ws, &q, f64::INFINITY)?
            .iter()
            .filter(|d| is_scene(d.pair))
            .min_by(|x, y| x.signed.distance.total_cmp(&y.signed.distance));
        if let Some(d) = closest {
            let (a, b) = model.pair_names(d.pair);
            let state = if free { "free     " } else { "COLLISION" };
            println!("  q2 = {:>7.4} rad  {state}  {:>7.4} m between {a} and {b}", q[1], d.signed.distance);
        }
    }
    Ok(())
}

/// The task under shared control: an Approach operator (linear velocity
/// only, 10 cm/s) drives the arm through each arbitration mode at 15 Hz;
/// the robot's LQR policy tracks the optimized reference. Returns the
/// figure written.
fn shared_control(out: &std::path::Path) -> Result<std::path::PathBuf, Box<dyn std::error::Error>> {
    use crate::arbitration::{Arbiter, ArbiterSettings, ArbitrationMode, GoalSettings, problem_goals};
    use crate::sim::{Approach, Episode, EpisodeSettings, TaskJudge, percentiles};
    let problem = crate::problem::Problem::builtin("panda_grasp_box")?;
    let goals = problem_goals(&problem, &GoalSettings::default())?;
    println!("\none episode per arbitration mode (Approach operator, 10 cm/s, 15 Hz):");
    println!(
        "  {:<24} {:>9} {:>6} {:>11} {:>9} {:>11} {:>11}  why",
        "mode", "outcome", "ticks", "median µs", "p99 µs", "violations", "clearance"
    );
    let mut paths = vec![];
    for mode in ArbitrationMode::ALL {
        let arbiter = Arbiter::for_problem(&problem, &goals, ArbiterSettings { mode, ..ArbiterSettings::default() })?;
        let mut ws = arbiter.workspace();
        let mut judge = TaskJudge::new(&goals[0]);
        let episode = Episode {
            arbiter: &arbiter,
            start: &problem.start,
            target: goals[0].position,
            true_goal: 0,
            settings: EpisodeSettings::default(),
        };
        let record = episode.run(&mut ws, &mut Approach::default(), &mut judge)?;
        let (median, p99, _) = percentiles(&record.tick_us);
        println!(
            "  {:<24} {:>9} {:>6} {median:>11.1} {p99:>9.1} {:>11} {:>9.1} mm  {}",
            mode.as_str(),
            record.outcome.as_str(),
            record.steps,
            record.hard_violations,
            record.min_clearance * 1e3,
            record.reason
        );
        paths.push((mode, record.outcome, record.gripper));
    }
    let corners = problem.scene.object("box").map(|o| o.silhouette_points()).unwrap_or_default();
    let svg = shared_control_svg(&paths, goals[0].position, &corners)?;
    let path = out.join("shared_control.svg");
    std::fs::write(&path, svg).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!(
        "  (the operator never turns the gripper: modes that read the robot policy's metric or action\n   \
         fix its orientation; direct control and obstacle avoidance leave it as it was.)\n  \
         median / p99 µs: the arbiter's tick; violations: executed steps past a hard limit; clearance:\n  \
         the smallest distance to anything over the episode."
    );
    Ok(path)
}

/// Top and side views of the gripper path under each mode, the box's
/// outline (`corners`, world) and the grasp point; a path within 1 mm of
/// an earlier one all along is named after it, as it hides under it.
fn shared_control_svg(
    paths: &[(crate::arbitration::ArbitrationMode, crate::sim::Outcome, Vec<[f64; 3]>)],
    goal: [f64; 3],
    corners: &[[f64; 3]],
) -> Result<String, Box<dyn std::error::Error>> {
    use crate::experiments::figures::{episode_path, outcome_legend};
    use crate::figures::{Color, Marker, Panel, Series, render_panels};
    let same_as = |k: usize| {
        let path = &paths[k].2;
        paths[..k].iter().find(|(_, _, other)| {
            other.len() == path.len()
                && other.iter().zip(path).all(|(a, b)| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>() < 1e-6)
        })
    };
    let labels: Vec<String> = (0..paths.len())
        .map(|k| match same_as(k) {
            Some((mode, ..)) => format!("{} (the path of {})", paths[k].0.as_str(), mode.as_str()),
            None => paths[k].0.as_str().to_string(),
        })
        .collect();
    let view = |a: usize, b: usize, title: &str, y: &str| {
        let project = |p: &[f64; 3]| (p[a], p[b]);
        let mut panel = Panel::new(title, "x (m)", y)
            .with(Series::outline("box", &corners.iter().map(project).collect::<Vec<_>>()));
        for (k, (_, outcome, path)) in paths.iter().enumerate() {
            let points: Vec<(f64, f64)> = path.iter().map(project).collect();
            panel = episode_path(panel, &labels[k], &points, k, *outcome);
        }
        let start: Vec<(f64, f64)> = paths.first().and_then(|p| p.2.first()).map(project).into_iter().collect();
        outcome_legend(panel, paths.iter().map(|p| p.1))
            .with(Series::markers("start", &start, Color::Reference, Marker::Dot))
            .with(Series::markers("grasp point", &[project(&goal)], Color::Reference, Marker::Ring))
            .equal()
    };
    Ok(render_panels(
        "panda_grasp_box under shared control: gripper paths (Approach operator)",
        &[view(0, 1, "from above", "y (m)"), view(0, 2, "from the side", "z (m)")],
        520,
        480,
    )?)
}
