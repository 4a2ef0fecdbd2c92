//! The `tandem` binary's contracts with scripts: exit statuses (0 success,
//! 1 invalid input, 2 usage, 3 ran but did not succeed), documented
//! bounds on every size and setting, one trajectory format written by
//! `solve` and read back by `policy`, and configurations checked against
//! the limits wherever they enter.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn tandem(args: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_tandem")).args(args).current_dir(common::repo()).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    o
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `args`, expects exit status `code` and `needle` in stdout + stderr.
fn expect(args: &[&str], code: i32, needle: &str) -> Output {
    let o = tandem(args);
    let all = format!("{}{}", stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(code), "{args:?}: {all}");
    assert!(all.contains(needle), "{args:?}: expected '{needle}' in:\n{all}");
    o
}

/// A copy of a shipped problem file with `from` replaced by `to`, written
/// into `dir` (the Panda path made absolute).
fn problem_with(dir: &Path, name: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(common::repo().join("problems").join(name)).unwrap();
    assert!(text.contains(from), "{from}");
    let urdf = common::repo().join("problems/robots/panda/panda.urdf");
    let limits = common::repo().join("problems/robots/panda/joint_limits.yaml");
    let text = text
        .replace(from, to)
        .replace("robots/panda/panda.urdf", urdf.to_str().unwrap())
        .replace("robots/panda/joint_limits.yaml", limits.to_str().unwrap());
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn check_refuses_configurations_outside_the_limits_and_exits_3_on_collision() {
    // Both were "valid": true, exit 0.
    expect(
        &["check", "builtin:panda_reach", "--q", "9,0,0,-1,0,1,0"],
        1,
        "joint 'panda_joint1' (index 0) = 9 is outside",
    );
    let o = expect(&["check", "builtin:panda_reach", "--q", "0,0,0,-1,0,1e308,0", "--json"], 1, "panda_joint6");
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["valid"], false);
    expect(&["check", "builtin:panda_reach", "--q", "0,0,0,-1,0,nan,0"], 1, "non-finite");
    // Within limits and free: 0; colliding: 3 (a documented "no", not an error).
    expect(&["check", "builtin:panda_reach"], 0, "collision-free: yes");
    expect(&["check", "builtin:panda_reach_obstacle", "--q", "0.1,0.5,0,-1.2,0,0.3,0"], 3, "collision-free: NO");
}

#[test]
fn check_validates_a_family_file_and_samples_members() {
    // Failed with "unknown field `base`".
    let o = expect(&["check", "problems/panda_grasp_family.toml"], 0, "family panda_grasp_family");
    assert_eq!(stdout(&o).lines().filter(|l| l.trim_start().starts_with("member ")).count(), 3);
    let o = expect(&["check", "problems/panda_grasp_family.toml", "--samples", "2", "--json"], 0, "\"family\"");
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    let samples = v["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 2);
    assert!(samples.iter().all(|s| s["collision_free"] == true && s["id"].is_u64()), "{v}");
    expect(&["check", "problems/panda_grasp_family.toml", "--samples", "10001"], 2, "[0, 10000]");
    expect(&["check", "problems/panda_grasp_family.toml", "--q", "0,0,0,0,0,0,0"], 1, "--q does not apply");
    // A broken family is named at its key.
    let dir = tempfile::tempdir().unwrap();
    let family = std::fs::read_to_string(common::repo().join("problems/panda_grasp_family.toml")).unwrap();
    let bad = dir.path().join("fam.toml");
    let base = common::repo().join("problems/panda_grasp_box.toml");
    std::fs::write(
        &bad,
        family.replace("jitter = 0.3", "jitter = -1").replace("panda_grasp_box.toml", base.to_str().unwrap()),
    )
    .unwrap();
    expect(&["check", bad.to_str().unwrap()], 1, "start.jitter");
}

#[test]
fn plan_exits_3_with_the_reason_when_it_finds_no_path() {
    let dir = tempfile::tempdir().unwrap();
    // A start through the wall: start_invalid was exit 0 with no reason.
    let through_wall = "q = [0.1, 0.5, 0.0, -1.2, 0.0, 0.3, 0.0]";
    let p = problem_with(
        dir.path(),
        "panda_reach_obstacle.toml",
        "q = [-0.6063, 0.1517, -0.0562, -2.0857, 0.0108, 2.2372, -1.4540]",
        through_wall,
    );
    expect(&["plan", &p], 3, "start: in collision: panda_hand and wall penetrate by");
    let o = expect(&["plan", &p, "--json"], 3, "start_invalid");
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert!(v["reason"].as_str().unwrap().contains("wall"), "{v}");
    expect(&["plan", "builtin:panda_reach_obstacle"], 0, "solved");
    // A resolution of 1e-300 planned through the wall; 1e-9 hung.
    let p = problem_with(
        dir.path(),
        "panda_reach_obstacle.toml",
        "resolution = 0.005",
        "resolution = 1e-300\nclearance = 0.0",
    );
    expect(&["plan", &p], 1, "planner.resolution: must be at least 0.00001 rad");
}

#[test]
fn solve_bounds_its_horizon_and_exits_3_unless_converged() {
    // -T 1000000 ran (the problem-file limit is 100,000).
    expect(&["solve", "builtin:panda_reach", "-T", "1000000"], 2, "[2, 100000]");
    expect(&["solve", "builtin:panda_reach", "-T", "1"], 2, "[2, 100000]");
    let dir = tempfile::tempdir().unwrap();
    let p =
        problem_with(dir.path(), "panda_reach_obstacle.toml", "duration = 4.0", "duration = 4.0\nmax_iterations = 1");
    let o = expect(&["solve", &p, "-T", "10", "--json"], 3, "\"status\"");
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_ne!(v["status"], "converged");
}

#[test]
fn policy_sizes_and_weights_have_documented_ranges() {
    // --dt 1e-9 aborted allocating 72 GB, 1e-300 panicked, 1e6 said
    // "(A, B) is not stabilisable"; --q-weight 1e300 "Q is not positive
    // semidefinite"; --r-weight 0 printed a raw struct.
    for dt in ["1e-9", "1e-300", "1e6", "0", "-1", "nan"] {
        let o = tandem(&["policy", &format!("--dt={dt}")]);
        assert_eq!(o.status.code(), Some(2), "--dt {dt}: {}", stderr(&o));
        assert!(stderr(&o).contains("--dt") && stderr(&o).contains("[0.0001, 1]"), "{}", stderr(&o));
    }
    for (option, value) in [("--q-weight", "1e300"), ("--r-weight", "0"), ("--v-weight", "-1")] {
        expect(&["policy", &format!("{option}={value}")], 2, "outside the allowed range [0.0001, 10000]");
    }
    // Rollouts that miss the goal: ran, did not succeed.
    expect(&["policy", "--goal-tolerance", "1e-12"], 3, "MISSED the goal");
}

#[test]
fn solve_writes_the_trajectory_policy_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = expect(
        &["solve", "builtin:panda_reach_obstacle", "-T", "20", "--out", out.to_str().unwrap(), "--json"],
        0,
        "converged",
    );
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    let time_step = v["time_step"].as_f64().unwrap();
    let csv = out.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("time,panda_joint1,"), "{}", &text[..60]);
    // The start first, at time 0, as in MoveIt trajectories.
    let start = tandem::problem::Problem::builtin("panda_reach_obstacle").unwrap().start;
    let first: Vec<f64> = text.lines().nth(1).unwrap().split(',').map(|x| x.parse().unwrap()).collect();
    assert_eq!(first[0], 0.0);
    assert_eq!(first[1..], start[..]);
    // Read back as 7 joints at the solve's time step (was 9 "joints" — slice
    // and time — at --dt 0.01).
    let o = expect(&["policy", "--reference", csv.to_str().unwrap()], 0, "21 waypoints of 7 joints");
    assert!(stdout(&o).contains(&format!("dt = {time_step} s")), "{}", stdout(&o));
    expect(&["policy", "--reference", csv.to_str().unwrap(), "--dt", "0.01"], 1, "disagrees with the time column");
    // One joint is a reference too (--slice was parsed even without --plot).
    let one = dir.path().join("one.csv");
    std::fs::write(&one, "time,panda_joint4\n0,-2.0\n0.1,-1.9\n0.2,-1.8\n").unwrap();
    expect(&["policy", "--reference", one.to_str().unwrap()], 0, "3 waypoints of 1 joints");
    let cases: [(&str, &str); 6] = [
        ("0,0,0\n0.1,0.1,0.1\n", "is the header missing?"),
        ("time,panda_joint1,panda_joint1\n0,0,0\n0.1,0,0\n", "named twice"),
        (
            "time,panda_jont1\n0,0\n0.1,0\n",
            "names joint 'panda_jont1', which panda has no movable joint of (did you mean panda_joint1",
        ),
        // Finite values whose velocity is not: the waypoint, readably.
        ("time,panda_joint1\n0,1e308\n0.1,-1e308\n", "waypoint 1: joint 'panda_joint1' moves from 1e308 to -1e308"),
        ("time,panda_joint1\n0,0\n0.1,9\n", "joint 'panda_joint1' = 9 is outside its limits"),
        ("slice,time,panda_joint1\n1,0.1,0\n2,0.2,0\n", "its first column is 'slice'"),
    ];
    for (text, message) in cases {
        std::fs::write(&one, text).unwrap();
        expect(&["policy", "--reference", one.to_str().unwrap()], 1, message);
    }
}

#[test]
fn demo_says_what_it_does() {
    let o = expect(&["demo", "--help"], 0, "reach-and-grasp");
    let help = stdout(&o);
    assert!(!help.contains("manipulability") && !help.contains("elbow sweep"), "{help}");
    expect(&["demo", "--steps", "1"], 2, "[2, 1000]");
}

#[test]
fn moveit_inputs_that_are_wrong_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let problems = common::unpack_mbm(dir.path());
    let (urdf, srdf) = (common::mbm().join("panda_spherized.urdf"), common::mbm().join("panda.srdf"));
    let request = problems.join("box_panda/request0001.yaml");
    let moveit = |scene: &Path, request: &Path| {
        let args = ["--urdf", urdf.to_str().unwrap(), "--srdf", srdf.to_str().unwrap()];
        let mut v: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        v.extend(["--scene".into(), scene.display().to_string(), "--request".into(), request.display().to_string()]);
        v
    };
    // The request passed as the scene was an empty scene.
    let args = [vec!["check".to_string()], moveit(&request, &request)].concat();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    expect(&args, 1, "looks like a motion plan request");
    // A start beyond a limit: "valid … collision-free" in check, start_invalid without a reason in plan.
    let text = std::fs::read_to_string(&request).unwrap().replace("position: [0, -0.785,", "position: [0, -1.9,");
    let bad = dir.path().join("bad_request.yaml");
    std::fs::write(&bad, text).unwrap();
    let scene = problems.join("box_panda/scene0001.yaml");
    for command in ["check", "plan"] {
        let args = [vec![command.to_string()], moveit(&scene, &bad)].concat();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        expect(&args, 1, "start_state: joint 'panda_joint2' (index 1) = -1.9 is outside its limits");
    }
}

#[test]
fn tandem_simd_chooses_the_fast_path_variant() {
    let run = |simd: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_tandem"))
            .args(["check", "builtin:panda_reach", "--json"])
            .env("TANDEM_SIMD", simd)
            .current_dir(common::repo())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
        (v["fast_path"].as_str().unwrap().to_string(), stderr(&o))
    };
    assert_eq!(run("baseline").0, "baseline");
    let best = tandem::collision::SimdLevel::best_up_to(None).name();
    assert_eq!(run("").0, best);
    let (level, warning) = run("sse9");
    assert!(level == best && warning.contains("TANDEM_SIMD=sse9"), "{warning}");
    if tandem::collision::SimdLevel::Avx2.is_available() {
        assert_eq!(run("avx2").0, "avx2");
    }
}

#[test]
fn arbitrate_ranges_and_the_learned_mode_are_usage_errors() {
    for (option, value) in [("--rate", "0"), ("--rate", "NaN"), ("--rate", "1001"), ("--speed", "3"), ("--speed", "0")]
    {
        let o = expect(&["arbitrate", "builtin:panda_grasp_box", option, value], 2, "outside the allowed range");
        assert!(stderr(&o).contains(option), "{option} {value}: {}", stderr(&o));
    }
    expect(&["arbitrate", "builtin:panda_grasp_box", "--rate", "fast"], 2, "is not a number");
    // The learned mode names the option it needs, not a Rust function.
    let o = expect(&["arbitrate", "builtin:planar_pick", "--mode", "learned"], 2, "--arbiter");
    assert!(!stderr(&o).contains("with_arbitration_policy"), "{}", stderr(&o));
}

/// Training commands check their output before training: a path that
/// cannot be written fails at once, with no training progress printed.
#[test]
fn training_checks_its_output_before_it_trains() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "").unwrap();
    let out = file.join("actor.safetensors");
    let o = expect(&["learn", "arbitration", "--episodes", "20", "--out", out.to_str().unwrap()], 1, "cannot access");
    assert!(stderr(&o).contains("a-file"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("episode 10"), "trained before checking --out: {}", stderr(&o));
    // learn policy: the output is checked before the dataset is even read.
    let out = file.join("policy.safetensors");
    let o =
        expect(&["learn", "policy", "--data", "no-such-dataset", "--out", out.to_str().unwrap()], 1, "cannot access");
    assert!(stderr(&o).contains("a-file") && !stderr(&o).contains("no-such-dataset"), "{}", stderr(&o));
    // A good --out is left without stray files when training fails later.
    let good = dir.path().join("sub").join("p.safetensors");
    expect(&["learn", "policy", "--data", "no-such-dataset", "--out", good.to_str().unwrap()], 1, "no-such-dataset");
    assert!(!good.exists(), "the writability check left {}", good.display());
}

/// Network sizes are bounded where they enter: `--hidden 50000,50000`
/// aborted allocating 10 GB, 2^64 - 1 overflowed a capacity, 0 printed a
/// candle backtrace; too many layers are named before the data is read.
#[test]
fn network_sizes_are_bounded_before_training() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.safetensors");
    let learn = |hidden: &str| {
        ["learn", "policy", "--data", "no-such-dataset", "--hidden", hidden, "--out", out.to_str().unwrap()]
            .map(String::from)
    };
    for (hidden, value) in [("50000,50000", "50000"), ("18446744073709551615", "18446744073709551615"), ("0", "0")] {
        let args = learn(hidden);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        expect(&args, 2, &format!("invalid value '{value}' for '--hidden"));
    }
    let args = learn("1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17");
    let o = expect(&args.iter().map(String::as_str).collect::<Vec<_>>(), 1, "--hidden must be 1 … 16 layer widths");
    assert!(!stderr(&o).contains("no-such-dataset"), "{}", stderr(&o));
    expect(&["learn", "policy", "--data", "d", "--learning-rate", "NaN", "--out", "p"], 2, "--learning-rate");
}

/// The planar task on arms of one and two joints (the planar gripper's
/// chain cut short; on one joint, the cylinders moved onto its line).
fn small_planar_problems(dir: &Path) -> [(String, &'static str); 2] {
    let two = problem_with(
        dir,
        "planar_pick.toml",
        r#"chain = ["world", "gripper_tcp"]"#,
        r#"chain = ["world", "carriage_y"]"#,
    );
    let text = std::fs::read_to_string(&two).unwrap().replace("q = [0.25, 0.05, 0.0]", "q = [0.25, 0.05]");
    let urdf = common::repo().join("problems/robots/planar/planar_gripper.urdf");
    let text = text.replace("robots/planar/planar_gripper.urdf", urdf.to_str().unwrap());
    std::fs::write(&two, &text).unwrap();
    let one = dir.join("one_joint.toml");
    let text = text
        .replace(r#"chain = ["world", "carriage_y"]"#, r#"chain = ["world", "carriage_x"]"#)
        .replace("q = [0.25, 0.05]", "q = [0.25]")
        .replace("position = [0.12, 0.42, 0.075]", "position = [0.12, 0.0, 0.075]")
        .replace("position = [0.38, 0.42, 0.075]", "position = [0.38, 0.0, 0.075]");
    std::fs::write(&one, text).unwrap();
    [(two, "two joints"), (one.to_str().unwrap().to_string(), "one joint")]
}

/// Every mode ticks on arms of one and two joints without panicking (the
/// task-space natural gradient indexed a 3 × 3 metric in an n × n buffer),
/// and --field, which draws joints 1 and 2, refuses a one-joint arm.
#[test]
fn every_mode_runs_on_arms_of_one_and_two_joints() {
    let dir = tempfile::tempdir().unwrap();
    for (problem, what) in small_planar_problems(dir.path()) {
        for mode in [
            "direct",
            "blend-timid",
            "blend-aggressive",
            "avoid",
            "natural-gradient",
            "natural-gradient-joint",
            "constrained",
            "sos",
        ] {
            for operator in ["straightline", "approach"] {
                let o = tandem(&["arbitrate", &problem, "--mode", mode, "--operator", operator, "--json"]);
                assert!(matches!(o.status.code(), Some(0 | 3)), "{what}, {mode}, {operator}: {}", stderr(&o));
                let report: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
                assert_eq!(report["hard_violations"], 0, "{what}, {mode}, {operator}: {report}");
            }
        }
    }
    let [_, (one, _)] = small_planar_problems(dir.path());
    let field = dir.path().join("field.svg");
    expect(&["arbitrate", &one, "--field", field.to_str().unwrap()], 1, "1 active joint");
}

/// serve checks its recording folder before it listens: an unwritable one
/// is an error at start, not a failure at every save shown only on the page.
#[test]
fn serve_refuses_a_recording_folder_it_cannot_write() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "").unwrap();
    let bad = file.join("recordings");
    let o =
        expect(&["serve", "--task", "planar", "--port", "0", "--record-dir", bad.to_str().unwrap()], 1, "--record-dir");
    assert!(stderr(&o).contains("a-file") && stderr(&o).contains("--no-record"), "{}", stderr(&o));
}

/// A goal no configuration within limits reaches, one inside an obstacle
/// and a start in collision: `plan`, `solve` and `arbitrate` exit 3 with
/// the status and reason (as JSON under `--json`, the command's usual
/// keys), where they exited 1 with nothing on stdout (a start in collision
/// read "the optimizer ended plan_failed" under `arbitrate`).
#[test]
fn problems_without_a_solution_exit_3_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let block = |at: &str| {
        format!(
            "[[scene.obstacles]]\nname = \"block\"\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = {at}\n\n[scene]\nallowed"
        )
    };
    let cases = [
        (
            "far",
            "position = [0.5, 0.3, 0.3]",
            "position = [3.0, 0.3, 0.3]".to_string(),
            "goal_invalid",
            "no joint configuration within limits reaches",
        ),
        (
            "inside",
            "[scene]\nallowed",
            block("[0.5, 0.3, 0.3]"),
            "goal_invalid",
            "reach the target but all collide (first: ",
        ),
        (
            "start",
            "[scene]\nallowed",
            block("[0.3, 0.0, 0.55]"),
            "start_invalid",
            "start: in collision: panda_hand and block",
        ),
    ];
    for (name, from, to, status, reason) in cases {
        let sub = dir.path().join(name);
        std::fs::create_dir_all(&sub).unwrap();
        let p = problem_with(&sub, "panda_reach.toml", from, &to);
        for command in ["plan", "solve", "arbitrate"] {
            expect(&[command, &p], 3, reason);
            let o = expect(&[command, &p, "--json"], 3, status);
            let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap_or_else(|e| panic!("{e}: {o:?}"));
            let (got_status, got_reason) = match command {
                "arbitrate" => (&v["reason"], &v["reason_detail"]),
                _ => (&v["status"], &v["reason"]),
            };
            assert_eq!(got_status, status, "{command} {name}: {v}");
            assert!(got_reason.as_str().unwrap().contains(reason), "{command} {name}: {v}");
            if command != "arbitrate" {
                assert_eq!(v["joints"].as_array().map(Vec::len), Some(7), "{command} {name}: {v}");
            } else {
                assert_eq!(v["outcome"], "failed", "{v}");
            }
        }
    }
    // A solved plan names its waypoints' joints too.
    let o = expect(&["plan", "builtin:panda_reach", "--json"], 0, "solved");
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["joints"][0], "panda_joint1", "{v}");
    assert_eq!(v["waypoints"][0].as_array().map(Vec::len), Some(7), "{v}");
}
