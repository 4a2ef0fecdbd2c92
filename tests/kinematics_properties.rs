//! Jacobians against central finite differences, allocation-free hot paths,
//! and the structure of compiled models (held and mimic joints).

mod common;

use common::random_configurations;
use nalgebra::{Matrix3xX, Matrix6xX, Point3, Rotation3};
use std::sync::Arc;
use tandem::robot::{KinematicsWorkspace, MeshSearchPath, ReferenceFrame, RobotDescription, RobotModel};

#[global_allocator]
static GLOBAL: common::alloc::CountingAllocator = common::alloc::CountingAllocator;

use common::alloc::allocations;

/// A small tree robot exercising every joint kind, an oblique axis, a
/// prismatic joint, a mimic with multiplier and offset, and a branch.
const TREE_URDF: &str = r#"<robot name="tree">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/><link name="tool"/>
  <joint name="ja" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0.1 0 0.3" rpy="0.2 -0.1 0.4"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="1" effort="1"/></joint>
  <joint name="jb" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 0.2 0.1" rpy="1.0 0.3 0"/>
    <axis xyz="1 2 -0.5"/></joint>
  <joint name="jc" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0.3 0 0" rpy="0 0.5 0"/>
    <axis xyz="0 1 0"/><limit lower="-0.2" upper="0.4" velocity="1" effort="1"/></joint>
  <joint name="jd" type="revolute"><parent link="c"/><child link="d"/><origin xyz="0 0 0.25" rpy="0 0 0"/>
    <axis xyz="0 1 0"/><mimic joint="ja" multiplier="-0.7" offset="0.1"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <joint name="je" type="revolute"><parent link="a"/><child link="e"/><origin xyz="0 -0.2 0" rpy="0 0 1.2"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="jtool" type="fixed"><parent link="d"/><child link="tool"/><origin xyz="0.05 0.02 0.1" rpy="0.3 0.2 0.1"/></joint>
</robot>"#;

fn tree_model() -> RobotModel {
    let desc = RobotDescription::from_urdf_str(TREE_URDF, &MeshSearchPath::default()).unwrap();
    RobotModel::builder(Arc::new(desc)).build().unwrap()
}

/// Max difference between analytic Jacobians and central differences of the
/// frame pose over all frames of `model` at `configs`.
fn max_fd_error(model: &RobotModel, configs: &[Vec<f64>]) -> f64 {
    let h = 1e-6;
    let mut ws = KinematicsWorkspace::new(model);
    let mut jac = Matrix6xX::zeros(model.nq());
    let mut worst = 0.0f64;
    for q in configs {
        for frame in model.frame_ids() {
            model.forward_kinematics(&mut ws, q).unwrap();
            model.frame_jacobian(&ws, frame, ReferenceFrame::WorldAligned, &mut jac).unwrap();
            for k in 0..model.nq() {
                let mut qp = q.clone();
                qp[k] += h;
                model.forward_kinematics(&mut ws, &qp).unwrap();
                let plus = model.frame_pose(&ws, frame);
                qp[k] -= 2.0 * h;
                model.forward_kinematics(&mut ws, &qp).unwrap();
                let minus = model.frame_pose(&ws, frame);
                let dp = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
                // ω ≈ vee(skew(R₊ R₋ᵀ)) / 2h in world axes; the skew part keeps full
                // precision for tiny angles, where acos-based logs do not.
                let dr: Rotation3<f64> = plus.rotation * minus.rotation.inverse();
                let m = dr.matrix();
                let w = nalgebra::Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)])
                    / (4.0 * h);
                for i in 0..3 {
                    worst = common::worst(worst, (jac[(i, k)] - dp[i]).abs());
                    worst = common::worst(worst, (jac[(i + 3, k)] - w[i]).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn panda_jacobians_match_finite_differences() {
    let panda = RobotModel::panda();
    let err = max_fd_error(&panda, &random_configurations(&panda, 200, 11));
    println!("panda: max |J - FD| = {err:.2e}");
    assert!(err < 1e-8, "{err:e}");
}

#[test]
fn tree_with_mimic_and_prismatic_matches_finite_differences() {
    let tree = tree_model();
    assert_eq!(tree.joint_names(), ["ja", "jb", "jc", "je"]);
    let err = max_fd_error(&tree, &random_configurations(&tree, 200, 12));
    println!("tree: max |J - FD| = {err:.2e}");
    assert!(err < 1e-8, "{err:e}");
}

#[test]
fn local_jacobian_is_the_rotated_world_aligned_one() {
    let panda = RobotModel::panda();
    let mut ws = KinematicsWorkspace::new(&panda);
    let (mut world, mut local) = (Matrix6xX::zeros(7), Matrix6xX::zeros(7));
    let frame = panda.frame_id("panda_hand_tcp").unwrap();
    for q in random_configurations(&panda, 50, 13) {
        panda.forward_kinematics(&mut ws, &q).unwrap();
        panda.frame_jacobian(&ws, frame, ReferenceFrame::WorldAligned, &mut world).unwrap();
        panda.frame_jacobian(&ws, frame, ReferenceFrame::Local, &mut local).unwrap();
        let r = panda.frame_pose(&ws, frame).rotation;
        let back_lin = r.matrix() * local.fixed_rows::<3>(0);
        let back_ang = r.matrix() * local.fixed_rows::<3>(3);
        assert!(common::max_abs((back_lin - world.fixed_rows::<3>(0)).iter().copied()) < 1e-12);
        assert!(common::max_abs((back_ang - world.fixed_rows::<3>(3)).iter().copied()) < 1e-12);
    }
}

#[test]
fn point_jacobian_matches_finite_differences() {
    let panda = RobotModel::panda();
    let mut ws = KinematicsWorkspace::new(&panda);
    let frame = panda.frame_id("panda_link6").unwrap();
    let point = Point3::new(0.05, -0.02, 0.11);
    let mut jac = Matrix3xX::zeros(7);
    let h = 1e-6;
    for q in random_configurations(&panda, 100, 14) {
        panda.forward_kinematics(&mut ws, &q).unwrap();
        let world = panda.point_jacobian(&ws, frame, &point, &mut jac).unwrap();
        assert!((world - panda.frame_pose(&ws, frame) * point).norm() < 1e-15);
        for k in 0..7 {
            let mut qp = q.clone();
            qp[k] += h;
            panda.forward_kinematics(&mut ws, &qp).unwrap();
            let plus = panda.frame_pose(&ws, frame) * point;
            qp[k] -= 2.0 * h;
            panda.forward_kinematics(&mut ws, &qp).unwrap();
            let minus = panda.frame_pose(&ws, frame) * point;
            let fd = (plus - minus) / (2.0 * h);
            assert!(common::max_abs((jac.column(k) - fd).iter().copied()) < 1e-8);
        }
    }
}

#[test]
fn held_joints_are_folded_at_their_values() {
    let desc = Arc::new(RobotDescription::panda());
    let full = RobotModel::builder(desc.clone()).build().unwrap();
    assert_eq!(full.nq(), 8, "7 arm joints and finger 1 (finger 2 mimics it)");
    let arm = RobotModel::panda();
    let finger = arm.frame_id("panda_rightfinger").unwrap();
    let (mut ws_full, mut ws_arm) = (KinematicsWorkspace::new(&full), KinematicsWorkspace::new(&arm));
    for q in random_configurations(&arm, 20, 15) {
        let mut qf = q.clone();
        qf.push(0.04);
        full.forward_kinematics(&mut ws_full, &qf).unwrap();
        arm.forward_kinematics(&mut ws_arm, &q).unwrap();
        let a = full.frame_pose(&ws_full, full.frame_id("panda_rightfinger").unwrap());
        let b = arm.frame_pose(&ws_arm, finger);
        assert!(common::max_abs((a.to_homogeneous() - b.to_homogeneous()).iter().copied()) < 1e-14);
    }
    let values = arm.all_joint_values(&arm.neutral_configuration()).unwrap();
    let j2 = desc.joints().iter().position(|j| j.name == "panda_finger_joint2").unwrap();
    assert_eq!(values[j2], 0.04, "the mimic finger follows the held finger");
}

#[test]
fn hot_paths_do_not_allocate() {
    let panda = RobotModel::panda();
    let mut ws = KinematicsWorkspace::new(&panda);
    let configs = random_configurations(&panda, 100, 16);
    let mut jac = Matrix6xX::zeros(7);
    let mut pjac = Matrix3xX::zeros(7);
    let frame = panda.frame_id("panda_hand_tcp").unwrap();
    let point = Point3::new(0.0, 0.0, 0.05);
    let before = allocations();
    let mut sink = 0.0;
    for q in &configs {
        panda.forward_kinematics(&mut ws, q).unwrap();
        panda.update_frame_placements(&mut ws);
        sink += panda.frame_pose(&ws, frame).translation.x;
        panda.frame_jacobian(&ws, frame, ReferenceFrame::WorldAligned, &mut jac).unwrap();
        panda.frame_jacobian(&ws, frame, ReferenceFrame::Local, &mut jac).unwrap();
        sink += panda.point_jacobian(&ws, frame, &point, &mut pjac).unwrap().x;
    }
    let made = allocations() - before;
    assert!(sink.is_finite());
    assert_eq!(made, 0, "kinematics allocated {made} times over 100 configurations");
}

#[test]
fn model_is_send_and_sync() {
    fn shareable<T: Send + Sync>() {}
    shareable::<RobotModel>();
    shareable::<RobotDescription>();
    shareable::<KinematicsWorkspace>();
}

#[test]
fn error_folds_keep_nan() {
    // `f64::max` drops a NaN: errors folded with it passed a NaN kinematics.
    assert_eq!([1e-16, f64::NAN].into_iter().fold(0.0, f64::max), 1e-16);
    let folded = common::max_abs([1e-16, f64::NAN, -2e-16]);
    assert!(folded.is_nan() && folded.partial_cmp(&1e-9).is_none(), "a NaN error fails every tolerance");
    assert!(common::worst(f64::NAN, 0.0).is_nan() && common::worst(0.0, f64::NAN).is_nan());
    assert_eq!(common::max_abs([1e-16, -3e-16]), 3e-16);
}
