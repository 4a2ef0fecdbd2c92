//! The `tandem` binary: JSON contract of `fk`, the `inspect` report, and
//! errors that exit non-zero with a message instead of a panic.

mod common;

use std::process::{Command, Output};

fn tandem(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tandem")).args(args).current_dir(common::repo()).output().expect("run tandem")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

const PANDA: &str = "problems/robots/panda/panda.urdf";
const ARM: &str = "panda_joint1,panda_joint2,panda_joint3,panda_joint4,panda_joint5,panda_joint6,panda_joint7";

#[test]
fn fk_json_is_one_object_with_the_documented_fields() {
    let o = tandem(&[
        "fk",
        PANDA,
        "--frame",
        "panda_hand_tcp",
        "--q",
        "0,-0.785,0,-2.356,0,1.571,0.785",
        "--joints",
        ARM,
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert_eq!(text.trim().lines().count(), 1, "exactly one line: {text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["frame"], "panda_hand_tcp");
    assert_eq!(v["joints"].as_array().unwrap().len(), 7);
    assert_eq!(v["translation"].as_array().unwrap().len(), 3);
    let rot = v["rotation"].as_array().unwrap();
    assert!(rot.len() == 3 && rot.iter().all(|r| r.as_array().unwrap().len() == 3));
    let jac = v["jacobian"].as_array().unwrap();
    assert!(jac.len() == 6 && jac.iter().all(|r| r.as_array().unwrap().len() == 7));
    // The ready pose puts the TCP about 0.31 m ahead and 0.49 m up.
    let x = v["translation"][0].as_f64().unwrap();
    let z = v["translation"][2].as_f64().unwrap();
    assert!((x - 0.307).abs() < 0.01 && (z - 0.487).abs() < 0.01, "{x} {z}");
    // Gripper pointing down: the TCP z axis is -world z.
    assert!((v["rotation"][2][2].as_f64().unwrap() + 1.0).abs() < 1e-3);
}

#[test]
fn fk_without_joints_uses_all_independent_movable_joints() {
    // 7 arm joints + finger joint 1 (finger joint 2 mimics it).
    let o = tandem(&["fk", PANDA, "--frame", "panda_link8", "--q", "0,0,0,-1,0,1,0,0.02", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["joints"].as_array().unwrap().len(), 8);
    assert_eq!(v["joints"][7], "panda_finger_joint1");
}

#[test]
fn inspect_reports_tree_joints_frames_geometry() {
    let o = tandem(&["inspect", PANDA]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for needle in [
        "kinematic tree:",
        "└─ panda_joint1 (revolute)",
        "panda_joint4",
        "position [-3.0718, -0.0698] rad",
        "mimics panda_finger_joint1",
        "panda_hand_tcp",
        "collision geometry:",
        "sphere",
        "problems found:",
    ] {
        assert!(text.contains(needle), "missing '{needle}' in:\n{text}");
    }
}

#[test]
fn errors_exit_non_zero_with_a_message_and_no_panic() {
    let cases: &[(&[&str], &str)] = &[
        (&["fk", PANDA, "--frame", "panda_hnd", "--q", "0"], "unknown frame 'panda_hnd'"),
        (&["fk", PANDA, "--frame", "panda_hand", "--q", "0,1", "--joints", ARM], "expected 7 joint values"),
        (&["fk", PANDA, "--frame", "panda_hand", "--q", "0,x,0,0,0,0,0", "--joints", ARM], "('x') is not a number"),
        (&["fk", PANDA, "--frame", "panda_hand", "--q", "0,NaN,0,-1,0,1,0", "--joints", ARM], "non-finite value NaN"),
        (
            &["fk", PANDA, "--frame", "panda_hand", "--q", "0", "--joints", "panda_joint9"],
            "unknown joint 'panda_joint9'",
        ),
        (&["inspect", "no/such/file.urdf"], "cannot read no/such/file.urdf"),
    ];
    for (args, message) in cases {
        let o = tandem(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: expected '{message}' in '{err}'");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
}

#[test]
fn inspect_names_line_of_a_broken_urdf() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.urdf");
    std::fs::write(&path, "<robot name=\"r\">\n<link name=\"a\"/>\n<joint name=\"j\" type=\"hinge\"><parent link=\"a\"/><child link=\"a\"/></joint>\n</robot>").unwrap();
    let o = tandem(&["inspect", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("bad.urdf:3") && err.contains("unknown type 'hinge'"), "{err}");
}

#[test]
fn help_teaches() {
    let o = tandem(&["fk", "--help"]);
    assert!(o.status.success());
    let text = stdout(&o);
    assert!(text.contains("world-aligned") && text.contains("Example") && text.contains("--package-dir"), "{text}");
}

#[test]
fn policy_rolls_out_to_the_goal_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("policy.svg");
    let o = tandem(&["policy", "--time-varying", "--plot", svg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    // Every rollout ends within 1e-4 rad of the goal.
    for line in text.lines().filter(|l| l.contains("rollout from")) {
        let miss: f64 = line.split("ends ").nth(1).and_then(|s| s.split(' ').next()).unwrap().parse().unwrap();
        assert!(miss < 1e-4, "{line}");
    }
    let picture = std::fs::read_to_string(&svg).unwrap();
    // Reference, rollouts and the velocity field's arrows (one polyline each).
    assert!(picture.starts_with("<svg") && picture.contains("reference") && picture.contains("rollouts"));
    assert!(picture.matches("<polyline").count() > 50, "{picture}");
    let o = tandem(&["policy", "--slice", "1,9", "--plot", svg.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--slice"), "{}", stderr(&o));
}

#[test]
fn check_json_reports_the_documented_fields() {
    let o = tandem(&["check", "problems/panda_grasp_box.toml", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert_eq!(text.trim().lines().count(), 1, "exactly one line: {text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["valid"], true);
    assert_eq!(v["collision_free"], true);
    assert!(v["min_distance"].as_f64().unwrap() > 0.0);
    assert_eq!(v["closest_pair"].as_array().unwrap().len(), 2);
    // A configuration through the wall of panda_reach_obstacle.
    let o = tandem(&["check", "builtin:panda_reach_obstacle", "--q", "0.1,0.5,0,-1.2,0,0.3,0", "--json"]);
    assert_eq!(o.status.code(), Some(3), "a collision: ran, did not succeed; {}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["collision_free"], false);
    assert!(v["min_distance"].as_f64().unwrap() < -0.05);
    assert_eq!(v["closest_pair"], serde_json::json!(["panda_hand", "wall"]));
    assert!(v["colliding_pairs"].as_array().unwrap().iter().any(|p| p[1] == "wall"));
}

#[test]
fn check_names_file_key_and_line_of_a_bad_problem() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(common::repo().join("problems/panda_reach.toml"))
        .unwrap()
        .replace("size = [1.4, 1.6]", "size = [1.4, -1.6]")
        .replace("robots/panda/panda.urdf", common::repo().join("problems/robots/panda/panda.urdf").to_str().unwrap())
        .replace(
            "robots/panda/joint_limits.yaml",
            common::repo().join("problems/robots/panda/joint_limits.yaml").to_str().unwrap(),
        );
    std::fs::write(&bad, &text).unwrap();
    let line = text.lines().position(|l| l.contains("-1.6")).unwrap() + 1;
    let o = tandem(&["check", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains(&format!("bad.toml:{line}: scene.table.size[1]")), "{err}");
    let o = tandem(&["check", bad.to_str().unwrap(), "--json"]);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["valid"], false);
    assert!(v["error"].as_str().unwrap().contains("scene.table.size[1]"));
    let o = tandem(&["check", "problems/panda_reach.toml", "--q", "0,0,0"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("expected 7 joint values"), "{}", stderr(&o));
}

#[test]
fn solve_json_reports_the_documented_fields_and_writes_files() {
    let dir = tempfile::TempDir::new().unwrap();
    let out = dir.path().to_str().unwrap();
    let o = tandem(&["solve", "problems/panda_grasp_box.toml", "-T", "20", "--seed", "2", "--json", "--out", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert_eq!(text.trim().lines().count(), 1, "exactly one line: {text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "status",
        "time_ms",
        "iterations",
        "cost",
        "eq_violation",
        "ineq_violation",
        "min_distance",
        "collision_free",
        "T",
        "joints",
        "trajectory",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {text}");
    }
    assert_eq!(v["status"], "converged");
    assert_eq!(v["T"], 20);
    assert_eq!(v["collision_free"], true);
    assert!(v["eq_violation"].as_f64().unwrap() <= 1e-4);
    // The start configuration first (MoveIt-style), then q_1 … q_T.
    let trajectory = v["trajectory"].as_array().unwrap();
    assert_eq!(trajectory.len(), 21);
    assert!(trajectory.iter().all(|q| q.as_array().unwrap().len() == 7));
    let start =
        tandem::problem::Problem::from_file(common::repo().join("problems/panda_grasp_box.toml")).unwrap().start;
    assert_eq!(trajectory[0], serde_json::json!(start));
    assert_eq!(v["joints"].as_array().unwrap().len(), 7);
    let csv = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
    assert_eq!(csv.lines().count(), 22);
    assert!(csv.starts_with("time,panda_joint1,"));
    for file in ["trajectory.parquet", "joints.svg", "path.svg"] {
        let bytes = std::fs::read(dir.path().join(file)).unwrap();
        assert!(bytes.len() > 500, "{file} is {} bytes", bytes.len());
    }
    let parquet = std::fs::read(dir.path().join("trajectory.parquet")).unwrap();
    assert!(parquet.starts_with(b"PAR1") && parquet.ends_with(b"PAR1"));
}

#[test]
fn solve_names_a_bad_problem_and_exits_non_zero() {
    let o = tandem(&["solve", "problems/no_such_problem.toml", "--json"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no_such_problem.toml"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn demo_runs_the_reach_and_grasp_end_to_end() {
    let dir = tempfile::TempDir::new().unwrap();
    let out = dir.path().join("demo");
    let o = tandem(&["demo", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("panda_grasp_box (<builtin:panda_grasp_box>): converged"), "{text}");
    assert!(text.contains("collision-free between slices (every 0.002 rad): yes"), "{text}");
    assert!(out.join("path.svg").exists() && out.join("trajectory.parquet").exists());
    // Shared control first, then the reference, and it ends with which
    // figure to open.
    assert!(text.contains("wrote trajectory.csv"), "{text}");
    assert!(text.find("one episode per arbitration mode") < text.find("the robot's reference"), "{text}");
    assert!(text.trim_end().lines().last().unwrap().contains("shared_control.svg"), "{text}");
    assert!(!text.contains("ns per call"), "micro-benchmarks only with --verbose: {text}");
    assert!(out.join("shared_control.svg").exists());
    for mode in ["sos", "constrained", "natural-gradient-joint"] {
        let row = text.lines().find(|l| l.trim_start().starts_with(&format!("{mode} "))).expect("mode row");
        let cols: Vec<&str> = row.split_whitespace().collect();
        assert_eq!((cols[1], cols[5]), ("success", "0"), "{mode} must grasp without violations: {row}");
    }
    assert!(!text.contains("join this command as they land"), "{text}");
}

#[test]
fn point_clouds_join_the_scene_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let ply = |name: &str, points: &[[f64; 3]]| {
        let mut text = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            points.len()
        );
        for p in points {
            text.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
        }
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    // A sheet of points far from the arm, and one through the hand at the start.
    let far: Vec<[f64; 3]> = (0..100).map(|k| [-0.6, -0.5 + 0.01 * k as f64, 0.5]).collect();
    let far = ply("far.ply", &far);
    let o = tandem(&["check", "builtin:panda_reach", "--point-cloud", &far, "--point-radius", "0.02"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("far (100 points, radius 0.02 m)"), "{}", stdout(&o));
    assert!(stdout(&o).contains("collision-free: yes"));
    let o = tandem(&["check", "builtin:panda_reach", "--q", "0,-0.785,0,-2.356,0,1.571,0.785", "--point-cloud", &far]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Optimization and shared control with the cloud in the scene: the
    // trajectory and every tick keep clear of it.
    // (problems/clouds/pillar.ply stands beside panda_reach's way.)
    let pillar = common::repo().join("problems/clouds/pillar.ply");
    let o = tandem(&["solve", "builtin:panda_reach", "--point-cloud", pillar.to_str().unwrap(), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!((v["status"].as_str(), v["collision_free"].as_bool()), (Some("converged"), Some(true)), "{v}");
    let o =
        tandem(&["arbitrate", "builtin:panda_grasp_box", "--operator", "approach", "--point-cloud", &far, "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!((v["outcome"].as_str(), v["hard_violations"].as_u64()), (Some("success"), Some(0)), "{v}");
    assert!(v["min_clearance_m"].as_f64().is_some_and(|d| d >= 0.0), "{v}");
    // The hand of the ready pose is at (0.307, 0, 0.590): points through it.
    let hand: Vec<[f64; 3]> = (0..50).map(|k| [0.2 + 0.005 * k as f64, 0.0, 0.59]).collect();
    let hand = ply("hand.ply", &hand);
    let o = tandem(&["plan", "builtin:panda_reach", "--point-cloud", &far, "--point-cloud", &hand, "--json"]);
    assert_eq!(o.status.code(), Some(3), "{}{}", stdout(&o), stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["status"], "start_invalid");
    let reason = v["reason"].as_str().unwrap();
    assert!(reason.contains("hand (point ") && reason.contains(" m)"), "{reason}");
    // A broken file names itself and the line.
    let bad = dir.path().join("bad.ply");
    std::fs::write(&bad, "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n").unwrap();
    let o = tandem(&["check", "builtin:panda_reach", "--point-cloud", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad.ply"), "{}", stderr(&o));
    let o = tandem(&["check", "builtin:panda_reach", "--point-cloud", &far, "--point-radius", "-1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
