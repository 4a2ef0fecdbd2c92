//! `tandem demo`: the main job on the embedded default robot.

use crate::robot::{KinematicsWorkspace, ReferenceFrame, RobotModel};
use nalgebra::Matrix6xX;
use std::time::Instant;

/// Arguments of `tandem demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Number of configurations in the elbow sweep (at least 2).
    #[arg(long, default_value_t = 7)]
    pub steps: usize,
}

/// The Panda's usual "ready" pose (rad).
pub const PANDA_READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

pub(super) fn run(args: &DemoArgs) -> Result<(), Box<dyn std::error::Error>> {
    let panda = RobotModel::panda();
    let tcp = panda.frame_id("panda_hand_tcp")?;
    let mut ws = KinematicsWorkspace::new(&panda);
    let mut jac = Matrix6xX::zeros(panda.nq());
    println!(
        "embedded Panda: {} active joints ({}), {} frames, gripper frame panda_hand_tcp",
        panda.nq(),
        panda.joint_names().join(", "),
        panda.frames().len()
    );
    println!("elbow (panda_joint4) sweep from the ready pose: tcp position (m), manipulability sqrt(det(J Jᵀ)):");
    let steps = args.steps.max(2);
    let elbow = panda.limits()[3];
    for s in 0..steps {
        let mut q = PANDA_READY;
        q[3] = elbow.lower + (elbow.upper - elbow.lower) * s as f64 / (steps - 1) as f64;
        panda.forward_kinematics(&mut ws, &q)?;
        let p = panda.frame_jacobian(&ws, tcp, ReferenceFrame::WorldAligned, &mut jac)?.translation.vector;
        let manip = (&jac * jac.transpose()).determinant().max(0.0).sqrt();
        println!(
            "  q4 = {:>7.4} rad  tcp = [{:>7.4}, {:>7.4}, {:>7.4}]  manipulability = {manip:.5}",
            q[3], p.x, p.y, p.z
        );
    }
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
    println!(
        "FK + tcp Jacobian: {per_call:.0} ns per call over {n} calls (checksum {checksum:.3}); see `cargo bench` for measured medians"
    );
    collision_sweep(steps)?;
    println!("planning, optimization, tracking and arbitration join this command as they land.");
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
