//! MoveIt inputs: all 700 MotionBenchMaker Panda problems (a planning
//! scene and a motion plan request YAML each) load with the spherized Panda
//! and its SRDF, with collision-free starts and goals; malformed inputs name
//! the file and key.

mod common;

use tandem::collision::CollisionWorkspace;
use tandem::scene::{Goal, Problem, read_moveit_request, read_moveit_scene};

use common::{mbm, unpack_mbm as unpack};

#[test]
fn all_motionbenchmaker_problems_load_with_free_starts_and_goals() {
    let dir = tempfile::tempdir().unwrap();
    let problems = unpack(dir.path());
    let (urdf, srdf) = (mbm().join("panda_spherized.urdf"), mbm().join("panda.srdf"));
    let mut families: Vec<_> = std::fs::read_dir(&problems).unwrap().map(|e| e.unwrap().path()).collect();
    families.sort();
    let (mut loaded, mut obstacles, mut goals_in_collision) = (0, 0, Vec::new());
    for family in &families {
        for k in 1..=100 {
            let scene = family.join(format!("scene{k:04}.yaml"));
            let request = family.join(format!("request{k:04}.yaml"));
            let p = Problem::from_moveit(&urdf, &srdf, &scene, &request).unwrap_or_else(|e| panic!("{e}"));
            let model = p.collision_model().unwrap();
            let mut ws = CollisionWorkspace::new(&model);
            assert!(model.collision_free(&mut ws, &p.start).unwrap(), "{}: start in collision", request.display());
            let Goal::Joints(goal) = &p.goal else { panic!("joint goal expected") };
            if !model.collision_free(&mut ws, goal).unwrap() {
                let d = model.min_distance(&mut ws, goal).unwrap().unwrap();
                println!(
                    "{}: goal penetrates {:?} by {:.4} m",
                    request.display(),
                    model.pair_names(d.pair),
                    -d.signed.distance
                );
                goals_in_collision.push(d.signed.distance);
            }
            assert_eq!(p.robot.nq(), 7);
            obstacles += p.scene.obstacles().len();
            loaded += 1;
        }
    }
    println!("{loaded} problems in {} families, {obstacles} obstacles in all", families.len());
    assert_eq!(loaded, 700);
    // With the conservative spheres a few pick goals graze their object
    // (VAMP, planning with the same spheres, reports 699 of 700 solved).
    assert!(goals_in_collision.len() <= 1 && goals_in_collision.iter().all(|d| *d > -0.01), "{goals_in_collision:?}");
}

#[test]
fn malformed_moveit_files_name_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let cone = write(
        "cone.yaml",
        "world:\n  collision_objects:\n    - id: c\n      primitives:\n        - type: cone\n          dimensions: [1, 1]\n      primitive_poses:\n        - position: [0, 0, 0]\n          orientation: [0, 0, 0, 1]\n",
    );
    let e = read_moveit_scene(&cone).unwrap_err().to_string();
    assert!(
        e.contains("cone.yaml") && e.contains("world.collision_objects[0].primitives[0].type") && e.contains("cone"),
        "{e}"
    );
    let bad_quat = write(
        "quat.yaml",
        "world:\n  collision_objects:\n    - id: b\n      primitives:\n        - type: box\n          dimensions: [1, 1, 1]\n      primitive_poses:\n        - position: [0, 0, 0]\n          orientation: [0, 0, 0, 2]\n",
    );
    let e = read_moveit_scene(&bad_quat).unwrap_err().to_string();
    assert!(e.contains("primitive_poses[0].orientation") && e.contains("unit quaternion"), "{e}");
    let neg = write(
        "neg.yaml",
        "world:\n  collision_objects:\n    - id: b\n      primitives:\n        - type: box\n          dimensions: [1, -1, 1]\n      primitive_poses:\n        - position: [0, 0, 0]\n          orientation: [0, 0, 0, 1]\n",
    );
    assert!(read_moveit_scene(&neg).unwrap_err().to_string().contains("dimensions"));
    let broken = write("broken.yaml", "world: [unclosed\n");
    let e = read_moveit_scene(&broken).unwrap_err().to_string();
    assert!(e.contains("broken.yaml") && e.contains("malformed YAML"), "{e}");
    let req =
        write("req.yaml", "group_name: panda_arm\nstart_state:\n  joint_state:\n    name: [a, b]\n    position: [0]\n");
    let e = read_moveit_request(&req).unwrap_err().to_string();
    assert!(e.contains("start_state.joint_state") && e.contains("2 names but 1 positions"), "{e}");
    let no_goal = write(
        "nogoal.yaml",
        "group_name: panda_arm\nstart_state:\n  joint_state:\n    name: [panda_joint1]\n    position: [0]\ngoal_constraints:\n  - joint_constraints:\n      - joint_name: panda_joint1\n        position: 0.1\n",
    );
    let e = Problem::from_moveit(&mbm().join("panda_spherized.urdf"), &mbm().join("panda.srdf"), &cone, &no_goal)
        .unwrap_err()
        .to_string();
    assert!(e.contains("nogoal.yaml") && e.contains("panda_joint2"), "{e}");
}
