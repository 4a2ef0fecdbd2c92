//! Live cross-check of forward kinematics and frame Jacobians against
//! Pinocchio (python_ref/pin_reference.py) on 1000 seeded random
//! configurations per robot: every frame's placement and its world-aligned
//! and local Jacobians agree to 3e-13 (about 100 times the largest error
//! seen, 3.1e-15; NaN fails).

mod common;

use common::{ErdRobots, max_abs, random_configurations, read_f64_file, run_python, worst};
use nalgebra::Matrix6xX;
use std::path::Path;
use std::sync::Arc;
use tandem::robot::{FrameKind, KinematicsWorkspace, MeshSearchPath, ReferenceFrame, RobotDescription, RobotModel};

/// Configurations per arm; the large humanoid trees use fewer to keep the
/// reference output small (hundreds of frames × 40 joints each).
const CONFIGURATIONS: usize = 1000;
const TREE_CONFIGURATIONS: usize = 100;
const TOLERANCE: f64 = 3e-13;

/// For each movable description joint: the active column driving it and the
/// combined mimic multiplier.
fn column_map(model: &RobotModel) -> Vec<(String, usize, f64)> {
    let desc = model.description();
    let joints = desc.joints();
    let mut out = Vec::new();
    for (i, j) in joints.iter().enumerate() {
        if !j.kind.is_movable() {
            continue;
        }
        let (mut root, mut mult) = (i, 1.0);
        while let Some(m) = &joints[root].mimic {
            mult *= m.multiplier;
            root = m.joint;
        }
        let col = model.active_joint_indices().iter().position(|&a| a == root).expect("all independent joints active");
        out.push((j.name.clone(), col, mult));
    }
    out
}

fn cross_check(label: &str, urdf: &Path, search: &MeshSearchPath, seed: u64) {
    cross_check_n(label, urdf, search, seed, CONFIGURATIONS);
}

fn cross_check_n(label: &str, urdf: &Path, search: &MeshSearchPath, seed: u64, count: usize) {
    let desc = Arc::new(RobotDescription::from_urdf_file(urdf, search).unwrap());
    let model = RobotModel::builder(desc.clone()).build().unwrap();
    let configs = random_configurations(&model, count, seed);
    let columns = column_map(&model);
    let all_values: Vec<Vec<f64>> = configs
        .iter()
        .map(|q| {
            let v = model.all_joint_values(q).unwrap();
            desc.joints().iter().zip(v).filter(|(j, _)| j.kind.is_movable()).map(|(_, v)| v).collect()
        })
        .collect();
    let frames: Vec<serde_json::Value> = model
        .frames()
        .iter()
        .map(|f| serde_json::json!({"name": f.name, "kind": if f.kind == FrameKind::Link {"link"} else {"joint"}}))
        .collect();
    let out = tempfile::NamedTempFile::new().unwrap();
    let request = serde_json::json!({
        "urdf": urdf, "joints": columns.iter().map(|c| &c.0).collect::<Vec<_>>(),
        "frames": frames, "q": all_values, "output": out.path(),
    });
    run_python("pin_reference.py", &["kinematics"], &request.to_string());
    let reference = read_f64_file(out.path());
    let (n_pin, nq, nf) = (columns.len(), model.nq(), model.frames().len());
    let per_frame = 12 + 12 * n_pin;
    assert_eq!(reference.len(), count * nf * per_frame, "{label}: reference size");

    let mut ws = KinematicsWorkspace::new(&model);
    let mut jac = Matrix6xX::zeros(nq);
    let (mut max_pose, mut max_jac) = (0.0f64, 0.0f64);
    for (c, q) in configs.iter().enumerate() {
        model.forward_kinematics(&mut ws, q).unwrap();
        for (f, id) in model.frame_ids().enumerate() {
            let r = &reference[(c * nf + f) * per_frame..][..per_frame];
            let pose = model.frame_pose(&ws, id);
            let rot = pose.rotation.matrix();
            for i in 0..3 {
                for k in 0..3 {
                    max_pose = worst(max_pose, (rot[(i, k)] - r[3 * i + k]).abs());
                }
                max_pose = worst(max_pose, (pose.translation.vector[i] - r[9 + i]).abs());
            }
            for (block, reference_frame) in
                [ReferenceFrame::WorldAligned, ReferenceFrame::Local].into_iter().enumerate()
            {
                model.frame_jacobian(&ws, id, reference_frame, &mut jac).unwrap();
                let pin_j = &r[12 + block * 6 * n_pin..][..6 * n_pin];
                let mut expected = Matrix6xX::<f64>::zeros(nq);
                for (p, (_, col, mult)) in columns.iter().enumerate() {
                    for row in 0..6 {
                        expected[(row, *col)] += mult * pin_j[row * n_pin + p];
                    }
                }
                max_jac = worst(max_jac, max_abs((&jac - &expected).iter().copied()));
            }
        }
    }
    println!("{label}: {count} configurations × {nf} frames: max |Δpose| = {max_pose:.2e}, max |ΔJ| = {max_jac:.2e}");
    assert!(max_pose < TOLERANCE, "{label}: placement error {max_pose:e}");
    assert!(max_jac < TOLERANCE, "{label}: Jacobian error {max_jac:e}");
}

#[test]
fn embedded_panda_matches_pinocchio() {
    let urdf = common::repo().join("problems/robots/panda/panda.urdf");
    cross_check("tandem panda", &urdf, &MeshSearchPath::default(), 1);
}

#[test]
fn example_robot_data_panda_matches_pinocchio() {
    let erd = ErdRobots::load();
    cross_check("erd panda", &erd.urdf("panda"), &MeshSearchPath::new([erd.package_dir.clone()]), 2);
}

#[test]
fn ur10_matches_pinocchio() {
    let erd = ErdRobots::load();
    cross_check("erd ur10", &erd.urdf("ur10"), &MeshSearchPath::new([erd.package_dir.clone()]), 3);
}

#[test]
fn so100_matches_pinocchio() {
    let erd = ErdRobots::load();
    cross_check("erd so100", &erd.urdf("so100"), &MeshSearchPath::new([erd.package_dir.clone()]), 4);
}

#[test]
fn continuous_double_pendulum_matches_pinocchio() {
    let erd = ErdRobots::load();
    cross_check(
        "erd double pendulum (continuous)",
        &erd.urdf("double_pendulum_continuous"),
        &MeshSearchPath::new([erd.package_dir.clone()]),
        5,
    );
}

#[test]
fn talos_humanoid_tree_matches_pinocchio() {
    let erd = ErdRobots::load();
    cross_check_n(
        "erd talos (tree)",
        &erd.urdf("talos"),
        &MeshSearchPath::new([erd.package_dir.clone()]),
        6,
        TREE_CONFIGURATIONS,
    );
}

#[test]
fn pr2_with_prismatic_continuous_and_mimic_joints_matches_pinocchio() {
    let erd = ErdRobots::load();
    cross_check_n("erd pr2", &erd.urdf("pr2"), &MeshSearchPath::new([erd.package_dir.clone()]), 7, TREE_CONFIGURATIONS);
}

/// Our Panda is written from Franka's published parameters; its frames must
/// coincide with example-robot-data's Panda wherever both name a frame.
#[test]
fn embedded_panda_frames_match_example_robot_data_panda() {
    let erd = ErdRobots::load();
    let theirs =
        RobotDescription::from_urdf_file(erd.urdf("panda"), &MeshSearchPath::new([erd.package_dir.clone()])).unwrap();
    let theirs = RobotModel::builder(Arc::new(theirs)).build().unwrap();
    let ours = RobotModel::builder(Arc::new(RobotDescription::panda())).build().unwrap();
    assert_eq!(ours.joint_names(), theirs.joint_names());
    let shared: Vec<_> = ours
        .frame_ids()
        .filter_map(|f| theirs.frame_id(ours.frame_name(f)).ok().map(|g| (f, g)))
        .filter(|&(f, g)| ours.frames()[f.index()].kind == theirs.frames()[g.index()].kind)
        .collect();
    assert!(shared.len() >= 20, "only {} shared frames", shared.len());
    let (mut wa, mut wb) = (KinematicsWorkspace::new(&ours), KinematicsWorkspace::new(&theirs));
    let mut largest = 0.0f64;
    for q in random_configurations(&ours, CONFIGURATIONS, 8) {
        ours.forward_kinematics(&mut wa, &q).unwrap();
        theirs.forward_kinematics(&mut wb, &q).unwrap();
        for &(f, g) in &shared {
            let d = ours.frame_pose(&wa, f).to_homogeneous() - theirs.frame_pose(&wb, g).to_homogeneous();
            largest = worst(largest, max_abs(d.iter().copied()));
        }
    }
    println!("tandem vs example-robot-data Panda: {} shared frames, max |Δ| = {largest:.2e}", shared.len());
    assert!(largest < TOLERANCE, "{largest:e}");
}
