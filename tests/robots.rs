//! Robots unlike the Panda on the fast paths: a TIAGo whose planning group
//! slides its torso (a prismatic joint) and a Baxter planning both arms,
//! with sphere models (problems/robots/). Motion certification on the
//! sphere fast path covers prismatic joints (sound: every certified motion
//! keeps half the clearance, checked densely on the general path), and the
//! MotionBenchMaker-style problems of the robot benchmark
//! (benches/support/robots.rs) plan, certified, for every robot and family.

mod common;

#[allow(dead_code)]
#[path = "../benches/support/robots.rs"]
mod robots;

use common::random_configurations;
use nalgebra::IsometryMatrix3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robots::Goals;
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::plan::{PlanStatus, ProblemPlanner};
use tandem::problem::Goal;
use tandem::robot::{KinematicsWorkspace, RobotDescription, RobotModel, Srdf};
use tandem::scene::{Obstacle, Scene, Shape};

/// The TIAGo sphere model with its `arm_torso` group (torso lift + 7 arm
/// joints), its SRDF's disabled pairs, and boxes around it.
fn tiago() -> (Arc<RobotModel>, CollisionModel) {
    let tiago = &robots::ROBOTS[1];
    let desc = Arc::new(RobotDescription::from_urdf_file(tiago.urdf(), &Default::default()).unwrap());
    let srdf = Srdf::from_srdf_file(tiago.srdf()).unwrap();
    let selection = srdf.joint_selection("arm_torso").unwrap();
    let robot = Arc::new(RobotModel::builder(desc).selection(selection).build().unwrap());
    assert_eq!(robot.joint_names()[0], "torso_lift_joint");
    let mut scene = Scene::new();
    let at = |x: f64, y: f64, z: f64| IsometryMatrix3::translation(x, y, z);
    for (name, size, pose) in [
        ("table", [0.6, 1.2, 0.04], at(0.75, 0.0, 0.6)),
        ("crate", [0.2, 0.3, 0.3], at(0.6, -0.35, 0.8)),
        ("shelf", [0.35, 1.0, 0.02], at(0.7, 0.0, 1.25)),
    ] {
        scene.add_obstacle(Obstacle::new(name, Shape::cuboid(size), pose)).unwrap();
    }
    let model = CollisionModel::builder(robot.clone()).scene(&scene).srdf(&srdf).build().unwrap();
    (robot, model)
}

/// What certifying random motions on the sphere fast path came to.
struct Certifications {
    certified: usize,
    total: usize,
    /// Motions the general path gives the same verdict.
    agree: usize,
    /// Motions the fast path left to the general path.
    deferred: u64,
}

/// Certifies motions from the free ones of `count` random configurations,
/// each joint moving by up to `spread` of its range (short and long
/// motions), on `fast`'s sphere fast path, and checks every certified
/// one densely on the general path: each of 201 configurations keeps
/// half the clearance.
fn certify_random_motions(robot: &RobotModel, fast: &CollisionModel, count: usize, spread: f64) -> Certifications {
    assert!(fast.has_fast_path());
    let mut general = fast.clone();
    general.set_fast_path(false);
    let (mut fast_ws, mut general_ws) = (CollisionWorkspace::new(fast), CollisionWorkspace::new(&general));
    let clearance = 0.002;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut counts = Certifications { certified: 0, total: 0, agree: 0, deferred: 0 };
    for q in random_configurations(robot, count, 17) {
        if !fast.collision_free(&mut fast_ws, &q).unwrap() {
            continue;
        }
        let s = rng.random_range(0.05..spread);
        let q1: Vec<f64> = q
            .iter()
            .zip(robot.limits())
            .map(|(v, l)| (v + s * rng.random_range(-1.0..1.0) * (l.upper - l.lower)).clamp(l.lower, l.upper))
            .collect();
        let ok = fast.motion_free_certified(&mut fast_ws, &q, &q1, clearance).unwrap();
        let reference = general.motion_free_certified(&mut general_ws, &q, &q1, clearance).unwrap();
        counts.total += 1;
        counts.agree += usize::from(ok == reference);
        if !ok {
            continue;
        }
        counts.certified += 1;
        common::assert_motion_keeps(&general, &mut general_ws, (&q, &q1), clearance / 2.0, 200);
    }
    counts.deferred = fast_ws.deferred_certifications();
    let Certifications { certified, total, agree, deferred } = counts;
    println!("{certified} of {total} motions certified, general path agrees on {agree}, {deferred} deferred");
    counts
}

#[test]
fn prismatic_joints_are_certified_on_the_sphere_fast_path() {
    let (robot, fast) = tiago();
    let Certifications { certified, total, agree, deferred } = certify_random_motions(&robot, &fast, 300, 0.6);
    assert!(certified >= 30 && certified + 20 <= total, "{certified} of {total}");
    assert!(agree * 100 >= total * 95);
    // The fast path decides nearly every motion itself (it deferred every
    // one when a sliding joint was in the chain).
    assert!(deferred * 10 <= total as u64, "{deferred} of {total} deferred");
}

/// Both Baxter arms at once among a bookshelf's boards: 27 sphere groups
/// and 187 self pairs, whose intervals' parts check again only the pairs
/// that fell short on the whole (see `collision/spheres/motion.rs`).
#[test]
fn both_baxter_arms_are_certified_on_the_sphere_fast_path() {
    let dir = tempfile::tempdir().unwrap();
    let problem = robots::problem(&robots::ROBOTS[2], "shelf", 1, Goals::Grasp, dir.path()).expect("a problem");
    let fast = problem.collision_model().unwrap();
    let Certifications { certified, total, agree, deferred } = certify_random_motions(&problem.robot, &fast, 2400, 0.3);
    assert!(certified >= 30 && certified + 20 <= total, "{certified} of {total}");
    assert!(agree * 100 >= total * 95);
    assert!(deferred * 10 <= total as u64, "{deferred} of {total} deferred");
}

#[test]
fn benchmark_problems_of_every_robot_and_family_plan_certified() {
    let dir = tempfile::tempdir().unwrap();
    for (robot, goals) in robots::ROBOTS.iter().flat_map(|r| [(r, Goals::Grasp), (r, Goals::Joint)]) {
        for family in robots::FAMILIES {
            let problem = robots::problem(robot, family, 1, goals, dir.path()).expect("a start and a goal");
            assert!(problem.warnings.is_empty(), "{:?}", problem.warnings);
            let model = problem.collision_model().unwrap();
            assert!(model.has_fast_path(), "{} {family}", robot.name);
            if goals == Goals::Grasp {
                assert_grasp(robot, family, &problem);
            }
            let report = ProblemPlanner::new(&problem, Some(0)).unwrap().run(0).unwrap();
            assert_eq!(report.result.status, PlanStatus::Solved, "{} {family}", robot.name);
            assert!(report.certified, "{} {family}", robot.name);
        }
    }
}

/// A grasp goal points each tool's approach axis within the tilt of its
/// family's approach direction, and lies within a half-turn of its IK seed
/// (itself near the ready pose) in every joint.
fn assert_grasp(robot: &robots::BenchRobot, family: &str, problem: &tandem::problem::Problem) {
    let Goal::Joints(goal) = &problem.goal else { panic!("joint goal expected") };
    let model = &problem.robot;
    for (name, value) in model.joint_names().iter().zip(goal) {
        let home = robot.home_value(name).unwrap();
        let off = (value - home).abs();
        assert!(
            off <= std::f64::consts::PI + robots::IK_SEED_SPREAD,
            "{} {family} {name}: {off} from home",
            robot.name
        );
    }
    let mut ws = KinematicsWorkspace::new(model);
    model.forward_kinematics(&mut ws, goal).unwrap();
    model.update_frame_placements(&mut ws);
    for (tool, _) in robot.tools {
        let pose = model.frame_pose(&ws, model.frame_id(tool).unwrap());
        let axis = pose.rotation.matrix().column(robot.tool_axis).into_owned();
        let angle = axis.angle(&robots::approach(family));
        assert!(angle <= robots::APPROACH_TILT + 1e-3, "{} {family} {tool}: {angle} rad off", robot.name);
    }
}

#[test]
fn the_optimizer_solves_a_problem_of_every_robot_and_family() {
    let dir = tempfile::tempdir().unwrap();
    for robot in &robots::ROBOTS {
        for family in robots::FAMILIES {
            let problem = robots::problem(robot, family, 1, Goals::Grasp, dir.path()).expect("a start and a goal");
            let options = tandem::pipeline::SolveSettings { seed: Some(0), ..Default::default() };
            let solution = tandem::pipeline::solve_problem(&problem, &options).unwrap();
            // Converged, within limits, and collision-free between slices.
            assert!(solution.converged(), "{} {family}: {}", robot.name, solution.status());
        }
    }
}

/// Both Baxter arms through one cage in 50 slices: the first try ends
/// `infeasible` (it converges to a motion through the cage, which the
/// refinement cannot undo); the stiffer second try
/// (`stiff_solver_settings`) converges collision-free.
#[test]
fn the_optimizer_takes_both_baxter_arms_through_one_cage() {
    let dir = tempfile::tempdir().unwrap();
    let baxter = &robots::ROBOTS[2];
    let problem = robots::problem(baxter, "cage", 14, Goals::Grasp, dir.path()).expect("a start and a goal");
    let options = tandem::pipeline::SolveSettings { seed: Some(0), ..Default::default() };
    let solution = tandem::pipeline::solve_problem(&problem, &options).unwrap();
    assert!(solution.converged(), "{}", solution.status());
    assert_eq!(solution.trajectory.len(), problem.optimizer.horizon);
}
