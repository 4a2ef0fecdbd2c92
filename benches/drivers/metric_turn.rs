//! Which way each robot policy's metric turns the gripper.
//!
//! `cargo run --release --example metric_turn [TASKS] [SEED] [POLICY]`
//! (default 40 tasks of seed 1001, the shipped policy). Along the LQR policy's episodes with the Approach
//! operator (the states are the same for both policies), each state with
//! the gripper's approach axis more than about 1° from the grasp's is
//! ticked through a constrained and a sum-of-squares arbiter (κ = 0, the
//! dissertation's) on the shipped learned policy and on the LQR policy.
//! For each command, and for each robot action alone, it prints the mean
//! cosine between the rate of change of the approach axis and the way to
//! the grasp's axis (1: straight there), the metrics' median condition
//! numbers, and how alike the two policies' metrics are at the same state
//! (mean Frobenius cosine of the repaired metrics' trace-free parts: 1
//! when they lean the same way, 0 when unrelated). docs/experiments.md quotes its output.

use std::sync::Arc;
use tandem::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationMode, GoalObjects, GoalSettings, HumanCommand, TickInput, problem_goals,
};
use tandem::control::RobotPolicy;
use tandem::learn::LearnedPolicy;
use tandem::learn::evaluate::{RolloutSettings, Task};
use tandem::problem::ProblemFamily;
use tandem::robot::{FrameId, KinematicsWorkspace, RobotModel};
use tandem::sim::{Approach, Episode, EpisodeSettings};

/// Mean cosines and conditions of one policy.
#[derive(Default)]
struct Tally {
    action: f64,
    commands: [f64; 2],
    conditions: [Vec<f64>; 2],
}

/// Cosine between the approach axis' rate of change under `u` at `q` and
/// the way to `axis` (0 when either is zero).
fn turn(
    robot: &RobotModel,
    kin: &mut KinematicsWorkspace,
    gripper: FrameId,
    q: &[f64],
    u: &[f64],
    axis: &nalgebra::Vector3<f64>,
) -> f64 {
    let dt = 1e-3;
    robot.forward_kinematics(kin, q).expect("a recorded configuration");
    let z = robot.frame_pose(kin, gripper).rotation.matrix().column(2).into_owned();
    let moved: Vec<f64> = q.iter().zip(u).map(|(a, b)| a + b * dt).collect();
    robot.forward_kinematics(kin, &moved).expect("a finite configuration");
    let z_next = robot.frame_pose(kin, gripper).rotation.matrix().column(2).into_owned();
    let rate = (z_next - z) / dt;
    let want = axis - z * z.dot(axis);
    if rate.norm() < 1e-9 || want.norm() < 1e-9 { 0.0 } else { rate.dot(&want) / (rate.norm() * want.norm()) }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let tasks: u64 = args.next().map_or(Ok(40), |a| a.parse())?;
    let seed: u64 = args.next().map_or(Ok(1001), |a| a.parse())?;
    let network = Arc::new(match args.next() {
        Some(path) => tandem::learn::PolicyNetwork::load(std::path::Path::new(&path))?,
        None => tandem::learn::shipped_policy()?,
    });
    let family = ProblemFamily::from_file(std::path::Path::new("problems/panda_grasp_family.toml"))?;
    let modes = [ArbitrationMode::Constrained, ArbitrationMode::SumOfSquares];
    let (mut learned, mut lqr, mut samples) = (Tally::default(), Tally::default(), 0usize);
    let mut alike = 0.0;
    for i in 0..tasks {
        let problem = family.sample(seed, i)?.problem;
        let task = Task::new(problem.clone(), RolloutSettings::default().max_tilt)?;
        let options = GoalSettings { seed: Some(seed), objects: GoalObjects::Goal, ..GoalSettings::default() };
        let Ok(goals) = problem_goals(&problem, &options) else { continue };
        let Some(target) = problem.grasp_target() else { continue };
        let network_policy: Arc<dyn RobotPolicy> = Arc::new(LearnedPolicy::for_problem(network.clone(), &problem)?);
        let lqr_policy: Arc<dyn RobotPolicy> = goals[0].policy.clone();
        let arbiters = |mode| -> Result<[Arbiter; 2], Box<dyn std::error::Error>> {
            let settings = ArbiterSettings { mode, ..ArbiterSettings::default() };
            let on_network = tandem::experiments::policy::learned_arbiter(&network, &task, settings)?;
            Ok([on_network, Arbiter::for_problem(&problem, &goals, settings)?])
        };
        let per_mode = [arbiters(modes[0])?, arbiters(modes[1])?];
        // The states: the LQR policy's constrained episode.
        let mut ws = per_mode[0][1].workspace();
        let episode = Episode {
            arbiter: &per_mode[0][1],
            start: &problem.start,
            target: target.translation.vector.into(),
            true_goal: 0,
            settings: EpisodeSettings { record: true, max_time: 20.0 },
        };
        let mut kin = KinematicsWorkspace::new(&problem.robot);
        let mut judge = |q: &[f64]| task.grasped(&mut kin, q, RolloutSettings::default().judge_radius).unwrap_or(false);
        let record = episode.run(&mut ws, &mut Approach::default(), &mut judge)?;
        let robot = &problem.robot;
        let gripper = robot.frame_id(task.gripper_name())?;
        let axis = target.rotation.matrix().column(2).into_owned();
        let mut workspaces: Vec<_> = per_mode.iter().flatten().map(|a| a.workspace()).collect();
        let (mut network_state, mut lqr_state) = (network_policy.new_workspace(), lqr_policy.new_workspace());
        let n = robot.nq();
        let mut action = vec![0.0; n];
        for t in (1..record.q.len().saturating_sub(1)).step_by(3) {
            let (q, velocity) = (&record.q[t], &record.qdot[t - 1]);
            robot.forward_kinematics(&mut kin, q)?;
            let z = robot.frame_pose(&kin, gripper).rotation.matrix().column(2).into_owned();
            if z.cross(&axis).norm() < 0.02 {
                continue;
            }
            samples += 1;
            network_policy.probe(&mut network_state, q, velocity, &mut action)?;
            learned.action += turn(robot, &mut kin, gripper, q, &action, &axis);
            lqr_policy.probe(&mut lqr_state, q, velocity, &mut action)?;
            lqr.action += turn(robot, &mut kin, gripper, q, &action, &axis);
            let input = TickInput {
                q,
                velocity: Some(velocity),
                command: HumanCommand::Linear(&record.human[t]),
                beliefs: None,
            };
            for (m, pair) in per_mode.iter().enumerate() {
                for (p, (arbiter, tally)) in pair.iter().zip([&mut learned, &mut lqr]).enumerate() {
                    let ws = &mut workspaces[2 * m + p];
                    let u = arbiter.tick(ws, &input).qdot.to_vec();
                    tally.commands[m] += turn(robot, &mut kin, gripper, q, &u, &axis);
                    tally.conditions[m].push(ws.metric().condition());
                }
                if m == 0 {
                    // Trace-free parts: the repaired metrics have mean
                    // eigenvalue 1, so `W − I` is the anisotropy that steers.
                    let shape = |w: &[f64]| -> Vec<f64> {
                        w.iter().enumerate().map(|(k, v)| if k % (n + 1) == 0 { v - 1.0 } else { *v }).collect()
                    };
                    let (a, b) = (shape(workspaces[0].metric().matrix()), shape(workspaces[1].metric().matrix()));
                    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
                    let norms = (dot(&a, &a) * dot(&b, &b)).sqrt();
                    alike += if norms > 0.0 { dot(&a, &b) / norms } else { 0.0 };
                }
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    println!("{samples} states of {tasks} tasks (seed {seed}) with the approach axis off the grasp's");
    println!("mean cosine of the approach axis' turn with the way to the grasp's axis:");
    for (name, tally) in [("learned", &mut learned), ("lqr", &mut lqr)] {
        let k = samples.max(1) as f64;
        println!(
            "  {name:<8} action alone {:.3}, constrained command {:.3}, sum-of-squares command {:.3}; median metric condition {:.1}",
            tally.action / k,
            tally.commands[0] / k,
            tally.commands[1] / k,
            median(&mut tally.conditions[0])
        );
    }
    println!(
        "  metrics alike (mean Frobenius cosine of W − I, learned against LQR): {:.3}",
        alike / samples.max(1) as f64
    );
    Ok(())
}
