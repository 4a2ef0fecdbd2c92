//! `tandem demo`: the main job on the embedded default robot.

use crate::robot::{KinematicsWorkspace, ReferenceFrame, RobotModel};
use nalgebra::Matrix6xX;
use std::time::Instant;

/// Arguments of `tandem demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Number of configurations in the forward lean (panda_joint2 from the
    /// start to 1.9 rad further), 2 to 1000.
    #[arg(long, default_value_t = 7, value_parser = |s: &str| super::number_in(s, 2usize..=1000))]
    pub steps: usize,
    /// Folder for the optimized trajectory (CSV, Parquet) and its plots
    /// (joints.svg, path.svg).
    #[arg(long, value_name = "DIR", default_value = "tandem-demo")]
    pub out: std::path::PathBuf,
}

/// The Panda's usual "ready" pose (rad).
pub const PANDA_READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

pub(super) fn run(args: &DemoArgs) -> Result<(), Box<dyn std::error::Error>> {
    let panda = RobotModel::panda();
    println!(
        "embedded Panda: {} active joints ({}), {} frames, gripper frame panda_hand_tcp",
        panda.nq(),
        panda.joint_names().join(", "),
        panda.frames().len()
    );
    kinematics_timing(&panda)?;
    collision_sweep(args.steps)?;
    reach_and_grasp(&args.out)?;
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
    let problem = crate::scene::Problem::builtin("panda_grasp_box")?;
    println!(
        "\nreach and grasp ({}): plan with RRT-Connect, then optimize {} slices:",
        problem.name, problem.optimizer.horizon
    );
    let solution = crate::komo::solve_problem(&problem, &crate::komo::SolveOptions::default())?;
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
    }
    super::solve::write_outputs(&problem, &solution, out)?;
    println!("wrote trajectory.csv, trajectory.parquet, joints.svg and path.svg to {}", out.display());
    Ok(())
}

/// The embedded reach-and-grasp problem: clearance along the elbow sweep.
fn collision_sweep(steps: usize) -> Result<(), Box<dyn std::error::Error>> {
    let problem = crate::scene::Problem::builtin("panda_grasp_box")?;
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
        let is_scene = |pair: usize| problem.robot.description().link(model.pair_names(pair).1).is_none();
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
