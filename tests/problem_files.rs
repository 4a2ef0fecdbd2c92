//! Problem files and problem families: every shipped file loads and makes
//! sense (collision-free start and goals, a reachable grasp target, a wall
//! that is actually in the way), families sample reproducibly, and every
//! kind of bad file is reported with its file name, line and key.

use std::path::{Path, PathBuf};
use tandem::collision::CollisionWorkspace;
use tandem::problem::{BUILTIN_PROBLEMS, Goal, ObjectiveKind, Problem, ProblemError, ProblemFamily};
use tandem::scene::Shape;
use tempfile::TempDir;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn shipped(name: &str) -> PathBuf {
    repo().join("problems").join(name)
}

// ---------------------------------------------------------------------------
// (a) The shipped problem files.

/// Problem files shipped in `problems/`, without the family file.
fn shipped_problem_names() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(repo().join("problems"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .filter(|p| !std::fs::read_to_string(p).unwrap().lines().any(|l| l.starts_with("base =")))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn every_shipped_problem_is_a_builtin() {
    let mut builtins: Vec<String> = BUILTIN_PROBLEMS.iter().map(|(n, _)| n.to_string()).collect();
    builtins.sort();
    assert_eq!(shipped_problem_names(), builtins);
    for (name, text) in BUILTIN_PROBLEMS {
        assert_eq!(std::fs::read_to_string(shipped(&format!("{name}.toml"))).unwrap(), text, "{name}");
    }
}

#[test]
fn shipped_problems_load_from_file_and_as_builtins() {
    for (name, _) in BUILTIN_PROBLEMS {
        let path = shipped(&format!("{name}.toml"));
        let file = Problem::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let builtin = Problem::builtin(name).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(file.name, name);
        assert_eq!(builtin.name, name);
        assert!(!file.description.is_empty(), "{name} has no description");
        assert_eq!(file.origin, path.display().to_string());
        assert_eq!(builtin.origin, format!("<builtin:{name}>"));
        assert_eq!(file.start, builtin.start, "{name}");
        assert_eq!(file.goal, builtin.goal, "{name}");
        assert_eq!(file.planner, builtin.planner, "{name}");
        assert_eq!(file.optimizer, builtin.optimizer, "{name}");
        assert_eq!(file.robot.joint_names(), builtin.robot.joint_names(), "{name}");
        let panda = name.starts_with("panda_");
        let (dof, gripper) = if panda { (7, "panda_hand_tcp") } else { (3, "gripper_tcp") };
        assert_eq!(file.robot.nq(), dof, "{name}");
        assert_eq!(file.start.len(), dof, "{name}");
        assert_eq!(file.robot_spec.gripper.as_deref(), Some(gripper), "{name}");
        let names = |p: &Problem| {
            let o: Vec<String> = p.scene.obstacles().iter().map(|o| o.name.clone()).collect();
            let b: Vec<String> = p.scene.objects().iter().map(|o| o.name.clone()).collect();
            (o, b, p.scene.allowed_contacts().to_vec())
        };
        assert_eq!(names(&file), names(&builtin), "{name}");
        if panda {
            assert!(file.scene.obstacle("table").is_some(), "{name} has a table");
            assert!(file.scene.is_contact_allowed("table", "panda_link0"), "{name}");
        }
        // Every shipped problem constrains joint limits and collisions.
        for feature in ["joint_limits", "collision"] {
            let o = file.optimizer.objectives.iter().find(|o| o.feature == feature).unwrap();
            assert_eq!(o.kind, ObjectiveKind::Inequality, "{name}: {feature}");
        }
    }
}

#[test]
fn unknown_builtin_lists_the_builtins() {
    let e = Problem::builtin("panda_fly").unwrap_err().to_string();
    assert!(e.starts_with("<builtin:panda_fly>: "), "{e}");
    assert!(e.contains("panda_reach, panda_reach_obstacle, panda_grasp_box"), "{e}");
}

#[test]
fn shipped_starts_and_joint_goals_are_collision_free() {
    for (name, _) in BUILTIN_PROBLEMS {
        for problem in [Problem::from_file(shipped(&format!("{name}.toml"))).unwrap(), Problem::builtin(name).unwrap()]
        {
            let model = problem.collision_model().unwrap();
            let mut ws = CollisionWorkspace::new(&model);
            assert!(model.collision_free(&mut ws, &problem.start).unwrap(), "{name}: start collides");
            if let Goal::Joints(q) = &problem.goal {
                assert!(model.collision_free(&mut ws, q).unwrap(), "{name}: goal collides");
            }
        }
    }
}

#[test]
fn goal_kinds_of_the_shipped_problems() {
    let reach = Problem::builtin("panda_reach").unwrap();
    let Goal::Pose { frame, position, orientation, axis_alignment } = &reach.goal else { panic!("{:?}", reach.goal) };
    assert_eq!(frame, "panda_hand_tcp");
    assert_eq!(position.as_slice(), &[0.5, 0.3, 0.3]);
    assert!(orientation.is_none());
    let (axis, direction) = axis_alignment.unwrap();
    assert_eq!(axis, 2);
    assert_eq!(direction.as_slice(), &[0.0, 0.0, -1.0]);
    assert!(reach.grasp_target().is_none());

    assert!(matches!(Problem::builtin("panda_reach_obstacle").unwrap().goal, Goal::Joints(_)));
}

#[test]
fn grasp_goal_target_pose_exists() {
    let problem = Problem::from_file(shipped("panda_grasp_box.toml")).unwrap();
    assert_eq!(problem.goal, Goal::Grasp { object: "box".into(), grasp: "grasp".into() });
    let target = problem.grasp_target().expect("the grasp target exists");
    // Above the middle of the box at (0.5, 0.1, 0.06), within the fingers'
    // reach below its top (tests/grasp.rs checks the depth), pointing down.
    assert!((target.translation.vector.xy() - nalgebra::Vector2::new(0.5, 0.1)).norm() < 1e-12);
    assert!(target.translation.z > 0.09 && target.translation.z < 0.12, "{}", target.translation.z);
    assert!((target.rotation * nalgebra::Vector3::z() + nalgebra::Vector3::z()).norm() < 1e-12);
    let approach = problem.scene.grasp_pose("box", "approach").unwrap();
    assert!((approach.translation.z - 0.21).abs() < 1e-12);
}

#[test]
fn reach_obstacle_straight_motion_collides() {
    let problem = Problem::from_file(shipped("panda_reach_obstacle.toml")).unwrap();
    let Goal::Joints(goal) = &problem.goal else { panic!("{:?}", problem.goal) };
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    assert!(model.collision_free(&mut ws, &problem.start).unwrap());
    assert!(model.collision_free(&mut ws, goal).unwrap());
    assert!(!model.motion_free(&mut ws, &problem.start, goal, 0.01).unwrap(), "the wall is not in the way");
    // Without the wall the same motion is free: it is the wall that blocks it.
    let mut without = problem.clone();
    let mut scene = tandem::scene::Scene::new();
    for o in problem.scene.obstacles().iter().filter(|o| o.name != "wall") {
        scene.add_obstacle(o.clone()).unwrap();
    }
    for (a, b) in problem.scene.allowed_contacts() {
        scene.allow_contact(a.clone(), b.clone());
    }
    without.scene = scene;
    let model = without.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    assert!(model.motion_free(&mut ws, &problem.start, goal, 0.01).unwrap());
}

#[test]
fn relative_paths_resolve_against_the_file_folder() {
    let dir = TempDir::new().unwrap();
    std::fs::create_dir(dir.path().join("robot")).unwrap();
    std::fs::copy(shipped("robots/panda/panda.urdf"), dir.path().join("robot/arm.urdf")).unwrap();
    // A tetrahedron, as OBJ and as ASCII STL.
    std::fs::write(
        dir.path().join("tet.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n",
    )
    .unwrap();
    let facet = |a: &str, b: &str, c: &str| {
        format!("facet normal 0 0 0\nouter loop\nvertex {a}\nvertex {b}\nvertex {c}\nendloop\nendfacet\n")
    };
    let (o, x, y, z) = ("0 0 0", "1 0 0", "0 1 0", "0 0 1");
    let stl =
        format!("solid tet\n{}{}{}{}endsolid tet\n", facet(o, x, y), facet(o, x, z), facet(o, y, z), facet(x, y, z));
    std::fs::write(dir.path().join("tet.stl"), stl).unwrap();
    let text = r#"name = "relative"

[robot]
urdf = "robot/arm.urdf"
joints = ["panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4", "panda_joint5", "panda_joint6", "panda_joint7"]

[start]
q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]

[goal]
q = [0.5, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]

[[scene.obstacles]]
name = "obj_mesh"
shape = "mesh"
mesh = "tet.obj"
scale = [0.1, 0.2, 0.3]
position = [0.6, 0.5, 0.5]

[[scene.obstacles]]
name = "stl_mesh"
shape = "mesh"
mesh = "tet.stl"
position = [0.6, -0.5, 0.5]
quaternion = [0.0, 0.0, 0.7071067811865476, 0.7071067811865476]
"#;
    let path = dir.path().join("p.toml");
    std::fs::write(&path, text).unwrap();
    // Load from another working directory's point of view: the paths are
    // relative to the file, not to the process.
    let problem = Problem::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(problem.robot_spec.urdf, dir.path().join("robot/arm.urdf"));
    // The hull of the tetrahedron, scaled per axis: its farthest vertex is
    // (0, 0, 0.3) for the OBJ, (1, 0, 0) etc. for the unscaled STL.
    for (name, radius) in [("obj_mesh", 0.3), ("stl_mesh", 1.0)] {
        let shape = &problem.scene.obstacle(name).unwrap().shape;
        let Shape::Convex(hull) = shape else { panic!("{name} is not a hull: {shape:?}") };
        assert_eq!(hull.vertex_count(), 4, "{name}");
        assert!((shape.bounding_radius() - radius).abs() < 1e-12, "{name}: {}", shape.bounding_radius());
    }
    let rotated = problem.scene.obstacle("stl_mesh").unwrap().pose.rotation;
    assert!((rotated * nalgebra::Vector3::x() - nalgebra::Vector3::y()).norm() < 1e-12);
}

#[test]
fn rpy_is_fixed_axis_roll_pitch_yaw_like_urdf() {
    let dir = TempDir::new().unwrap();
    let text = problem(&[
        ROBOT,
        START,
        JOINT_GOAL,
        "[[scene.obstacles]]\nname = \"a\"\nshape = \"sphere\"\nradius = 0.05\nposition = [1.0, 1.0, 1.0]\nrpy = [0.3, 0.2, 0.1]\n",
        "[[scene.obstacles]]\nname = \"b\"\nshape = \"sphere\"\nradius = 0.05\nposition = [1.0, -1.0, 1.0]\n",
    ]);
    let path = dir.path().join("p.toml");
    std::fs::write(&path, text).unwrap();
    let problem = Problem::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    let r = problem.scene.obstacle("a").unwrap().pose.rotation;
    let (x, y, z) = (nalgebra::Vector3::x_axis(), nalgebra::Vector3::y_axis(), nalgebra::Vector3::z_axis());
    let expected = nalgebra::Rotation3::from_axis_angle(&z, 0.1)
        * nalgebra::Rotation3::from_axis_angle(&y, 0.2)
        * nalgebra::Rotation3::from_axis_angle(&x, 0.3);
    assert!((r.matrix() - expected.matrix()).norm() < 1e-12);
    let b = problem.scene.obstacle("b").unwrap().pose;
    assert_eq!(b.rotation, nalgebra::Rotation3::identity());
    assert_eq!(b.translation.vector.as_slice(), &[1.0, -1.0, 1.0]);
}

/// The ```toml blocks of problems/README.md.
fn readme_examples() -> Vec<String> {
    let readme = std::fs::read_to_string(repo().join("problems/README.md")).unwrap();
    readme.split("```toml\n").skip(1).map(|b| b.split("```").next().unwrap().to_string()).collect()
}

#[test]
fn readme_examples_load() {
    let examples = readme_examples();
    assert_eq!(examples.len(), 2, "a problem and a family example");
    let problem = Problem::from_str_with(&examples[0], "README problem", Some(&repo().join("problems")))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(problem.scene.objects().len(), 1);
    assert_eq!(problem.scene.obstacles().len(), 2);
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    assert!(model.collision_free(&mut ws, &problem.start).unwrap());
    // The family example, with its base made absolute.
    let dir = TempDir::new().unwrap();
    let base = shipped("panda_grasp_box.toml");
    let text = examples[1].replace("\"panda_grasp_box.toml\"", &format!("\"{}\"", base.display()));
    std::fs::write(dir.path().join("family.toml"), text).unwrap();
    let family = ProblemFamily::from_file(dir.path().join("family.toml")).unwrap_or_else(|e| panic!("{e}"));
    let sample = family.sample(0, 0).unwrap();
    assert_eq!(sample.problem.name, "grasp_anywhere#0");
}

// ---------------------------------------------------------------------------
// (b) The shipped family.

fn family() -> ProblemFamily {
    ProblemFamily::from_file(shipped("panda_grasp_family.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Everything sampled, as comparable text: start, object poses, obstacles
/// (name, shape, pose).
fn fingerprint(p: &Problem) -> String {
    let objects: Vec<String> = p.scene.objects().iter().map(|o| format!("{} {:?}", o.name, o.pose)).collect();
    let obstacles: Vec<String> =
        p.scene.obstacles().iter().map(|o| format!("{} {:?} {:?}", o.name, o.shape, o.pose)).collect();
    format!("{}\n{:?}\n{objects:?}\n{obstacles:?}", p.name, p.start)
}

#[test]
fn family_loads() {
    let f = family();
    assert_eq!(f.name, "panda_grasp_family");
    assert!(!f.description.is_empty());
    assert_eq!(f.base.name, "panda_grasp_box");
    assert!(matches!(f.base.goal, Goal::Grasp { .. }));
}

#[test]
fn family_samples_are_deterministic() {
    let f = family();
    let a = f.sample(7, 3).unwrap();
    let b = family().sample(7, 3).unwrap();
    assert_eq!(a.id, 3);
    assert_eq!(a.seed, b.seed);
    assert_eq!(a.seed, tandem::problem::sample_seed(7, 3));
    assert_eq!(fingerprint(&a.problem), fingerprint(&b.problem));
    assert_eq!(a.problem.start, b.problem.start);
    assert_eq!(a.problem.scene.object("box").unwrap().pose, b.problem.scene.object("box").unwrap().pose);
    assert_eq!(a.skipped_obstacles, b.skipped_obstacles);
    assert_eq!(a.problem.name, "panda_grasp_family#3");
    // Sampling other ids in between changes nothing.
    for id in 0..5 {
        f.sample(7, id).unwrap();
    }
    assert_eq!(fingerprint(&f.sample(7, 3).unwrap().problem), fingerprint(&a.problem));
    // Other ids and other seeds give other problems.
    let c = f.sample(7, 4).unwrap();
    assert_ne!(a.problem.start, c.problem.start);
    assert_ne!(a.problem.scene.object("box").unwrap().pose, c.problem.scene.object("box").unwrap().pose);
    let d = f.sample(8, 3).unwrap();
    assert_ne!(a.problem.start, d.problem.start);
    // The base problem is left alone.
    assert_eq!(f.base.start, Problem::builtin("panda_grasp_box").unwrap().start);
}

#[test]
fn family_samples_are_valid() {
    let f = family();
    let base_box = f.base.scene.object("box").unwrap().pose;
    let mut fingerprints = std::collections::HashSet::new();
    let mut random_obstacles = 0;
    for id in 0..200 {
        let s = f.sample(1, id).unwrap();
        let p = &s.problem;
        assert!(fingerprints.insert(fingerprint(p)), "sample {id} repeats an earlier one");
        for ((v, l), name) in p.start.iter().zip(p.robot.limits()).zip(p.robot.joint_names()) {
            assert!(l.contains(*v), "sample {id}: {name} = {v} outside [{}, {}]", l.lower, l.upper);
        }
        for (v, b) in p.start.iter().zip(&f.base.start) {
            assert!((v - b).abs() <= 0.3 + 1e-12, "sample {id}: start jitter beyond 0.3 rad");
        }
        // The box moved within its ranges and stays on the table.
        let b = p.scene.object("box").unwrap().pose;
        let t = b.translation.vector;
        assert!((0.4..=0.6).contains(&t.x) && (-0.3..=0.3).contains(&t.y), "sample {id}: box at {t:?}");
        assert_eq!(t.z, base_box.translation.z);
        assert!((b.rotation * nalgebra::Vector3::z() - nalgebra::Vector3::z()).norm() < 1e-12);
        assert!(p.grasp_target().is_some());

        let model = p.collision_model().unwrap();
        let mut ws = CollisionWorkspace::new(&model);
        assert!(model.collision_free(&mut ws, &p.start).unwrap(), "sample {id}: start collides");
        let random: Vec<&str> =
            p.scene.obstacles().iter().map(|o| o.name.as_str()).filter(|n| n.starts_with("random_")).collect();
        assert!(random.len() + s.skipped_obstacles <= 2, "sample {id}");
        random_obstacles += random.len();
        // Every random obstacle clears the start arm by the family's clearance.
        for d in model.distances(&mut ws, &p.start, 0.05 - 1e-9).unwrap() {
            let (a, b) = model.pair_names(d.pair);
            assert!(
                !random.contains(&a) && !random.contains(&b),
                "sample {id}: {a} and {b} are {} m apart",
                d.signed.distance
            );
        }
        for o in p.scene.obstacles().iter().filter(|o| random.contains(&o.name.as_str())) {
            let c = o.pose.translation.vector;
            assert!((0.25..=0.75).contains(&c.x) && (-0.6..=0.6).contains(&c.y) && (0.25..=0.8).contains(&c.z));
        }
    }
    assert!(random_obstacles > 100, "only {random_obstacles} random obstacles in 200 samples");
}

// ---------------------------------------------------------------------------
// (c) Errors: every kind names the file, the line and the key.

fn urdf() -> String {
    format!("{}/problems/robots/panda/panda.urdf", env!("CARGO_MANIFEST_DIR"))
}

const ROBOT: &str = r#"[robot]
urdf = "@URDF@"
chain = ["panda_link0", "panda_hand_tcp"]
hold = { panda_finger_joint1 = 0.04 }
gripper = "panda_hand_tcp"
"#;

const START: &str = "[start]\nq = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\n";

const JOINT_GOAL: &str = "[goal]\nq = [0.5, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\n";

const BOX: &str = r#"[[scene.objects]]
name = "box"
shape = "box"
size = [0.06, 0.06, 0.12]
position = [0.5, 0.1, 0.06]
grasps = [
    { name = "top", position = [0.0, 0.0, 0.06], rpy = [3.141592653589793, 0.0, 0.0] },
]
"#;

/// A problem file of these sections, after a `name`.
fn problem(sections: &[&str]) -> String {
    let mut text = String::from("name = \"bad\"\n");
    for s in sections {
        text.push('\n');
        text.push_str(s);
    }
    text.replace("@URDF@", &urdf())
}

/// 1-based line of the only line of `text` containing `marker`.
#[track_caller]
fn line_of(text: &str, marker: &str) -> usize {
    let lines: Vec<usize> = text.lines().enumerate().filter(|(_, l)| l.contains(marker)).map(|(i, _)| i + 1).collect();
    assert_eq!(lines.len(), 1, "`{marker}` is on lines {lines:?} of\n{text}");
    lines[0]
}

/// Writes `text` as `file_name` in a fresh folder, loads it with `load`,
/// and checks the error reads "path:line: key: …message…", the line being
/// that of `marker`.
#[track_caller]
fn expect<T: std::fmt::Debug>(
    load: fn(&Path) -> Result<T, ProblemError>,
    file_name: &str,
    text: &str,
    marker: &str,
    key: &str,
    message: &str,
) {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join(file_name);
    std::fs::write(&path, text).unwrap();
    let e = load(&path).expect_err("the file loads");
    let line = line_of(text, marker);
    let shown = e.to_string();
    let head = format!("{}:{line}: {key}: ", path.display());
    assert!(shown.starts_with(&head), "expected `{head}…`\n     got `{shown}`\nfor\n{text}");
    assert!(shown.contains(message), "`{message}` is not in `{shown}`");
    let ProblemError::Invalid { file, line: Some(l), key: Some(k), .. } = &e else { panic!("{e:?}") };
    assert_eq!((file.as_str(), *l as usize, k.as_str()), (path.display().to_string().as_str(), line, key));
}

#[track_caller]
fn expect_problem_error(text: &str, marker: &str, key: &str, message: &str) {
    expect(|p| Problem::from_file(p), "bad.toml", text, marker, key, message);
}

#[track_caller]
fn expect_family_error(text: &str, marker: &str, key: &str, message: &str) {
    expect(|p| ProblemFamily::from_file(p), "family.toml", text, marker, key, message);
}

#[test]
fn the_error_fixture_is_valid() {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("good.toml");
    let grasp = "[goal]\ngrasp = \"box\"\n";
    for text in [problem(&[ROBOT, START, JOINT_GOAL]), problem(&[ROBOT, START, grasp, BOX])] {
        std::fs::write(&path, &text).unwrap();
        Problem::from_file(&path).unwrap_or_else(|e| panic!("{e}\n{text}"));
    }
    let p = Problem::from_file(&path).unwrap();
    // The first grasp frame is the default.
    assert_eq!(p.goal, Goal::Grasp { object: "box".into(), grasp: "top".into() });
}

#[test]
fn missing_file() {
    let e = Problem::from_file("/nonexistent/p.toml").unwrap_err().to_string();
    assert!(e.starts_with("cannot read /nonexistent/p.toml: "), "{e}");
}

#[test]
fn toml_syntax_error() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nhorizon = = 50\n"]);
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, &text).unwrap();
    let e = Problem::from_file(&path).unwrap_err().to_string();
    let head = format!("{}:{}: ", path.display(), line_of(&text, "horizon = = 50"));
    assert!(e.starts_with(&head), "expected `{head}…`, got `{e}`");
}

#[test]
fn unknown_key_at_top_level() {
    let text =
        problem(&[ROBOT, START, JOINT_GOAL]).replacen("name = \"bad\"\n", "name = \"bad\"\ncolour = \"red\"\n", 1);
    expect_problem_error(&text, "colour", "colour", "unknown field `colour`");
}

#[test]
fn unknown_key_in_a_grasp() {
    let text =
        problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace("rpy = [3.141592653589793", "rpyy = [3.141592653589793");
    expect_problem_error(&text, "rpyy", "scene.objects[0].grasps[0].rpyy", "unknown field `rpyy`");
}

#[test]
fn unknown_key_in_robot() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("gripper =", "end_effector =");
    expect_problem_error(&text, "end_effector", "robot.end_effector", "unknown field `end_effector`");
}

#[test]
fn unknown_key_in_an_obstacle() {
    let wall = "[[scene.obstacles]]\nname = \"wall\"\nshape = \"sphere\"\nradius = 0.1\n\n\
                [[scene.obstacles]]\nname = \"post\"\nshape = \"sphere\"\nradios = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "radios", "scene.obstacles[1].radios", "unknown field `radios`");
}

#[test]
fn unknown_key_in_an_objective() {
    let objectives = "[[optimizer.objectives]]\nfeature = \"control\"\n\n\
                      [[optimizer.objectives]]\nfeature = \"collision\"\nkind = \"ineq\"\nweight = 2.0\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, objectives]);
    expect_problem_error(&text, "weight", "optimizer.objectives[1].weight", "unknown field `weight`");
}

#[test]
fn string_for_a_number() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nhorizon = \"fifty\"\n"]);
    expect_problem_error(&text, "fifty", "optimizer.horizon", "invalid type");
}

#[test]
fn two_element_position() {
    let wall = "[[scene.obstacles]]\nname = \"wall\"\nshape = \"sphere\"\nradius = 0.1\nposition = [0.5, 0.2]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "position = [0.5, 0.2]", "scene.obstacles[0].position", "3");
}

#[test]
fn negative_radius() {
    let wall = "[[scene.obstacles]]\nname = \"post\"\nshape = \"cylinder\"\nradius = -0.1\nlength = 0.5\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "radius = -0.1", "scene.obstacles[0].radius", "must be positive, got -0.1");
}

#[test]
fn zero_box_size() {
    let wall =
        "[[scene.obstacles]]\nname = \"wall\"\nshape = \"box\"\nsize = [\n    0.3,\n    0.0, # zero\n    0.5,\n]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "# zero", "scene.obstacles[0].size[1]", "must be positive, got 0");
}

#[test]
fn box_size_with_two_values() {
    let wall = "[[scene.obstacles]]\nname = \"wall\"\nshape = \"box\"\nsize = [0.3, 0.5]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "size", "scene.obstacles[0].size", "must hold 3 lengths, has 2");
}

#[test]
fn missing_shape_dimension() {
    let wall = "[[scene.obstacles]]\nname = \"ball\"\nshape = \"sphere\"\nposition = [0.5, 0.0, 0.5]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    // A missing key is reported at the header of its table.
    expect_problem_error(&text, "[[scene.obstacles]]", "scene.obstacles[0].radius", "a sphere needs `radius`");
}

#[test]
fn dimension_of_another_shape() {
    let wall = "[[scene.obstacles]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.1\nlength = 0.2\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "length", "scene.obstacles[0].length", "does not apply to a sphere");
}

#[test]
fn table_with_zero_thickness() {
    let table = "[scene.table]\ntop = [0.3, 0.0, 0.0]\nsize = [1.4, 1.6]\nthickness = 0.0\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, table]);
    expect_problem_error(&text, "thickness", "scene.table.thickness", "must be positive");
}

#[test]
fn negative_padding() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("gripper = \"panda_hand_tcp\"\n", "padding = -0.01\n");
    expect_problem_error(&text, "padding", "robot.padding", "must be zero or positive, got -0.01");
}

#[test]
fn start_outside_a_joint_limit() {
    let start = "[start]\nq = [\n    0.0,\n    -0.785,\n    0.0,\n    0.25,\n    0.0,\n    1.571,\n    0.785,\n]\n";
    let text = problem(&[ROBOT, start, JOINT_GOAL]);
    expect_problem_error(&text, "0.25,", "start.q[3]", "panda_joint4 = 0.25 is outside its limits [-3.0718, -0.0698]");
}

#[test]
fn goal_outside_a_joint_limit() {
    let goal = "[goal]\nq = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 3.0]\n";
    let text = problem(&[ROBOT, START, goal]);
    expect_problem_error(&text, "3.0]", "goal.q[6]", "panda_joint7 = 3 is outside its limits");
}

#[test]
fn wrong_number_of_start_values() {
    let start = "[start]\nq = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571]\n";
    let text = problem(&[ROBOT, start, JOINT_GOAL]);
    expect_problem_error(&text, "1.571]", "start.q", "has 6 values, the robot has 7 active joints (panda_joint1, ");
}

#[test]
fn horizon_of_one() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nduration = 3.0\nhorizon = 1\n"]);
    expect_problem_error(&text, "horizon", "optimizer.horizon", "must be between 2 and 100000, got 1");
}

#[test]
fn zero_planner_step() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[planner]\nseed = 3\nstep = 0.0\n"]);
    expect_problem_error(&text, "step", "planner.step", "must be positive, got 0");
}

#[test]
fn more_out_of_range_values() {
    let pose_goal =
        "[goal]\nframe = \"panda_hand_tcp\"\nposition = [0.5, 0.0, 0.4]\naxis = \"z\"\ndirection = [0.0, 0.0, -1.0]\n";
    let table = "[scene.table]\ntop = [0.3, 0.0, 0.0]\nsize = [1.4, 1.6]\n";
    let settings = "[planner]\nmax_iterations = 10\n\n[optimizer]\norder = 2\nmax_iterations = 20\n";
    let objective = "[[optimizer.objectives]]\nfeature = \"scalar_product\"\nframes = [\"panda_hand_tcp\", \"world\"]\naxes = [\"z\", \"z\"]\nscale = 1.0\norder = 0\nmargin = 0.0\ntarget = [0.0]\n";
    let good = problem(&[ROBOT, START, pose_goal, table, settings, objective]);
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("good.toml"), &good).unwrap();
    Problem::from_file(dir.path().join("good.toml")).unwrap_or_else(|e| panic!("{e}"));
    let cases = [
        ("frame = \"panda_hand_tcp\"", "frame = \"hand\"", "goal.frame", "unknown frame 'hand'"),
        ("axis = \"z\"", "axis = \"w\"", "goal.axis", "must be x, y or z"),
        ("direction = [0.0, 0.0, -1.0]", "direction = [0.0, 0.0, 0.0]", "goal.direction", "non-zero finite vector"),
        ("direction = [0.0, 0.0, -1.0]", "# no direction", "goal", "`axis` and `direction` go together"),
        ("size = [1.4, 1.6]", "size = [0.0, 1.6]", "scene.table.size[0]", "must be positive, got 0"),
        ("max_iterations = 10", "max_iterations = 0", "planner.max_iterations", "must be at least 1"),
        ("order = 2", "order = 3", "optimizer.order", "must be 1 or 2, got 3"),
        ("max_iterations = 20", "max_iterations = 0", "optimizer.max_iterations", "must be at least 1"),
        (
            "axes = [\"z\", \"z\"]",
            "axes = [\"z\"]",
            "optimizer.objectives[0].axes",
            "scalar_product reads 2 axis name(s)",
        ),
        ("axes = [\"z\", \"z\"]", "axes = [\"z\", \"q\"]", "optimizer.objectives[0].axes[1]", "must be x, y or z"),
        ("scale = 1.0", "scale = 0.0", "optimizer.objectives[0].scale", "must be positive, got 0"),
        ("order = 0", "order = 3", "optimizer.objectives[0].order", "must be 0, 1 or 2, got 3"),
        ("margin = 0.0", "margin = -0.1", "optimizer.objectives[0].margin", "must be zero or positive, got -0.1"),
        ("target = [0.0]", "target = [nan]", "optimizer.objectives[0].target[0]", "must be finite, got NaN"),
        ("target = [0.0]", "target = [0.0, 1.0]", "optimizer.objectives[0].target", "has 1 value(s); the target has 2"),
        ("target = [0.0]", "target = [-1.0]", "optimizer.objectives[0].target", "with feature \"vector\""),
    ];
    for (from, to, key, message) in cases {
        assert_eq!(good.matches(from).count(), 1, "{from}");
        let text = good.replace(from, to);
        let marker = if key == "goal" { "[goal]" } else { to.lines().next().unwrap() };
        expect_problem_error(&text, marker, key, message);
    }
}

#[test]
fn objective_time_backwards() {
    let o = "[[optimizer.objectives]]\nfeature = \"joint_state\"\ntime = [0.8, 0.2]\nkind = \"eq\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "time", "optimizer.objectives[0].time", "0 ≤ start ≤ end ≤ 1, got [0.8, 0.2]");
}

#[test]
fn unknown_feature() {
    let o = "[[optimizer.objectives]]\nfeature = \"control\"\n\n[[optimizer.objectives]]\nfeature = \"speed\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(
        &text,
        "speed",
        "optimizer.objectives[1].feature",
        "unknown feature 'speed' (expected one of ",
    );
}

#[test]
fn targets_fit_their_feature() {
    let cases = [
        ("feature = \"joint_limits\"\nkind = \"ineq\"\ntarget = [0.0]\n", "feature joint_limits takes no target"),
        ("feature = \"joint_state\"\ntarget = [0.0, 0.0]\n", "has 7 value(s); the target has 2"),
        (
            "feature = \"vector\"\nframes = [\"panda_hand_tcp\", \"world\"]\naxes = [\"z\"]\ntarget = [0.0, -1.0]\n",
            "has 3 value(s)",
        ),
        (
            "feature = \"vector\"\nframes = [\"panda_hand_tcp\", \"world\"]\naxes = [\"z\", \"x\"]\n",
            "vector reads 1 axis name(s)",
        ),
    ];
    for (objective, message) in cases {
        let text = problem(&[ROBOT, START, JOINT_GOAL, &format!("[[optimizer.objectives]]\n{objective}")]);
        let line = objective.lines().last().unwrap();
        let key =
            if line.starts_with("axes") { "optimizer.objectives[0].axes" } else { "optimizer.objectives[0].target" };
        expect_problem_error(&text, line, key, message);
    }
}

#[test]
fn wrong_number_of_feature_frames() {
    let o = "[[optimizer.objectives]]\nfeature = \"position_difference\"\nframes = [\"panda_hand_tcp\"]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "frames", "optimizer.objectives[0].frames", "reads 2 frame(s), got 1");
}

#[test]
fn unknown_shape() {
    let wall = "[[scene.obstacles]]\nname = \"cone\"\nshape = \"cone\"\nradius = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "shape", "scene.obstacles[0].shape", "unknown shape 'cone' (expected box, sphere, ");
}

#[test]
fn unknown_objective_kind() {
    let o = "[[optimizer.objectives]]\nfeature = \"collision\"\nkind = \"hard\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(
        &text,
        "kind = \"hard\"",
        "optimizer.objectives[0].kind",
        "unknown kind 'hard' (expected sos, eq or ineq)",
    );
}

#[test]
fn non_unit_quaternion() {
    let o = "[[scene.obstacles]]\nname = \"b\"\nshape = \"sphere\"\nradius = 0.1\nquaternion = [0.0, 0.0, 0.0, 2.0]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "quaternion", "scene.obstacles[0].quaternion", "unit quaternion [x, y, z, w]");
}

#[test]
fn unknown_gripper_frame() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("\"panda_hand_tcp\"\n", "\"panda_hand_tpc\"\n");
    expect_problem_error(&text, "panda_hand_tpc", "robot.gripper", "panda_hand_tpc");
}

#[test]
fn grasp_of_a_missing_object() {
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"cup\"\n", BOX]);
    expect_problem_error(&text, "cup", "goal.grasp", "the scene has no object 'cup'");
}

#[test]
fn missing_grasp_frame() {
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"box\"\ngrasp_frame = \"side\"\n", BOX]);
    expect_problem_error(&text, "side", "goal.grasp_frame", "no grasp frame named 'side'");
}

#[test]
fn finger_pads_name_collision_elements() {
    let with = |keys: &str| {
        problem(&[ROBOT, START, JOINT_GOAL])
            .replace("gripper = \"panda_hand_tcp\"\n", &format!("gripper = \"panda_hand_tcp\"\n{keys}\n"))
    };
    Problem::from_str_with(&with("finger_pads = [\"panda_leftfinger_pad\", \"panda_rightfinger_pad\"]"), "ok", None)
        .unwrap();
    let text = with("finger_pads = [\"panda_leftfinger_pad\", \"panda_rightfinger_pda\"]");
    let message =
        "no collision element of the robot is named 'panda_rightfinger_pda' (did you mean panda_rightfinger_pad";
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[1]", message);
    let text = with("finger_pads = [\"panda_leftfinger\"]");
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[0]", "'panda_leftfinger' is a link");
    let text = format!(
        "{}\n[[scene.obstacles]]\nname = \"panda_leftfinger_pad\"\nshape = \"sphere\"\nradius = 0.05\nposition = [1.0, 1.0, 1.0]\n",
        with("finger_pads = [\"panda_leftfinger_pad\"]")
    );
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[0]", "a name apart from the scene's obstacles");
    let text = with("max_grasp_depth = -0.01");
    expect_problem_error(&text, "max_grasp_depth", "robot.max_grasp_depth", "must be positive, got -0.01");
    let text = problem(&[ROBOT, START, JOINT_GOAL])
        .replace("gripper = \"panda_hand_tcp\"\n", "finger_pads = [\"panda_leftfinger_pad\"]\n");
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[0]", "finger pads need `robot.gripper`");
}

#[test]
fn grasp_goal_without_a_gripper() {
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"box\"\n", BOX]).replace("gripper = \"panda_hand_tcp\"\n", "");
    expect_problem_error(&text, "grasp = \"box\"", "goal.grasp", "a grasp goal needs `robot.gripper`");
}

#[test]
fn grasp_of_an_object_without_grasp_frames() {
    let ball = "[[scene.objects]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.03\nposition = [0.5, 0.0, 0.03]\n";
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"ball\"\n", ball]);
    expect_problem_error(&text, "grasp = ", "goal.grasp", "object 'ball' has no grasp frame");
}

#[test]
fn objective_frame_naming_nothing() {
    let o = "[[optimizer.objectives]]\nfeature = \"position_difference\"\nframes = [\n    \"panda_hand_tcp\",\n    \"box/bottom\",\n]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX, o]);
    expect_problem_error(&text, "box/bottom", "optimizer.objectives[0].frames[1]", "'box/bottom' is neither");
}

#[test]
fn allowed_contact_naming_nothing() {
    let scene = "[scene]\nallowed_contacts = [[\"panda_link0\", \"table\"]]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, scene]);
    expect_problem_error(&text, "allowed", "scene.allowed_contacts[0][1]", "no link, obstacle or object named 'table'");
}

#[test]
fn duplicate_scene_names() {
    let table = "[scene.table]\ntop = [0.3, 0.0, 0.0]\nsize = [1.4, 1.6]\n\n\
                 [[scene.obstacles]]\nname = \"table\"\nshape = \"sphere\"\nradius = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, table]);
    expect_problem_error(
        &text,
        "name = \"table\"",
        "scene.obstacles[0].name",
        "already has an obstacle or object named 'table'",
    );
}

#[test]
fn duplicate_grasp_names() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace(
        "    { name = \"top\", position = [0.0, 0.0, 0.06], rpy = [3.141592653589793, 0.0, 0.0] },\n",
        "    { name = \"top\", position = [0.0, 0.0, 0.06] },\n    { name = \"top\", position = [0.0, 0.0, -0.06] },\n",
    );
    expect_problem_error(&text, "-0.06", "scene.objects[0].grasps[1].name", "two grasp frames named 'top'");
}

#[test]
fn grasps_on_an_obstacle() {
    let wall =
        "[[scene.obstacles]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.1\ngrasps = [{ name = \"top\" }]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "grasps", "scene.obstacles[0].grasps", "make it an object");
}

#[test]
fn missing_urdf_file() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace(&urdf(), "/nonexistent/robot.urdf");
    expect_problem_error(&text, "nonexistent", "robot.urdf", "/nonexistent/robot.urdf");
}

#[test]
fn missing_mesh_file() {
    let o = "[[scene.obstacles]]\nname = \"m\"\nshape = \"mesh\"\nmesh = \"missing.stl\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "missing.stl", "scene.obstacles[0].mesh", "missing.stl");
}

#[test]
fn unknown_chain_tip() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("panda_hand_tcp\"]", "panda_hand_tcpp\"]");
    expect_problem_error(&text, "chain", "robot.chain", "unknown frame 'panda_hand_tcpp' (did you mean panda_hand_tcp");
}

#[test]
fn unknown_active_joint() {
    let joints = "joints = [\"panda_joint1\", \"panda_joint2\", \"panda_joint3\", \"panda_joint4\", \"panda_joint5\", \"panda_joint6\", \"panda_joint77\"]";
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("chain = [\"panda_link0\", \"panda_hand_tcp\"]", joints);
    expect_problem_error(&text, "joints", "robot.joints", "unknown joint 'panda_joint77'");
}

#[test]
fn bad_held_joints() {
    let base = problem(&[ROBOT, START, JOINT_GOAL]);
    let text = base.replace("panda_finger_joint1 = 0.04", "panda_finger_joint3 = 0.04");
    expect_problem_error(&text, "hold", "robot.hold.panda_finger_joint3", "unknown joint 'panda_finger_joint3'");
    let text = base.replace("panda_finger_joint1 = 0.04", "panda_finger_joint1 = 0.5");
    expect_problem_error(
        &text,
        "hold",
        "robot.hold.panda_finger_joint1",
        "held value 0.5 for joint 'panda_finger_joint1' is outside its limits [0, 0.04]",
    );
    let text = base.replace("{ panda_finger_joint1 = 0.04 }", "{ panda_finger_joint1 = 0.04, panda_joint1 = 0.5 }");
    expect_problem_error(&text, "hold", "robot.hold.panda_joint1", "joint 'panda_joint1' cannot be active");
}

#[test]
fn group_without_srdf() {
    let text = problem(&[ROBOT, START, JOINT_GOAL])
        .replace("chain = [\"panda_link0\", \"panda_hand_tcp\"]", "group = \"panda_arm\"");
    expect_problem_error(&text, "group", "robot.group", "a group needs `srdf`");
}

#[test]
fn joints_and_chain_both() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace(
        "hold =",
        "joints = [\"panda_joint1\", \"panda_joint2\", \"panda_joint3\", \"panda_joint4\", \"panda_joint5\", \"panda_joint6\", \"panda_joint7\"]\nhold =",
    );
    expect_problem_error(&text, "joints", "robot.joints", "give only one of `joints`, `chain` or `group`");
}

#[test]
fn rpy_and_quaternion_both() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace(
        "position = [0.5, 0.1, 0.06]\n",
        "position = [0.5, 0.1, 0.06]\nrpy = [0.0, 0.0, 0.1]\nquaternion = [0.0, 0.0, 0.0, 1.0]\n",
    );
    expect_problem_error(&text, "quaternion", "scene.objects[0].quaternion", "give rpy or quaternion, not both");
}

#[test]
fn two_goal_kinds() {
    let goal = "[goal]\nq = [0.5, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\ngrasp = \"box\"\n";
    let text = problem(&[ROBOT, START, goal, BOX]);
    expect_problem_error(&text, "grasp = ", "goal.grasp", "give exactly one kind of goal");
}

#[test]
fn goal_key_of_another_goal_kind() {
    let goal = "[goal]\ngrasp = \"box\"\ndirection = [0.0, 0.0, -1.0]\n";
    let text = problem(&[ROBOT, START, goal, BOX]);
    expect_problem_error(&text, "direction", "goal.direction", "does not apply to a grasp goal");
    let goal = "[goal]\nq = [0.5, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\ngrasp_frame = \"top\"\n";
    let text = problem(&[ROBOT, START, goal, BOX]);
    expect_problem_error(&text, "grasp_frame", "goal.grasp_frame", "does not apply to a joint goal");
}

#[test]
fn pose_goal_without_position() {
    let goal = "[goal]\nframe = \"panda_hand_tcp\"\naxis = \"z\"\ndirection = [0.0, 0.0, -1.0]\n";
    let text = problem(&[ROBOT, START, goal]);
    expect_problem_error(&text, "[goal]", "goal", "a pose goal needs `position`");
}

#[test]
fn missing_required_keys() {
    // A missing key is reported at the table it is missing from.
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("urdf = ", "# urdf = ");
    expect_problem_error(&text, "[robot]", "robot", "missing field `urdf`");
    let o = "[[scene.obstacles]]\nname = \"a\"\nradius = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "[[scene.obstacles]]", "scene.obstacles[0]", "missing field `shape`");
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace("{ name = \"top\", ", "{ ");
    expect_problem_error(&text, "position = [0.0, 0.0, 0.06]", "scene.objects[0].grasps[0]", "missing field `name`");
    // A missing top-level table has no line.
    let text = problem(&[ROBOT, START]);
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, &text).unwrap();
    let e = Problem::from_file(&path).unwrap_err().to_string();
    assert_eq!(e, format!("{}: missing field `goal`", path.display()));
}

// Family errors.

fn family_text(body: &str) -> String {
    format!("base = \"{}\"\nname = \"fam\"\n\n{body}", shipped("panda_grasp_box.toml").display())
}

#[test]
fn family_fixture_is_valid_and_relative_base_works() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("f.toml"), family_text("[[objects]]\nname = \"box\"\nx = [0.4, 0.6]\n")).unwrap();
    ProblemFamily::from_file(dir.path().join("f.toml")).unwrap_or_else(|e| panic!("{e}"));
    // A relative base resolves against the family file's folder.
    let f = ProblemFamily::from_file(shipped("panda_grasp_family.toml")).unwrap();
    assert_eq!(f.base.origin, shipped("panda_grasp_box.toml").display().to_string());
}

#[test]
fn family_with_a_missing_base() {
    let text = "# a family\nname = \"fam\"\nbase = \"no_such_problem.toml\"\n";
    expect_family_error(text, "base", "base", "cannot read");
}

#[test]
fn family_base_with_an_error_names_the_base_file() {
    let dir = TempDir::new().unwrap();
    let base = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nhorizon = 1\n"]);
    std::fs::write(dir.path().join("base.toml"), &base).unwrap();
    std::fs::write(dir.path().join("fam.toml"), "base = \"base.toml\"\nname = \"fam\"\n").unwrap();
    let e = ProblemFamily::from_file(dir.path().join("fam.toml")).unwrap_err().to_string();
    let head = format!("{}:{}: optimizer.horizon: ", dir.path().join("base.toml").display(), line_of(&base, "horizon"));
    assert!(e.starts_with(&head), "expected `{head}…`, got `{e}`");
}

#[test]
fn family_unknown_object() {
    let text = family_text("[[objects]]\nname = \"cup\"\nx = [0.4, 0.6]\n");
    expect_family_error(&text, "cup", "objects[0].name", "the base problem has no object 'cup'");
}

#[test]
fn family_unknown_key() {
    let text = family_text("[start]\njitter = 0.1\nspread = 0.2\n");
    expect_family_error(&text, "spread", "start.spread", "unknown field `spread`");
}

#[test]
fn family_negative_jitter() {
    let text = family_text("[start]\njitter = -0.1\n");
    expect_family_error(&text, "jitter", "start.jitter", "must be between 0 and 10 rad, got -0.1");
}

#[test]
fn family_range_min_above_max() {
    let text = family_text("[[objects]]\nname = \"box\"\nx = [0.4, 0.6]\nyaw = [1.0, -1.0]\n");
    expect_family_error(&text, "yaw", "objects[0].yaw", "low ≤ high, got [1, -1]");
}

const OBSTACLES: &str = "[obstacles]\ncount = [0, 2]\nshapes = [\"box\", \"sphere\"]\nsize = [0.04, 0.1]\n\
                         region_min = [0.25, -0.6, 0.25]\nregion_max = [0.75, 0.6, 0.8]\n";

#[test]
fn family_obstacle_ranges() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("f.toml"), family_text(OBSTACLES)).unwrap();
    ProblemFamily::from_file(dir.path().join("f.toml")).unwrap_or_else(|e| panic!("{e}"));

    let text = family_text(&OBSTACLES.replace("[0, 2]", "[3, 2]"));
    expect_family_error(&text, "count", "obstacles.count", "min ≤ max ≤ 1000, got [3, 2]");
    let text = family_text(&OBSTACLES.replace("[0.04, 0.1]", "[0.1, 0.04]"));
    expect_family_error(&text, "size", "obstacles.size", "0 < low ≤ high ≤ 10 m, got [0.1, 0.04]");
    let text = family_text(&OBSTACLES.replace("[0.75, 0.6, 0.8]", "[0.75, 0.6, 0.2]"));
    expect_family_error(&text, "region_max", "obstacles.region_max[2]", "be ≥ region_min[2], got 0.2 < 0.25");
    let text = family_text(&OBSTACLES.replace("\"sphere\"", "\"mesh\""));
    expect_family_error(&text, "shapes", "obstacles.shapes[1]", "unknown shape 'mesh'");
    let text = family_text(&format!("{OBSTACLES}clearance = -0.01\n"));
    expect_family_error(&text, "clearance", "obstacles.clearance", "must be between 0 and 10 m, got -0.01");
}

/// A family's `[optimizer] obstacle_margin` changes the base problem's
/// collision objective and nothing else: the same draws for every (seed, id).
#[test]
fn a_family_obstacle_margin_keeps_the_tasks() {
    let text = std::fs::read_to_string(shipped("panda_grasp_family.toml")).unwrap();
    let text = format!("{text}\n[optimizer]\nobstacle_margin = 0.02\n");
    let clearance = ProblemFamily::from_str_with(&text, "clearance.toml", Some(&repo().join("problems"))).unwrap();
    let plain = family();
    for id in 0..40 {
        let (a, b) = (clearance.sample(5, id).unwrap().problem, plain.sample(5, id).unwrap().problem);
        assert_eq!(fingerprint(&a), fingerprint(&b), "sample {id}");
    }
    let margins = |f: &ProblemFamily| -> Vec<(f64, Option<f64>)> {
        let collision = f.base.optimizer.objectives.iter().filter(|o| o.feature == "collision");
        collision.map(|o| (o.margin, o.obstacle_margin)).collect()
    };
    assert_eq!(margins(&plain), [(0.005, None)]);
    assert_eq!(margins(&clearance), [(0.005, Some(0.02))]);
    // Everything else of the base problem is kept.
    let mut same = clearance.base.optimizer.clone();
    same.objectives.iter_mut().for_each(|o| o.obstacle_margin = None);
    assert_eq!(same, plain.base.optimizer);
}

#[test]
fn obstacle_margins_out_of_place_or_range() {
    let text = family_text("[optimizer]\nobstacle_margin = -0.02\n");
    expect_family_error(&text, "obstacle_margin", "optimizer.obstacle_margin", "must be between 0 and 10 m, got -0.02");
    let text = family_text("[optimizer]\nobstacle_margin = nan\n");
    expect_family_error(&text, "obstacle_margin", "optimizer.obstacle_margin", "got NaN");
    let text = family_text("[optimizer]\nmargin = 0.02\n");
    expect_family_error(&text, "margin", "optimizer.margin", "unknown field `margin`");
    // A base without a collision objective has nothing to set.
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("base.toml"), problem(&[ROBOT, START, JOINT_GOAL])).unwrap();
    let text = "base = \"base.toml\"\nname = \"fam\"\n\n[optimizer]\nobstacle_margin = 0.02\n";
    std::fs::write(dir.path().join("fam.toml"), text).unwrap();
    let e = ProblemFamily::from_file(dir.path().join("fam.toml")).unwrap_err().to_string();
    assert!(e.contains("optimizer.obstacle_margin: the base problem lists no collision objective"), "{e}");
    // In a problem file: collision objectives only, never negative.
    let limits = "[[optimizer.objectives]]\nfeature = \"joint_limits\"\nkind = \"ineq\"\nobstacle_margin = 0.02\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, limits]);
    expect_problem_error(&text, "obstacle_margin", "optimizer.objectives[0].obstacle_margin", "collision feature only");
    let collision = "[[optimizer.objectives]]\nfeature = \"collision\"\nkind = \"ineq\"\nobstacle_margin = -1.0\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, collision]);
    expect_problem_error(
        &text,
        "obstacle_margin",
        "optimizer.objectives[0].obstacle_margin",
        "zero or positive, got -1",
    );
}

/// Finite values far beyond any workspace are refused where they enter:
/// they used to pass and then panic in sampling (a range of ±1.7e308) or in
/// the collision solver (an obstacle of 1e300 m).
#[test]
fn family_values_beyond_any_workspace_are_refused() {
    let text =
        family_text(&OBSTACLES.replace("region_min = [0.25, -0.6, 0.25]", "region_min = [-1.7e308, -0.6, 0.25]"));
    expect_family_error(&text, "region_min", "obstacles.region_min[0]", "within ±1000 m");
    let text = family_text(&OBSTACLES.replace("[0.75, 0.6, 0.8]", "[1.7e308, 0.6, 0.8]"));
    // Out of range, not "smaller than region_min" (it printed "got 1e308 < 0.25").
    expect_family_error(&text, "region_max", "obstacles.region_max[0]", "must lie within ±1000 m, got 1.7e308");
    let text = family_text(&OBSTACLES.replace("[0.04, 0.1]", "[0.04, 1e300]"));
    expect_family_error(&text, "size", "obstacles.size", "≤ 10 m, got [0.04, 1e300]");
    let text = family_text("[[objects]]\nname = \"box\"\nx = [-1.7e308, 1.7e308]\n");
    expect_family_error(&text, "x =", "objects[0].x", "within ±1000");
}

#[test]
fn flipped_grasp_keeps_position_and_approach_axis() {
    let mut problem = Problem::builtin("panda_grasp_box").unwrap();
    let before = problem.scene.grasp_pose("box", "grasp").unwrap();
    problem.scene.flip_grasp("box", "grasp").unwrap();
    let after = problem.scene.grasp_pose("box", "grasp").unwrap();
    assert!((after.translation.vector - before.translation.vector).norm() < 1e-15);
    let axis = |p: &nalgebra::IsometryMatrix3<f64>, i: usize| p.rotation.matrix().column(i).into_owned();
    assert!((axis(&after, 2) - axis(&before, 2)).norm() < 1e-15, "approach axis kept");
    assert!((axis(&after, 0) + axis(&before, 0)).norm() < 1e-15, "x turned by π");
    assert!((axis(&after, 1) + axis(&before, 1)).norm() < 1e-15, "y turned by π");
    let err = problem.scene.flip_grasp("box", "grasps").unwrap_err().to_string();
    assert!(err.contains("grasp frame named 'grasps' (did you mean grasp?)"), "{err}");
    assert!(problem.scene.flip_grasp("crate", "grasp").is_err());
}

#[test]
fn family_with_a_builtin_base_parses_from_text() {
    let text = std::fs::read_to_string(shipped("panda_grasp_family.toml"))
        .unwrap()
        .replace("base = \"panda_grasp_box.toml\"", "base = \"builtin:panda_grasp_box\"");
    let family = ProblemFamily::from_str_with(&text, "<text>", None).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(family.base.origin, "<builtin:panda_grasp_box>");
    let from_file = ProblemFamily::from_file(shipped("panda_grasp_family.toml")).unwrap();
    let (a, b) = (family.sample(3, 7).unwrap(), from_file.sample(3, 7).unwrap());
    assert_eq!(a.problem.start, b.problem.start, "the builtin base is the shipped file");
    let e = ProblemFamily::from_str_with(&text.replace("builtin:panda_grasp_box", "builtin:nope"), "<text>", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("<text>:5: base: ") && e.contains("no builtin problem named 'nope'"), "{e}");
}
