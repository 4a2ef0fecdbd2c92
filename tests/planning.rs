//! RRT-Connect, shortcutting and IK on the shipped problems and on
//! MotionBenchMaker problems: paths are collision-free at a resolution 4×
//! finer than the planner's and within limits, end where asked, and the
//! same seed gives the same path.

mod common;

use std::process::Command;
use tandem::collision::CollisionWorkspace;
use tandem::plan::{IkError, IkSettings, IkTarget, PlanStatus, plan_problem, resample, solve_ik};
use tandem::robot::KinematicsWorkspace;
use tandem::scene::{Goal, Problem};

/// Checks a solved plan: ends, limits, collisions at resolution/4.
fn assert_valid(problem: &Problem, path: &[Vec<f64>], goals: &[Vec<f64>]) {
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    assert_eq!(path.first().unwrap(), &problem.start);
    assert!(goals.contains(path.last().unwrap()), "the path does not end at a goal configuration");
    // Far finer than any sampling the planner does: its edges are certified.
    let fine = 1e-3;
    for w in path.windows(2) {
        assert!(problem.robot.within_limits(&w[0]) && problem.robot.within_limits(&w[1]));
        if !model.motion_free(&mut ws, &w[0], &w[1], fine).unwrap() {
            let mut worst = f64::INFINITY;
            for k in 0..=1000 {
                let t = k as f64 / 1000.0;
                let q: Vec<f64> = w[0].iter().zip(&w[1]).map(|(a, b)| a + (b - a) * t).collect();
                let d = model.min_distance(&mut ws, &q).unwrap().unwrap();
                worst = worst.min(d.signed.distance);
            }
            panic!("{}: a segment collides, depth {worst:e}", problem.name);
        }
    }
}

#[test]
fn shipped_problems_are_solved_for_every_seed() {
    for name in ["panda_reach", "panda_reach_obstacle", "panda_grasp_box"] {
        let problem = Problem::builtin(name).unwrap();
        for seed in 0..20 {
            let report = plan_problem(&problem, Some(seed)).unwrap();
            assert_eq!(report.result.status, PlanStatus::Solved, "{name} seed {seed}");
            assert!(report.certified, "{name} seed {seed}: path not certified");
            assert_valid(&problem, &report.path, &report.goals);
            assert!(tandem::plan::path_length(&report.path) <= tandem::plan::path_length(&report.result.path) + 1e-9);
        }
    }
}

#[test]
fn same_seed_same_path_and_resampling_stays_free() {
    let problem = Problem::builtin("panda_reach_obstacle").unwrap();
    let a = plan_problem(&problem, Some(7)).unwrap();
    let b = plan_problem(&problem, Some(7)).unwrap();
    assert_eq!(a.result.path, b.result.path);
    assert_eq!(a.path, b.path);
    let resampled = resample(&a.path, 50);
    assert_eq!(resampled.len(), 50);
    assert_valid(&problem, &resampled, &a.goals);
}

#[test]
fn ik_goals_reach_their_targets() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let report = plan_problem(&problem, Some(2)).unwrap();
    let target = problem.grasp_target().unwrap();
    let robot = &problem.robot;
    let tcp = robot.frame_id("panda_hand_tcp").unwrap();
    let mut ws = KinematicsWorkspace::new(robot);
    for g in &report.goals {
        robot.forward_kinematics(&mut ws, g).unwrap();
        let pose = robot.frame_pose(&ws, tcp);
        assert!((pose.translation.vector - target.translation.vector).norm() < 1e-5);
        assert!((pose.rotation.inverse() * target.rotation).angle() < 1e-4);
    }
    // Out of reach: a typed error with the residual.
    let model = problem.collision_model().unwrap();
    let mut cws = CollisionWorkspace::new(&model);
    let far = IkTarget { frame: tcp, position: [2.0, 0.0, 0.5].into(), orientation: None, axis_alignment: None };
    let settings = IkSettings { restarts: 5, ..IkSettings::default() };
    match solve_ik(&model, &mut cws, &far, &problem.start, 1, &settings) {
        Err(IkError::Unreachable { position_error, .. }) => assert!(position_error > 0.8),
        other => panic!("expected Unreachable, got {other:?}"),
    }
    // Inside the table: reachable, but every solution collides.
    let low = IkTarget { frame: tcp, position: [0.5, 0.3, -0.02].into(), orientation: None, axis_alignment: None };
    assert!(matches!(solve_ik(&model, &mut cws, &low, &problem.start, 1, &settings), Err(IkError::InCollision { .. })));
}

#[test]
fn invalid_start_or_goal_is_reported() {
    let mut problem = Problem::builtin("panda_reach_obstacle").unwrap();
    let Goal::Joints(goal) = problem.goal.clone() else { unreachable!() };
    // Leaning into the table.
    let inside = vec![0.0, 1.7, 0.0, -0.2, 0.0, 1.0, 0.0];
    problem.goal = Goal::Joints(inside.clone());
    assert_eq!(plan_problem(&problem, None).unwrap().result.status, PlanStatus::GoalInvalid);
    problem.goal = Goal::Joints(goal);
    problem.start = inside;
    assert_eq!(plan_problem(&problem, None).unwrap().result.status, PlanStatus::StartInvalid);
}

#[test]
fn motionbenchmaker_problems_are_solved() {
    let mbm = common::repo().join("../shared/benchmarks/mbm");
    let dir = tempfile::tempdir().unwrap();
    let ok = Command::new("tar").arg("xjf").arg(mbm.join("panda_problems.tar.bz2")).arg("-C").arg(dir.path()).status();
    assert!(ok.unwrap().success());
    let (urdf, srdf) = (mbm.join("panda_spherized.urdf"), mbm.join("panda.srdf"));
    let mut solved = 0;
    let families =
        ["bookshelf_small", "bookshelf_tall", "bookshelf_thin", "box", "cage", "table_pick", "table_under_pick"];
    for family in families {
        for k in 1..=5 {
            let folder = dir.path().join(format!("problems/{family}_panda"));
            let at = |f: &str| folder.join(format!("{f}{k:04}.yaml"));
            let mut problem = Problem::from_moveit(&urdf, &srdf, &at("scene"), &at("request")).unwrap();
            problem.planner.time_limit = 5.0;
            let report = plan_problem(&problem, Some(0)).unwrap();
            assert_eq!(report.result.status, PlanStatus::Solved, "{family} {k}");
            assert!(report.certified, "{family} {k}: path not certified");
            assert_valid(&problem, &report.path, &report.goals);
            solved += 1;
        }
    }
    assert_eq!(solved, 35);
}
