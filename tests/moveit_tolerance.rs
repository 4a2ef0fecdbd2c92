//! MoveIt-tolerant loading: allowed collision matrices and SRDFs naming
//! links the URDF lacks load with warnings (as MoveIt and srdfdom do), and
//! SRDF groups are unions of chains, joints, links and subgroups, so a
//! planning group may span both arms of a dual-arm robot or a torso lift
//! plus an arm.

mod common;

use common::{mbm, unpack_mbm as unpack};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tandem::plan::{PlanStatus, ProblemPlanner};
use tandem::problem::Problem;
use tandem::robot::{JointSelection, RobotDescription, RobotModel, Srdf};

/// MotionBenchMaker's first box problem with `scene` and `srdf` text.
fn panda_problem(dir: &Path, scene: &str, srdf: Option<&str>) -> Result<Problem, String> {
    let request = unpack(dir).join("box_panda/request0001.yaml");
    let scene_file = dir.join("scene.yaml");
    std::fs::write(&scene_file, scene).unwrap();
    let srdf_file = match srdf {
        Some(text) => {
            let f = dir.join("robot.srdf");
            std::fs::write(&f, text).unwrap();
            f
        }
        None => mbm().join("panda.srdf"),
    };
    Problem::from_moveit(&mbm().join("panda_spherized.urdf"), &srdf_file, &scene_file, &request)
        .map_err(|e| e.to_string())
}

#[test]
fn allowed_collision_matrix_names_unknown_to_the_robot_are_warnings() {
    let dir = tempfile::tempdir().unwrap();
    // An ACM saved with a mobile base's laser in it, loaded for the arm alone.
    let scene = "world:\n  collision_objects:\n    - id: table\n      primitives: [{type: box, dimensions: [0.4, 0.4, 0.02]}]\n      primitive_poses: [{position: [0.5, 0, 0.0], orientation: [0, 0, 0, 1]}]\nallowed_collision_matrix:\n  entry_names: [panda_link0, base_laser_link, table]\n  entry_values:\n    - enabled: [false, true, true]\n    - enabled: [true, false, true]\n    - enabled: [true, true, false]\n";
    let p = panda_problem(dir.path(), scene, None).unwrap();
    assert_eq!(p.warnings.len(), 1, "{:?}", p.warnings);
    let w = &p.warnings[0];
    assert!(w.contains("scene.yaml") && w.contains("base_laser_link") && w.contains("ignored"), "{w}");
    // The known pair is kept: panda_link0 may touch the table.
    assert!(p.scene.allowed_contacts().iter().any(|(a, b)| a == "panda_link0" && b == "table"));
    assert!(!p.scene.allowed_contacts().iter().any(|(a, b)| a == "base_laser_link" || b == "base_laser_link"));
    p.collision_model().unwrap();
}

#[test]
fn srdf_entries_naming_links_the_urdf_lacks_are_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let panda = std::fs::read_to_string(mbm().join("panda.srdf")).unwrap();
    // An SRDF written for the Panda on a mobile base.
    let srdf = panda.replace(
        "</robot>",
        "<disable_collisions link1=\"panda_link0\" link2=\"base_link\" reason=\"Adjacent\"/>\n\
         <group name=\"with_base\"><joint name=\"base_x\"/><group name=\"panda_arm\"/></group>\n</robot>",
    );
    let p = panda_problem(dir.path(), "world: {}\n", Some(&srdf)).unwrap();
    assert_eq!(p.warnings.len(), 2, "{:?}", p.warnings);
    assert!(p.warnings.iter().any(|w| w.contains("robot.srdf:") && w.contains("link 'base_link'")), "{:?}", p.warnings);
    assert!(p.warnings.iter().any(|w| w.contains("joint 'base_x'") && w.contains("with_base")), "{:?}", p.warnings);
    let srdf = p.srdf.as_ref().unwrap();
    assert!(!srdf.is_disabled("panda_link0", "base_link"));
    assert_eq!(p.robot.nq(), 7);
    // The strict check still names the first unknown entry.
    let mut strict = Srdf::from_srdf_file(dir.path().join("robot.srdf")).unwrap();
    let desc = RobotDescription::from_urdf_file(mbm().join("panda_spherized.urdf"), &Default::default()).unwrap();
    assert!(strict.check_against(&desc).unwrap_err().to_string().contains("base_x"));
    assert_eq!(strict.reconcile(&desc).len(), 2);
    assert!(strict.check_against(&desc).is_ok());
}

/// A torso with a lift (prismatic) and two 2-joint arms.
const DUAL_ARM: &str = r#"<robot name="dual">
  <link name="base"/><link name="torso"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="torso"/><axis xyz="0 0 1"/>
    <origin xyz="0 0 0.5"/><limit lower="0" upper="0.3" effort="1" velocity="1"/></joint>
  <link name="l1"/><link name="l2"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="l_tool"/>
  <link name="r1"/><link name="r2"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="r_tool"/>
  <joint name="l_j1" type="revolute"><parent link="torso"/><child link="l1"/><origin xyz="0 0.3 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="l_j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="l_fix" type="fixed"><parent link="l2"/><child link="l_tool"/><origin xyz="0.2 0 0"/></joint>
  <joint name="r_j1" type="revolute"><parent link="torso"/><child link="r1"/><origin xyz="0 -0.3 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="r_j2" type="revolute"><parent link="r1"/><child link="r2"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="r_fix" type="fixed"><parent link="r2"/><child link="r_tool"/><origin xyz="0.2 0 0"/></joint>
</robot>"#;

const DUAL_ARM_SRDF: &str = r#"<robot name="dual">
  <group name="left_arm"><chain base_link="torso" tip_link="l_tool"/></group>
  <group name="right_arm"><chain base_link="torso" tip_link="r_tool"/></group>
  <group name="both_arms"><group name="left_arm"/><group name="right_arm"/></group>
  <group name="lift_and_left"><joint name="lift"/><joint name="l_fix"/><group name="left_arm"/></group>
  <group name="two_chains"><chain base_link="torso" tip_link="l_tool"/><chain base_link="torso" tip_link="r_tool"/></group>
  <group name="by_links"><link name="l1"/><link name="l2"/><link name="l_tool"/></group>
  <group name="loop_a"><group name="loop_b"/></group>
  <group name="loop_b"><group name="loop_a"/></group>
</robot>"#;

#[test]
fn srdf_groups_are_unions_of_chains_joints_links_and_subgroups() {
    let desc = Arc::new(RobotDescription::from_urdf_str(DUAL_ARM, &Default::default()).unwrap());
    let srdf = Srdf::from_srdf_str(DUAL_ARM_SRDF).unwrap();
    let joints = |group: &str| {
        let selection = srdf.joint_selection(group).unwrap();
        RobotModel::builder(desc.clone()).selection(selection).build().unwrap().joint_names().to_vec()
    };
    assert!(matches!(srdf.joint_selection("left_arm").unwrap(), JointSelection::Chain { .. }));
    assert_eq!(joints("both_arms"), ["l_j1", "l_j2", "r_j1", "r_j2"]);
    assert_eq!(joints("two_chains"), ["l_j1", "l_j2", "r_j1", "r_j2"]);
    // A fixed joint in a group's joint list is allowed and not active (MoveIt).
    assert_eq!(joints("lift_and_left"), ["lift", "l_j1", "l_j2"]);
    assert_eq!(joints("by_links"), ["l_j1", "l_j2"]);
    let e = srdf.joint_selection("loop_a").unwrap_err().to_string();
    assert!(e.contains("loop_a -> loop_b -> loop_a"), "{e}");
}

/// Scene and request files for the dual-arm robot planning `group`.
fn dual_arm_inputs(dir: &Path, group: &str, start: &[(&str, f64)], goal: &[(&str, f64)]) -> [PathBuf; 4] {
    let write = |name: &str, text: String| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let names: Vec<&str> = start.iter().map(|(n, _)| *n).collect();
    let values: Vec<String> = start.iter().map(|(_, v)| v.to_string()).collect();
    let goals: String = goal
        .iter()
        .map(|(n, v)| format!("      - {{joint_name: {n}, position: {v}, tolerance_above: 0.001, tolerance_below: 0.001, weight: 1}}\n"))
        .collect();
    let request = format!(
        "group_name: {group}\nstart_state:\n  joint_state:\n    name: [{}]\n    position: [{}]\ngoal_constraints:\n  - joint_constraints:\n{goals}",
        names.join(", "),
        values.join(", ")
    );
    // A post between the arms' reach at the front.
    let scene = "world:\n  collision_objects:\n    - id: post\n      primitives: [{type: box, dimensions: [0.1, 0.1, 2.0]}]\n      primitive_poses: [{position: [0.45, 0, 0.5], orientation: [0, 0, 0, 1]}]\n";
    [
        write("dual.urdf", DUAL_ARM.to_string()),
        write("dual.srdf", DUAL_ARM_SRDF.to_string()),
        write("scene.yaml", scene.to_string()),
        write("request.yaml", request),
    ]
}

#[test]
fn a_group_of_two_arms_plans_both_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let start = [("lift", 0.1), ("l_j1", 1.2), ("l_j2", 0.0), ("r_j1", -1.2), ("r_j2", 0.0)];
    let goal = [("l_j1", -0.9), ("l_j2", 0.3), ("r_j1", 0.9), ("r_j2", -0.3)];
    let [urdf, srdf, scene, request] = dual_arm_inputs(dir.path(), "both_arms", &start, &goal);
    let problem = Problem::from_moveit(&urdf, &srdf, &scene, &request).unwrap();
    assert_eq!(problem.robot.joint_names(), ["l_j1", "l_j2", "r_j1", "r_j2"]);
    assert!(problem.warnings.is_empty(), "{:?}", problem.warnings);
    let mut planner = ProblemPlanner::new(&problem, Some(0)).unwrap();
    let report = planner.run(0).unwrap();
    assert_eq!(report.result.status, PlanStatus::Solved);
    assert!(report.certified);
    // The request's goal lists the right arm first; `plan --json` names the
    // columns of its waypoints (tandem's order, the SRDF's tree order), so a
    // consumer reads each joint's goal where it is.
    let reordered = [("r_j1", 0.9), ("r_j2", -0.3), ("l_j1", -0.9), ("l_j2", 0.3)];
    let [urdf, srdf, scene, request] = dual_arm_inputs(dir.path(), "both_arms", &start, &reordered);
    let flags = ["--urdf", "--srdf", "--scene", "--request"];
    let paths = [&urdf, &srdf, &scene, &request];
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_tandem"));
    command.args(["plan", "--json"]);
    for (flag, path) in flags.iter().zip(paths) {
        command.arg(flag).arg(path);
    }
    let out = command.output().unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {out:?}"));
    let joints: Vec<&str> = v["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap()).collect();
    assert_eq!(joints, ["l_j1", "l_j2", "r_j1", "r_j2"], "{v}");
    let last = v["waypoints"].as_array().unwrap().last().unwrap().as_array().unwrap().clone();
    for (name, value) in reordered {
        let column = joints.iter().position(|j| *j == name).unwrap();
        assert!((last[column].as_f64().unwrap() - value).abs() < 1e-9, "{name}: {v}");
    }
    // The group with the lift: the prismatic joint moves too.
    let goal = [("lift", 0.25), ("l_j1", -0.9), ("l_j2", 0.3)];
    let [urdf, srdf, scene, request] = dual_arm_inputs(dir.path(), "lift_and_left", &start, &goal);
    let problem = Problem::from_moveit(&urdf, &srdf, &scene, &request).unwrap();
    assert_eq!(problem.robot.joint_names(), ["lift", "l_j1", "l_j2"]);
    let report = ProblemPlanner::new(&problem, Some(0)).unwrap().run(0).unwrap();
    assert_eq!(report.result.status, PlanStatus::Solved);
    assert!(report.certified);
}

#[test]
fn check_and_inspect_list_the_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let request = unpack(dir.path()).join("box_panda/request0001.yaml");
    let scene = dir.path().join("scene.yaml");
    std::fs::write(
        &scene,
        "allowed_collision_matrix:\n  entry_names: [panda_link0, base_laser_link]\n  entry_values:\n    - enabled: [false, true]\n    - enabled: [true, false]\n",
    )
    .unwrap();
    let panda = std::fs::read_to_string(mbm().join("panda.srdf")).unwrap();
    let srdf = dir.path().join("robot.srdf");
    std::fs::write(
        &srdf,
        panda.replace("</robot>", "<disable_collisions link1=\"panda_link0\" link2=\"base_link\"/>\n</robot>"),
    )
    .unwrap();
    let urdf = mbm().join("panda_spherized.urdf");
    let tandem = |args: &[&Path]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_tandem")).args(args).output().unwrap();
        (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned())
    };
    let flags = ["--urdf", "--srdf", "--scene", "--request"].map(Path::new);
    let (ok, text) =
        tandem(&[Path::new("check"), flags[0], &urdf, flags[1], &srdf, flags[2], &scene, flags[3], &request]);
    assert!(ok, "{text}");
    assert!(text.contains("warnings (2") && text.contains("base_laser_link") && text.contains("'base_link'"), "{text}");
    let (ok, text) = tandem(&[Path::new("inspect"), &urdf, Path::new("--srdf"), &srdf]);
    assert!(ok, "{text}");
    assert!(
        text.contains("SRDF warnings (entries left out, as MoveIt does): 1") && text.contains("'base_link'"),
        "{text}"
    );
    assert!(text.contains("panda_arm") && text.contains("7 joints"), "{text}");
    assert!(text.contains("every collision element is a sphere"), "{text}");
    // The compiled fast path: the Panda's eleven-digit quarter turns and its f32 checks.
    assert!(text.contains("joint frames within 1e-9 of a quarter turn"), "{text}");
    assert!(text.contains("plain checks run first in single precision"), "{text}");
    // A robot with a box link: the report says what would take the fast path.
    let boxy = dir.path().join("boxy.urdf");
    std::fs::write(&boxy, "<robot name=\"boxy\"><link name=\"base\"><collision><geometry><box size=\"1 1 1\"/></geometry></collision></link></robot>").unwrap();
    let (ok, text) = tandem(&[Path::new("inspect"), &boxy]);
    assert!(ok && text.contains("general path") && text.contains("what would take the fast path"), "{text}");
}
