//! A shared-control loop around `Arbiter::tick`, as a teleoperation stack
//! runs it: prepare the goals once, then every control period read the
//! robot's state and the operator's command, tick, and send the joint
//! velocity to the robot.
//!
//! Here the robot is a perfect velocity integrator and the operator pushes
//! the gripper straight toward the box at 5 cm/s; on a real system the two
//! `// robot` lines are your driver's read and write. Run it with
//! `cargo run --release --example arbiter_loop` (docs/embedding.md walks
//! through it).

use tandem::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationMode, GoalSettings, HumanCommand, TickInput, problem_goals,
};
use tandem::problem::Problem;
use tandem::robot::KinematicsWorkspace;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Once, before the loop (milliseconds to seconds: planning and
    // optimizing a reference per goal, then its LQR policy).
    let problem = Problem::builtin("panda_grasp_box")?;
    let goals = problem_goals(&problem, &GoalSettings::default())?;
    let settings = ArbiterSettings::default();
    let period = settings.period; // s, the control period the limits assume
    let arbiter = Arbiter::for_problem(&problem, &goals, settings)?;
    let mut ws = arbiter.workspace(); // per-thread scratch: the tick allocates nothing
    ws.set_mode(ArbitrationMode::SumOfSquares); // the dissertation's SOS blending (`--mode sos`)

    let robot = arbiter.robot().clone();
    let mut kinematics = KinematicsWorkspace::new(&robot);
    let box_position = goals[0].position; // m, world frame
    let mut q = problem.start.clone(); // robot: read the joint positions (rad)
    let mut qdot = vec![0.0; q.len()];
    let mut command = [0.0; 3];
    for tick in 0..400 {
        // The operator: 5 cm/s toward the box, in world axes (m/s).
        robot.forward_kinematics(&mut kinematics, &q)?;
        let gripper = robot.frame_pose(&kinematics, arbiter.gripper_frame()).translation.vector;
        let to_box: Vec<f64> = (0..3).map(|k| box_position[k] - gripper[k]).collect();
        let distance = to_box.iter().map(|d| d * d).sum::<f64>().sqrt();
        if distance < 0.005 {
            println!("at the grasp after {tick} ticks ({:.2} s)", tick as f64 * period);
            return Ok(());
        }
        for k in 0..3 {
            command[k] = 0.05 * to_box[k] / distance;
        }

        let input = TickInput { q: &q, velocity: Some(&qdot), command: HumanCommand::Linear(&command), beliefs: None };
        let out = arbiter.tick(&mut ws, &input);
        if out.status.is_hold() {
            println!("tick {tick}: holding ({})", out.status.as_str());
        }
        qdot.copy_from_slice(out.qdot);
        for (qi, vi) in q.iter_mut().zip(out.qdot) {
            *qi += vi * period; // robot: send the joint velocities (rad/s)
        }
    }
    Err("the gripper did not reach the box in 400 ticks".into())
}
