//! Robots far larger than an arm: a 10,000-link chain compiles, gives
//! exact forward kinematics and prints (the recursive model compiler and
//! `inspect` tree overflowed the stack), and collision models of long
//! chains and a humanoid-like tree are built with memory growing as the
//! pair count, not as its cube (listing every pair's movers took O(n⁴)
//! time and O(n³) memory: 700 MB for 1,000 links).

mod common;
#[path = "../benches/support/large_robots.rs"]
mod large;

use large::{chain_urdf, humanoid_urdf};

use common::alloc::{CountingAllocator, allocated_bytes};
use nalgebra::Vector3;
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::robot::{KinematicsWorkspace, MeshSearchPath, RobotDescription, RobotModel};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn load(text: &str) -> Arc<RobotDescription> {
    Arc::new(RobotDescription::from_urdf_str(text, &MeshSearchPath::default()).unwrap())
}

#[test]
fn a_ten_thousand_link_chain_compiles_and_gives_exact_kinematics() {
    let desc = load(&chain_urdf(10_000, false));
    let model = RobotModel::builder(desc).build().unwrap();
    assert_eq!(model.nq(), 9_999);
    let mut ws = KinematicsWorkspace::new(&model);
    let tip = model.frame_id("l9999").unwrap();
    // Straight: the tip 999.9 m up.
    model.forward_kinematics(&mut ws, &vec![0.0; 9_999]).unwrap();
    let p = model.frame_pose(&ws, tip).translation.vector;
    assert!((p - Vector3::new(0.0, 0.0, 999.9)).norm() < 1e-9, "{p}");
    // The first joint at π/2 lays the chain along x (about y: z turns into x).
    let mut q = vec![0.0; 9_999];
    q[0] = std::f64::consts::FRAC_PI_2;
    model.forward_kinematics(&mut ws, &q).unwrap();
    let p = model.frame_pose(&ws, tip).translation.vector;
    assert!((p - Vector3::new(999.8, 0.0, 0.1)).norm() < 1e-9, "{p}");
}

#[test]
fn a_ten_thousand_joint_mimic_chain_resolves() {
    // Every joint mimics the one before: one active joint drives them all.
    let desc = load(&chain_urdf(10_000, true));
    let model = RobotModel::builder(desc).build().unwrap();
    assert_eq!(model.joint_names(), ["j1"]);
    let mut ws = KinematicsWorkspace::new(&model);
    // 9,999 joints turning by 2π/9,999 each lay the links out as a
    // regular 9,999-gon: the tip is back where the chain started.
    let step = std::f64::consts::TAU / 9_999.0;
    model.forward_kinematics(&mut ws, &[step]).unwrap();
    let values = model.all_joint_values(&[step]).unwrap();
    assert!(values.iter().all(|v| (v - step).abs() < 1e-15), "every joint follows j1");
    let p = model.frame_pose(&ws, model.frame_id("l9999").unwrap()).translation.vector;
    assert!(p.norm() < 1e-9, "{p}");
}

#[test]
fn inspect_and_fk_of_a_ten_thousand_link_chain_run_in_the_binary() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("chain.urdf");
    std::fs::write(&urdf, chain_urdf(10_000, false)).unwrap();
    let tandem = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_tandem")).args(args).output().unwrap();
    let o = tandem(&["inspect", urdf.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    // Linear in size: indentation stops growing at 32 levels.
    assert!(text.len() < 10_000_000, "{} bytes", text.len());
    assert!(text.contains("[level 19999] l9999"), "the deepest link is printed with its level");
    let q = vec!["0"; 9_999].join(",");
    let o = tandem(&["fk", urdf.to_str().unwrap(), "--frame", "l9999", "--q", &q, "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!((v["translation"][2].as_f64().unwrap() - 999.9).abs() < 1e-9);
    // A wrong-length --q names the count and a few joints, not all 9,999
    // (the full list made a 789 KB message on a 100,000-link robot).
    let o = tandem(&["fk", urdf.to_str().unwrap(), "--frame", "l9999", "--q", "0,0"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.len() < 400 && err.contains("expected 9999 joint values") && err.contains("9989 more"), "{err}");
}

#[test]
fn collision_models_of_long_chains_use_memory_linear_in_their_pairs() {
    for links in [250, 1_000] {
        let robot = Arc::new(RobotModel::builder(load(&chain_urdf(links, false))).build().unwrap());
        let before = allocated_bytes();
        let model = CollisionModel::builder(robot.clone()).build().unwrap();
        let bytes = allocated_bytes() - before;
        let pairs = model.pair_count();
        // Every pair of links but neighbours.
        assert_eq!(pairs, (links - 1) * (links - 2) / 2);
        // Measured: ~135 bytes per pair (object pairs, group pairs, the
        // fast path's tables); 1,000 links took 700 MB before.
        let per_pair = bytes as f64 / pairs as f64;
        assert!(per_pair < 400.0, "{links} links: {bytes} bytes for {pairs} pairs ({per_pair:.0} per pair)");
        eprintln!("{links} links: {:.1} MB, {per_pair:.0} bytes per pair", bytes as f64 / 1e6);
        // Certified motions use the pairs' movers: a bent chain folds onto itself.
        let mut ws = CollisionWorkspace::new(&model);
        let q0 = vec![0.0; robot.nq()];
        let mut q1 = q0.clone();
        q1[links / 2] = 3.0;
        assert!(model.motion_free_certified(&mut ws, &q0, &q0, 0.001).unwrap());
        assert!(!model.motion_free_certified(&mut ws, &q0, &q1, 0.001).unwrap(), "folding the chain collides");
    }
}

#[test]
fn a_humanoid_loads_with_a_collision_model() {
    let robot = Arc::new(RobotModel::builder(load(&humanoid_urdf())).build().unwrap());
    assert_eq!(robot.description().links().len(), 62);
    let before = allocated_bytes();
    let model = CollisionModel::builder(robot.clone()).build().unwrap();
    let bytes = allocated_bytes() - before;
    assert!(bytes < 20_000_000, "{bytes} bytes");
    let mut ws = CollisionWorkspace::new(&model);
    let q = vec![0.0; robot.nq()];
    // Fingers of one hand start on top of each other: the model sees it.
    assert!(model.min_distance(&mut ws, &q).unwrap().is_some());
}

/// Certification on the sphere fast path tracks its pending pairs as one
/// bit per group, and groups past the 64th have none (always checked):
/// on a 100-link chain, certified motions keep half the clearance at 101
/// configurations each (the general path's distances), and the general
/// path agrees on nearly every verdict.
#[test]
fn certified_motions_of_a_chain_past_64_groups_keep_half_the_clearance() {
    use rand::{RngExt, SeedableRng};
    let robot = Arc::new(RobotModel::builder(load(&chain_urdf(100, false))).build().unwrap());
    let fast = CollisionModel::builder(robot.clone()).build().unwrap();
    assert!(fast.has_fast_path());
    let mut general = fast.clone();
    general.set_fast_path(false);
    let (mut fast_ws, mut general_ws) = (CollisionWorkspace::new(&fast), CollisionWorkspace::new(&general));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let clearance = 0.002;
    let (mut certified, mut agree, total) = (0, 0, 60);
    for _ in 0..total {
        // The chain curled into an arc, then further: past 2π / 100 rad per
        // joint its tip comes round to its base (groups 0 and 99 meet).
        let (c0, c1) = (rng.random_range(0.0..0.05), rng.random_range(0.03..0.09));
        let q0: Vec<f64> = (0..robot.nq()).map(|_| c0 + rng.random_range(-0.005..0.005)).collect();
        let q1: Vec<f64> = q0.iter().map(|v| v - c0 + c1).collect();
        let ok = fast.motion_free_certified(&mut fast_ws, &q0, &q1, clearance).unwrap();
        agree += usize::from(ok == general.motion_free_certified(&mut general_ws, &q0, &q1, clearance).unwrap());
        if !ok {
            continue;
        }
        certified += 1;
        common::assert_motion_keeps(&general, &mut general_ws, (&q0, &q1), clearance / 2.0, 100);
    }
    eprintln!("{certified} of {total} motions certified, the general path agrees on {agree}");
    assert!(certified >= 10 && certified + 10 <= total, "{certified} of {total}");
    assert!(agree * 100 >= total * 90, "{agree} of {total}");
}
