//! Checking that the robot on the ROS 2 system is the arm the arbiter
//! models: the URDF published on `/robot_description` (as MoveIt reads it)
//! against the problem's robot — the same active joints with the same
//! limits, and the same gripper pose over random configurations. A
//! mismatch stops the node before it commands anything.

use crate::robot::{FrameId, KinematicsWorkspace, MeshSearchPath, RobotDescription, RobotModel};
use rand::{RngExt, SeedableRng};

/// The largest URDF read from `/robot_description` (bytes, 4 MiB): the
/// Panda's is 30 KB and large robots' some hundreds of KB; a 60 MB one
/// took 7 s and 611 MB of memory to parse. Larger is refused with its size.
pub const MAX_ROBOT_DESCRIPTION_BYTES: usize = 4 << 20;

/// Configurations whose gripper poses are compared.
const SAMPLES: usize = 200;
/// Largest gripper position difference accepted (m) and rotation (the
/// largest entry of the rotation matrices' difference).
const POSE_TOLERANCE: f64 = 1e-9;

/// The URDF `text` read as the robot it describes, collision and visual
/// geometry left out (their `package://` meshes are on the robot's
/// machine, not necessarily here; only the kinematics is compared).
fn kinematics_only(text: &str) -> Result<RobotDescription, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not XML: {e}"))?;
    let mut out = text.to_string();
    let mut ranges: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("collision") || n.has_tag_name("visual"))
        .map(|n| n.range())
        .collect();
    // From the end, so that earlier ranges keep their offsets.
    ranges.sort_by_key(|r| std::cmp::Reverse(r.start));
    for range in ranges {
        out.replace_range(range, "");
    }
    RobotDescription::from_urdf_str(&out, &MeshSearchPath::default()).map_err(|e| e.to_string())
}

/// Compares the published URDF `text` with `model` (whose gripper frame is
/// `gripper`).
///
/// # Errors
/// What differs, naming the joint, the limit or the configuration, or a
/// text larger than [`MAX_ROBOT_DESCRIPTION_BYTES`]: the node must not start.
pub fn check_robot_description(model: &RobotModel, gripper: FrameId, text: &str) -> Result<(), String> {
    if text.len() > MAX_ROBOT_DESCRIPTION_BYTES {
        return Err(format!(
            "the description is {} bytes, more than the limit of {MAX_ROBOT_DESCRIPTION_BYTES} bytes",
            text.len()
        ));
    }
    let description = kinematics_only(text)?;
    let names = model.joint_names();
    let theirs = RobotModel::builder(std::sync::Arc::new(description))
        .active_joints(names.iter().cloned())
        .build()
        .map_err(|e| format!("it lacks the arm's joints: {e}"))?;
    let gripper_name = model.frame_name(gripper);
    let their_gripper =
        theirs.frame_id(gripper_name).map_err(|_| format!("it has no frame {gripper_name} (the gripper)"))?;
    for ((name, ours), theirs) in names.iter().zip(model.limits()).zip(theirs.limits()) {
        for (what, a, b) in [
            ("lower limit", ours.lower, theirs.lower),
            ("upper limit", ours.upper, theirs.upper),
            ("velocity limit", ours.velocity, theirs.velocity),
        ] {
            if a != b && !(a.is_infinite() && a == b) {
                return Err(format!("joint {name}: {what} {b} there, {a} in the problem's robot"));
            }
        }
    }
    let mut ours_ws = KinematicsWorkspace::new(model);
    let mut theirs_ws = KinematicsWorkspace::new(&theirs);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let mut q = vec![0.0; names.len()];
    for _ in 0..SAMPLES {
        for (v, l) in q.iter_mut().zip(model.limits()) {
            let (lo, hi) = (l.lower.max(-std::f64::consts::PI), l.upper.min(std::f64::consts::PI));
            *v = lo + (hi - lo) * rng.random::<f64>();
        }
        model.forward_kinematics(&mut ours_ws, &q).map_err(|e| e.to_string())?;
        theirs.forward_kinematics(&mut theirs_ws, &q).map_err(|e| e.to_string())?;
        let a = model.frame_pose(&ours_ws, gripper);
        let b = theirs.frame_pose(&theirs_ws, their_gripper);
        let dp = (a.translation.vector - b.translation.vector).norm();
        let dr = (a.rotation.matrix() - b.rotation.matrix()).amax();
        if !(dp <= POSE_TOLERANCE && dr <= POSE_TOLERANCE) {
            return Err(format!(
                "the gripper ({gripper_name}) is {dp:.3e} m and {dr:.3e} (rotation) away from the problem's robot's at q = {q:?}"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_panda_matches_itself_and_an_edited_copy_is_named() {
        let model = RobotModel::panda();
        let gripper = model.frame_id("panda_hand_tcp").unwrap();
        let urdf = RobotDescription::panda().embedded_urdf().unwrap();
        check_robot_description(&model, gripper, urdf).unwrap();
        let slower = urdf.replacen("velocity=\"2.175\"", "velocity=\"1.0\"", 1);
        assert_ne!(slower, urdf);
        let e = check_robot_description(&model, gripper, &slower).unwrap_err();
        assert!(e.contains("panda_joint1: velocity limit 1 there, 2.175"), "{e}");
        let longer = urdf.replacen("0.333", "0.343", 1);
        assert_ne!(longer, urdf);
        let e = check_robot_description(&model, gripper, &longer).unwrap_err();
        assert!(e.contains("panda_hand_tcp") && e.contains("m and"), "{e}");
        let e = check_robot_description(&model, gripper, "<robot name='x'><link name='a'/></robot>").unwrap_err();
        assert!(e.contains("lacks the arm's joints"), "{e}");
        assert!(check_robot_description(&model, gripper, "not xml <").unwrap_err().contains("not XML"));
        let padded = format!("{urdf}<!-- {} -->", "x".repeat(MAX_ROBOT_DESCRIPTION_BYTES));
        let e = check_robot_description(&model, gripper, &padded).unwrap_err();
        assert!(e.contains(&format!("{} bytes, more than the limit of 4194304", padded.len())), "{e}");
    }
}
