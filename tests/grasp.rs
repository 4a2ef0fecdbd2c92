//! Grasps a real gripper can make, checked independently: the final poses
//! of the shipped grasp problem and of a sample of `panda_grasp_family.toml`
//! trajectories go to `python_ref/grasp_mesh_check.py`, which places
//! example-robot-data's Panda collision meshes with Pinocchio and measures
//! them against the box with coal. The hand and the fingers' outer parts
//! keep the problem's collision margin (5 mm) from the box, the pads do not
//! penetrate it, the box lies between the finger pads and the fingertip
//! centre within its footprint. Also: the contact model of
//! `Problem::collision_model` (pads only may touch the target), tandem's own
//! `GraspJudge` on the same poses, and the typed error for a grasp frame
//! deeper than the fingers reach.

mod common;

use common::{repo, run_python};
use nalgebra::IsometryMatrix3;
use serde_json::{Value, json};
use tandem::data::{GenerateSettings, SampleOutcome, run_sample};
use tandem::pipeline::{PipelineSettings, SolveSettings, solve_problem};
use tandem::problem::{
    BUILTIN_PROBLEMS, GraspCriteria, GraspError, GraspJudge, Problem, ProblemError, ProblemFamily, grasp_depth,
};
use tandem::robot::KinematicsWorkspace;
use tandem::scene::{SceneObject, Shape};

/// The shipped problems' collision margin (m).
const MARGIN: f64 = 0.005;

fn box_json(object: &SceneObject) -> Value {
    let Shape::Box { half_extents } = object.shape else { panic!("{} is not a box", object.name) };
    let r = object.pose.rotation.matrix();
    let rotation: Vec<[f64; 3]> = (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect();
    json!({"half_extents": half_extents.as_slice(), "translation": object.pose.translation.vector.as_slice(), "rotation": rotation})
}

/// Judges `(q, box)` grasps with the erd meshes through coal.
fn mesh_check(problem: &Problem, grasps: &[(Vec<f64>, &SceneObject)]) -> Vec<Value> {
    let request = json!({
        "joints": problem.robot.joint_names(),
        "finger": 0.04,
        "margin": MARGIN,
        "grasps": grasps.iter().map(|(q, o)| json!({"q": q, "box": box_json(o)})).collect::<Vec<_>>(),
    });
    let out: Value = serde_json::from_str(&run_python("grasp_mesh_check.py", &[], &request.to_string())).unwrap();
    println!("mesh check worst: {}", out["worst"]);
    out["grasps"].as_array().unwrap().clone()
}

/// The mesh check's verdict on one grasp, with tandem's judge agreeing.
fn assert_good_grasp(label: &str, problem: &Problem, q: &[f64], object: &SceneObject, mesh: &Value) {
    let f = |k: &str| mesh[k].as_f64().unwrap();
    assert!(f("hand") >= MARGIN, "{label}: the hand is {} m from the box (mesh)", f("hand"));
    assert!(f("finger_outer") >= MARGIN, "{label}: a finger's outer part is {} m from the box", f("finger_outer"));
    assert!(f("arm") >= MARGIN, "{label}: the arm is {} m from the box", f("arm"));
    assert!(f("pad") >= 0.0, "{label}: a pad penetrates the box by {} m", -f("pad"));
    assert!(mesh["between_pads"].as_bool().unwrap(), "{label}: the box is not between the pads");
    assert!(mesh["in_footprint"].as_bool().unwrap(), "{label}: the fingertip centre is outside the footprint");
    assert!(f("tilt") < 0.01, "{label}: the gripper is tilted {} rad", f("tilt"));
    // tandem's own sphere model encloses the meshes: it sees less clearance.
    let judge = GraspJudge::new(problem).unwrap();
    let mut ws = KinematicsWorkspace::new(&problem.robot);
    let report = judge.judge(&mut ws, q, object, &GraspCriteria::default()).unwrap();
    assert!(
        report.success(&GraspCriteria { margin: MARGIN - 1e-4, ..GraspCriteria::default() }),
        "{label}: {report:?}"
    );
    assert!(report.palm_clearance <= f("hand") + 1e-9 && report.finger_clearance <= f("finger_outer") + 1e-9);
    assert_eq!(report.between_pads, mesh["between_pads"].as_bool().unwrap());
}

#[test]
fn shipped_grasp_passes_the_mesh_check() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let solution = solve_problem(&problem, &SolveSettings::default()).unwrap();
    assert!(solution.converged(), "{}", solution.status());
    let q = solution.trajectory.last().unwrap().clone();
    let object = problem.scene.object("box").unwrap();
    let mesh = mesh_check(&problem, &[(q.clone(), object)]);
    println!("panda_grasp_box at q_T: {}", mesh[0]);
    assert_good_grasp("panda_grasp_box", &problem, &q, object, &mesh[0]);
}

#[test]
fn family_grasps_pass_the_mesh_check() {
    let family = ProblemFamily::from_file(repo().join("problems/panda_grasp_family.toml")).unwrap();
    let pipeline = PipelineSettings { horizon: Some(20), ..PipelineSettings::default() };
    let settings = GenerateSettings { seed: 7, pipeline, ..GenerateSettings::default() };
    let (mut problems, mut grasps) = (Vec::new(), Vec::new());
    for id in 0..12 {
        match run_sample(&family, &settings, id).0 {
            SampleOutcome::Accepted(record) => {
                let problem = family.sample(settings.seed, id).unwrap().problem;
                let grasp = record.grasp.expect("a grasp goal's record has a grasp report");
                assert!(grasp.palm_clearance >= MARGIN - 1e-4 && grasp.between_pads && grasp.in_footprint);
                grasps.push((record.q.last().unwrap().clone(), id));
                problems.push(problem);
            }
            SampleOutcome::Rejected(r) => println!("sample {id} rejected: {} ({})", r.reason, r.detail),
        }
    }
    assert!(grasps.len() >= 10, "only {} of 12 samples accepted", grasps.len());
    let pairs: Vec<(Vec<f64>, &SceneObject)> =
        grasps.iter().zip(&problems).map(|((q, _), p)| (q.clone(), p.scene.object("box").unwrap())).collect();
    let mesh = mesh_check(&problems[0], &pairs);
    for (((q, id), problem), verdict) in grasps.iter().zip(&problems).zip(&mesh) {
        assert_good_grasp(&format!("family sample {id}"), problem, q, problem.scene.object("box").unwrap(), verdict);
    }
}

#[test]
fn only_the_pads_may_touch_the_target() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let model = problem.collision_model().unwrap();
    let pairs: Vec<(&str, &str)> = model.body_pairs().collect();
    let has = |a: &str, b: &str| pairs.iter().any(|&(x, y)| (x, y) == (a, b) || (y, x) == (a, b));
    for body in ["panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_link7", "panda_link6"] {
        assert!(has(body, "box"), "{body} is not checked against the box");
    }
    for pad in ["panda_leftfinger_pad", "panda_rightfinger_pad"] {
        assert!(!has(pad, "box"), "{pad} is checked against the box");
        assert!(has(pad, "table"), "{pad} is not checked against the table");
    }
    // The pads stay a finger's own: no self pair with the hand, checked against the arm.
    assert!(!has("panda_leftfinger_pad", "panda_hand") && has("panda_leftfinger_pad", "panda_link5"));
    // Without a grasp goal the pads are checked against the box too.
    let text = BUILTIN_PROBLEMS.iter().find(|(n, _)| *n == "panda_grasp_box").unwrap().1;
    let reach =
        text.replace("grasp = \"box\"\ngrasp_frame = \"grasp\"", "q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]");
    let joint_goal = Problem::from_str_with(&reach, "<joint goal>", None).unwrap();
    let model = joint_goal.collision_model().unwrap();
    assert!(model.body_pairs().any(|p| p == ("panda_leftfinger_pad", "box")));
}

#[test]
fn shipped_grasp_frame_is_the_middle_of_the_reachable_top() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let judge = GraspJudge::new(&problem).unwrap();
    let reach = judge.geometry().max_depth().unwrap();
    // erd's hand.stl ends 37.4 mm from the TCP; the spheres reach below it.
    assert!(reach > 0.025 && reach < 0.0374, "reach {reach}");
    let object = problem.scene.object("box").unwrap();
    let grasp = object.grasps.iter().find(|g| g.name == "grasp").unwrap();
    let depth = grasp_depth(object, grasp);
    assert!((depth - reach / 2.0).abs() < 1e-3, "depth {depth}, reach {reach}");
    let approach = object.grasps.iter().find(|g| g.name == "approach").unwrap();
    assert!(grasp_depth(object, approach) < 0.0);
}

#[test]
fn a_grasp_frame_deeper_than_the_fingers_reach_is_a_typed_error() {
    let text = BUILTIN_PROBLEMS.iter().find(|(n, _)| *n == "panda_grasp_box").unwrap().1;
    let grasp_line = text.lines().find(|l| l.contains("{ name = \"grasp\"")).unwrap();
    let centre = "    { name = \"grasp\", position = [0.0, 0.0, 0.0], rpy = [3.141592653589793, 0.0, 0.0] },";
    let deep = text.replace(grasp_line, centre);
    let err = Problem::from_str_with(&deep, "deep.toml", None).unwrap_err();
    let message = err.to_string();
    let ProblemError::Grasp { source, line, key, .. } = err else { panic!("expected a grasp error, got {err:?}") };
    match *source {
        GraspError::TooDeep { object, grasp, depth, max_depth } => {
            assert_eq!((object.as_str(), grasp.as_str()), ("box", "grasp"));
            assert!((depth - 0.06).abs() < 1e-12, "depth {depth}");
            assert!(max_depth < 0.0374, "max depth {max_depth}");
            assert_eq!(key.as_deref(), Some("scene.objects[0].grasps[0]"));
            let expected = deep.lines().position(|l| l == centre).unwrap() as u32 + 1;
            assert_eq!(line, Some(expected));
        }
        other => panic!("expected GraspError::TooDeep, got {other:?}"),
    }
    assert!(message.contains("'grasp' of 'box'") && message.contains("0.0600 m deep"), "{message}");
    // A stated reach overrides the geometry's.
    let stated = deep.replace("gripper = \"panda_hand_tcp\"", "gripper = \"panda_hand_tcp\"\nmax_grasp_depth = 0.07");
    assert!(Problem::from_str_with(&stated, "stated.toml", None).is_ok());
}

#[test]
fn grasp_depth_is_the_objects_extent_against_the_approach() {
    let pose = IsometryMatrix3::translation(0.4, 0.1, 0.3);
    let mut object = SceneObject::new("c", Shape::cylinder(0.03, 0.1), pose);
    let down = nalgebra::Rotation3::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
    object.add_grasp("top", IsometryMatrix3::from_parts(nalgebra::Translation3::new(0.0, 0.0, 0.02), down));
    // Approach along the cylinder axis from above: 0.05 − 0.02.
    assert!((grasp_depth(&object, &object.grasps[0]) - 0.03).abs() < 1e-12);
    // From the side (approach along +x): the radius.
    let side = nalgebra::Rotation3::from_euler_angles(0.0, std::f64::consts::FRAC_PI_2, 0.0);
    object.add_grasp("side", IsometryMatrix3::from_parts(nalgebra::Translation3::identity(), side));
    assert!((grasp_depth(&object, &object.grasps[1]) - 0.03).abs() < 1e-12);
    let ball = SceneObject { shape: Shape::sphere(0.05), ..object.clone() };
    assert!((grasp_depth(&ball, &object.grasps[0]) - 0.03).abs() < 1e-12);
    // Support values: a capsule along z, a box and a tetrahedron's hull, in an oblique direction.
    let d = nalgebra::Vector3::new(0.3, -0.4, 1.2);
    assert!((Shape::capsule(0.02, 0.1).support(&d) - (0.05 * 1.2 + 0.02 * d.norm())).abs() < 1e-12);
    assert!((Shape::cuboid([0.1, 0.2, 0.3]).support(&d) - (0.05 * 0.3 + 0.1 * 0.4 + 0.15 * 1.2)).abs() < 1e-12);
    let tet = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]].map(nalgebra::Point3::from);
    let hull = Shape::Convex(std::sync::Arc::new(tandem::scene::ConvexHull::new(&tet).unwrap()));
    assert!((hull.support(&d) - 0.12).abs() < 1e-12);
    assert!((Shape::cylinder(0.03, 0.1).support(&d) - (0.05 * 1.2 + 0.03 * 0.5)).abs() < 1e-12);
}

#[test]
fn surface_groups_split_links_without_changing_distances() {
    use std::sync::Arc;
    use tandem::collision::{CollisionError, CollisionModel, CollisionWorkspace};
    let robot = Arc::new(tandem::robot::RobotModel::panda());
    let scene = Problem::builtin("panda_grasp_box").unwrap().scene;
    let builder = CollisionModel::builder(robot.clone()).scene(&scene);
    let e = builder.clone().surface_groups(["panda_leftfinger_pda"]).build().unwrap_err();
    assert!(matches!(e, CollisionError::UnknownSurface { .. }), "{e:?}");
    assert!(e.to_string().contains("did you mean panda_leftfinger_pad"), "{e}");
    let e = builder.clone().surface_groups(["panda_hand"]).build().unwrap_err();
    assert!(matches!(e, CollisionError::SurfaceNameTaken { .. }), "{e:?}");
    let pads = ["panda_leftfinger_pad", "panda_rightfinger_pad"];
    let split = builder.clone().surface_groups(pads).build().unwrap();
    let whole = builder.build().unwrap();
    // The same object pairs, grouped differently: the same distances.
    assert_eq!(split.pair_count(), whole.pair_count());
    assert!(split.body_pairs().count() > whole.body_pairs().count());
    let (mut ws_split, mut ws_whole) = (CollisionWorkspace::new(&split), CollisionWorkspace::new(&whole));
    for q in common::random_configurations(&robot, 200, 3) {
        let a = split.min_distance(&mut ws_split, &q).unwrap().unwrap().signed.distance;
        let b = whole.min_distance(&mut ws_whole, &q).unwrap().unwrap().signed.distance;
        assert_eq!(a, b, "at {q:?}");
        assert_eq!(split.collision_free(&mut ws_split, &q).unwrap(), whole.collision_free(&mut ws_whole, &q).unwrap());
    }
}
