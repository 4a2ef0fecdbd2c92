//! MuJoCo's model of the robot against tandem's: MuJoCo compiles the same
//! URDF with its own compiler; the gripper frame's pose agrees over random
//! configurations within the limits (the arbiter and the physics see the
//! same arm).
#![cfg(feature = "mujoco")]

use rand::{RngExt, SeedableRng};
use tandem::robot::{KinematicsWorkspace, RobotModel};
use tandem::sim::mujoco::MujocoArm;

#[test]
fn mujoco_and_tandem_put_the_gripper_in_the_same_place() {
    let robot = RobotModel::panda();
    let arm = MujocoArm::from_robot(&robot, "panda_hand_tcp").unwrap();
    let gripper = robot.frame_id("panda_hand_tcp").unwrap();
    let mut data = arm.data();
    let mut ws = KinematicsWorkspace::new(&robot);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let (mut worst_position, mut worst_rotation) = (0.0_f64, 0.0_f64);
    for _ in 0..1000 {
        let q: Vec<f64> = robot.limits().iter().map(|l| l.lower + (l.upper - l.lower) * rng.random::<f64>()).collect();
        arm.set_configuration(&mut data, &q);
        let (position, rotation) = arm.gripper_pose(&mut data);
        robot.forward_kinematics(&mut ws, &q).unwrap();
        let pose = robot.frame_pose(&ws, gripper);
        for k in 0..3 {
            worst_position = common_worst(worst_position, (position[k] - pose.translation.vector[k]).abs());
            for c in 0..3 {
                // MuJoCo's xmat is row-major.
                worst_rotation = common_worst(worst_rotation, (rotation[3 * k + c] - pose.rotation[(k, c)]).abs());
            }
        }
    }
    println!("largest difference: position {worst_position:.2e} m, rotation {worst_rotation:.2e}");
    // Seen: 6.7e-16 m and 1.4e-15; asserted at about 100 times that.
    assert!(worst_position <= 1e-13, "position {worst_position}");
    assert!(worst_rotation <= 1e-13, "rotation {worst_rotation}");
}

/// The larger, NaN when either is.
fn common_worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}
