//! Problem files and problem families: every shipped file loads and makes
//! sense (collision-free start and goals, a reachable grasp target, a wall
//! that is actually in the way), families sample reproducibly, and every
//! kind of bad file is reported with its file name, line and key.

use std::path::{Path, PathBuf};
use tandem::collision::CollisionWorkspace;
use tandem::problem::{BUILTIN_PROBLEMS, Goal, ObjectiveKind, Problem, ProblemError, ProblemFamily};
use tandem::scene::Shape;
use tempfile::TempDir;

mod errors;
mod family_errors;
mod point_clouds;

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
    let mut examples = readme_examples();
    assert_eq!(examples.len(), 3, "a point cloud section, a problem and a family example");
    // The point cloud section, added to panda_reach.toml: the pillar's
    // 2,500 points as balls of 1 cm.
    let clouds = examples.remove(0);
    let reach = std::fs::read_to_string(shipped("panda_reach.toml")).unwrap() + "\n" + &clouds;
    let with_cloud = Problem::from_str_with(&reach, "README point cloud", Some(&repo().join("problems")))
        .unwrap_or_else(|e| panic!("{e}"));
    let cloud = with_cloud.scene.obstacle("point_cloud").expect("the cloud's obstacle");
    assert!(matches!(&cloud.shape, Shape::Points { points, radius } if points.len() == 2500 && *radius == 0.01));
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

// ---------------------------------------------------------------------------
// The fixture of the error tests (errors.rs, family_errors.rs): a valid
// problem file cut into sections, and the check that an error names the
// file, the line and the key.

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
