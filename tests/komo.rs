//! The trajectory optimizer on the shipped problems and on problems built
//! in Rust: converged, collision-free between slices at fine resolution,
//! within limits, goals reached; deterministic; warm starts; clear reports
//! for unreachable or contradictory problems; no allocation per solve.

mod common;

use common::alloc::{CountingAllocator, allocations};
use nalgebra::Vector3;
use std::sync::Arc;
use tandem::komo::{
    Feature, FrameRef, Initialization, JOINT_LIMIT_CUTOFF, KomoError, Objective, TimeSpan, TrajectoryOptimizer,
    TrajectoryProblem, TrajectoryWorkspace, trajectory_solver_settings,
};
use tandem::pipeline::{ProblemSolution, SolveSettings, solve_problem};
use tandem::problem::{Goal, ObjectiveKind, Problem};
use tandem::robot::{KinematicsWorkspace, RobotModel};
use tandem_solvers::least_squares::{Residuals, Termination};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

const SHIPPED: [&str; 3] = ["panda_reach", "panda_reach_obstacle", "panda_grasp_box"];

/// World pose of the problem's gripper at `q`.
fn gripper_pose(problem: &Problem, q: &[f64]) -> nalgebra::IsometryMatrix3<f64> {
    let robot = &problem.robot;
    let frame = robot.frame_id(problem.robot_spec.gripper.as_deref().unwrap()).unwrap();
    let mut ws = KinematicsWorkspace::new(robot);
    robot.forward_kinematics(&mut ws, q).unwrap();
    robot.frame_pose(&ws, frame)
}

#[test]
fn shipped_problems_converge_collision_free_at_both_horizons() {
    for name in SHIPPED {
        let problem = Problem::builtin(name).unwrap();
        for horizon in [20, 50] {
            for seed in 0..3 {
                let options = SolveSettings { seed: Some(seed), horizon: Some(horizon), ..SolveSettings::default() };
                let s = solve_problem(&problem, &options).unwrap();
                let label = format!("{name} T={horizon} seed {seed}");
                assert_eq!(s.status(), "converged", "{label}: {:?}", s.report);
                assert_eq!(s.trajectory.len(), horizon);
                assert!(s.report.equality_violation <= 1e-4 && s.report.inequality_violation <= 1e-4, "{label}");
                // Independently of the optimizer: every slice within limits,
                // and the motion start → q_1 → … → q_T free at 1 mrad.
                let model = problem.collision_model().unwrap();
                let mut ws = tandem::collision::CollisionWorkspace::new(&model);
                let mut previous = &problem.start;
                for q in &s.trajectory {
                    assert!(problem.robot.within_limits(q), "{label}");
                    assert!(model.motion_free(&mut ws, previous, q, 1e-3).unwrap(), "{label}: collides");
                    previous = q;
                }
                let last = s.trajectory.last().unwrap();
                let pose = gripper_pose(&problem, last);
                match &problem.goal {
                    Goal::Joints(goal) => {
                        let err = common::max_abs(last.iter().zip(goal).map(|(a, b)| a - b));
                        assert!(err < 1e-4, "{label}: joint goal missed by {err}");
                    }
                    Goal::Pose { .. } => {
                        let err = (pose.translation.vector - Vector3::new(0.5, 0.3, 0.3)).norm();
                        assert!(err < 1e-4, "{label}: position missed by {err}");
                        assert!(
                            (pose.rotation * Vector3::z() + Vector3::z()).norm() < 1e-4,
                            "{label}: not pointing down"
                        );
                    }
                    Goal::Grasp { .. } => {
                        let target = problem.grasp_target().unwrap();
                        let err = (pose.translation.vector - target.translation.vector).norm();
                        assert!(err < 1e-4, "{label}: grasp missed by {err} m");
                        let down = pose.rotation * Vector3::z();
                        assert!((down + Vector3::z()).norm() < 1e-4, "{label}: gripper not pointing down");
                        // Fingers close across the box: gripper y along the box's y.
                        let across = (pose.rotation * Vector3::y()).dot(&(target.rotation * Vector3::x()));
                        assert!(across.abs() < 1e-4, "{label}: fingers not across the box ({across})");
                    }
                }
                // At rest at the end.
                let before = &s.trajectory[horizon - 2];
                let speed = common::max_abs(last.iter().zip(before).map(|(a, b)| a - b)) / s.time_step;
                assert!(speed < 1e-3, "{label}: final speed {speed} rad/s");
            }
        }
    }
}

#[test]
fn grasp_passes_the_approach_point_above_the_box() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let s = solve_problem(&problem, &SolveSettings::default()).unwrap();
    assert!(s.converged());
    // Slice round(0.7 T) holds the gripper at the approach frame, 15 cm above the centre.
    let slice = (0.7 * s.trajectory.len() as f64).round() as usize;
    let approach = problem.scene.grasp_pose("box", "approach").unwrap();
    let pose = gripper_pose(&problem, &s.trajectory[slice - 1]);
    assert!((pose.translation.vector - approach.translation.vector).norm() < 1e-4);
}

#[test]
fn same_seed_same_trajectory() {
    let problem = Problem::builtin("panda_reach_obstacle").unwrap();
    let options = SolveSettings { seed: Some(4), ..SolveSettings::default() };
    let a = solve_problem(&problem, &options).unwrap();
    let b = solve_problem(&problem, &options).unwrap();
    let bits = |t: &[Vec<f64>]| t.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.trajectory), bits(&b.trajectory));
    assert_eq!(a.report.evaluations, b.report.evaluations);
}

#[test]
fn warm_start_from_a_solution_converges_at_once() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let plan = tandem::plan::plan_problem(&problem, Some(0)).unwrap();
    let mut optimizer =
        TrajectoryOptimizer::new(TrajectoryProblem::from_problem(&problem).unwrap(), trajectory_solver_settings());
    let cold = optimizer.solve(Initialization::Path(&plan.path)).unwrap();
    assert_eq!(cold.report.termination, Termination::Converged);
    // A warm start keeps the multipliers of the last solve.
    let warm = optimizer.solve(Initialization::Warm(&cold.trajectory)).unwrap();
    assert_eq!(warm.report.termination, Termination::Converged);
    assert!(
        warm.report.evaluations * 3 < cold.report.evaluations,
        "{} vs {}",
        warm.report.evaluations,
        cold.report.evaluations
    );
    assert!((warm.report.cost - cold.report.cost).abs() < 1e-3 * cold.report.cost);
}

/// A reach built in Rust: minimal acceleration from the ready pose to a
/// gripper position, with limits; no collision model.
fn rust_reach(target: [f64; 3]) -> TrajectoryProblem {
    let robot = Arc::new(RobotModel::panda());
    let tcp = FrameRef::Robot(robot.frame_id("panda_hand_tcp").unwrap());
    let objectives = vec![
        Objective::control(2),
        Objective::new("limits", Feature::JointLimits { margin: 0.0 }, ObjectiveKind::Inequality),
        Objective::new("reach", Feature::Position { frame: tcp }, ObjectiveKind::Equality)
            .time(TimeSpan::END)
            .target(target),
        Objective::new("rest", Feature::JointState, ObjectiveKind::Equality).time(TimeSpan::END).order(1),
    ];
    let start = vec![0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    TrajectoryProblem::new(robot, None, objectives, 30, 2, 3.0, start).unwrap()
}

#[test]
fn a_problem_built_in_rust_converges() {
    let problem = rust_reach([0.4, -0.3, 0.5]);
    let start = problem.start().to_vec();
    let mut optimizer = TrajectoryOptimizer::new(problem, trajectory_solver_settings());
    let result = optimizer.solve(Initialization::Interpolate(&start)).unwrap();
    assert_eq!(result.report.termination, Termination::Converged, "{:?}", result.report);
    let measured = optimizer.problem().measure(&result.trajectory).unwrap();
    assert!(measured.equality_violation < 1e-4 && measured.inequality_violation == 0.0);
    assert!((measured.cost - result.report.cost).abs() < 1e-9 * (1.0 + measured.cost));
}

/// Joint-limit rows exist only near a limit (`JOINT_LIMIT_CUTOFF`), yet a
/// goal beyond a limit still stops at it: the row appears when a step
/// brings the joint close.
#[test]
fn a_goal_beyond_a_joint_limit_stops_at_the_limit() {
    let robot = Arc::new(RobotModel::panda());
    let start = vec![0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let upper = robot.limits()[3].upper;
    let mut goal = start.clone();
    goal[3] = upper + 0.5;
    let objectives = vec![
        Objective::control(2),
        Objective::new("limits", Feature::JointLimits { margin: 0.0 }, ObjectiveKind::Inequality),
        Objective::new("goal", Feature::JointState, ObjectiveKind::SumOfSquares)
            .time(TimeSpan::END)
            .target(goal)
            .scale(10.0),
    ];
    let problem = TrajectoryProblem::new(robot.clone(), None, objectives, 20, 2, 2.0, start.clone()).unwrap();
    // Far from every limit: no limit rows at all.
    let mut ws = TrajectoryWorkspace::new(&problem);
    let mut rows = Residuals::default();
    problem.residuals(&mut ws, &start.repeat(20), &mut rows).unwrap();
    assert_eq!(rows.inequality.len(), 0);
    let mut optimizer = TrajectoryOptimizer::new(problem, trajectory_solver_settings());
    let result = optimizer.solve(Initialization::Interpolate(&start)).unwrap();
    assert_eq!(result.report.termination, Termination::Converged, "{:?}", result.report);
    let last = result.trajectory.last().unwrap();
    assert!((last[3] - upper).abs() < 1e-3, "q_T[3] = {}, limit {upper}", last[3]);
    for q in &result.trajectory {
        for (v, l) in q.iter().zip(robot.limits()) {
            assert!(*v <= l.upper + 1e-5 && *v >= l.lower - 1e-5, "{v} outside [{}, {}]", l.lower, l.upper);
        }
    }
    let near = JOINT_LIMIT_CUTOFF;
    optimizer.problem().residuals(&mut ws, &result.trajectory.concat(), &mut rows).unwrap();
    let at_limit = result.trajectory.iter().filter(|q| q[3] > upper - near).count();
    assert!(
        at_limit > 0 && rows.inequality.len() >= at_limit,
        "{} rows, {at_limit} slices near",
        rows.inequality.len()
    );
}

#[test]
fn an_unreachable_target_is_reported_infeasible() {
    // 2 m away: the Panda reaches about 0.85 m.
    let problem = rust_reach([2.0, 0.0, 0.5]);
    let start = problem.start().to_vec();
    let mut optimizer = TrajectoryOptimizer::new(problem, trajectory_solver_settings());
    let result = optimizer.solve(Initialization::Interpolate(&start)).unwrap();
    assert_eq!(result.report.termination, Termination::Infeasible, "{:?}", result.report);
    assert!(result.report.equality_violation > 0.5, "{:?}", result.report);
    assert!(result.trajectory.iter().all(|q| q.iter().all(|v| v.is_finite())));
}

#[test]
fn contradictory_goals_end_with_a_report_not_a_hang() {
    let problem = Problem::builtin("panda_reach_obstacle").unwrap();
    let mut base = TrajectoryProblem::from_problem(&problem).unwrap().objectives().to_vec();
    let Goal::Joints(goal) = &problem.goal else { unreachable!() };
    let elsewhere: Vec<f64> = goal.iter().map(|g| g + 0.3).collect();
    base.push(
        Objective::new("other goal", Feature::JointState, ObjectiveKind::Equality)
            .time(TimeSpan::END)
            .target(elsewhere),
    );
    let model = problem.collision_model().unwrap();
    let t =
        TrajectoryProblem::new(problem.robot.clone(), Some(model), base, 20, 2, 4.0, problem.start.clone()).unwrap();
    let mut optimizer = TrajectoryOptimizer::new(t, trajectory_solver_settings());
    let result = optimizer.solve(Initialization::Interpolate(goal)).unwrap();
    assert_ne!(result.report.termination, Termination::Converged);
    assert!(result.report.equality_violation > 0.1, "{:?}", result.report);
}

#[test]
fn bad_inputs_get_typed_errors() {
    let problem = rust_reach([0.4, -0.3, 0.5]);
    let mut optimizer = TrajectoryOptimizer::new(problem, trajectory_solver_settings());
    let nan = vec![vec![f64::NAN; 7]; 30];
    let err = optimizer.solve(Initialization::Warm(&nan)).unwrap_err();
    assert!(matches!(err, KomoError::Initialization(_)), "{err}");
    assert!(err.to_string().contains("configuration 1 has a non-finite value at joint 0"), "{err}");
    let short = vec![vec![0.0; 7]; 3];
    assert!(matches!(optimizer.solve(Initialization::Warm(&short)), Err(KomoError::Initialization(_))));
    let err = optimizer.solve(Initialization::Path(&[])).unwrap_err();
    assert!(err.to_string().contains("path is empty"));
    // Objectives that do not fit the problem.
    let robot = Arc::new(RobotModel::panda());
    let start = robot.neutral_configuration();
    let wrong = Objective::new("q", Feature::JointState, ObjectiveKind::Equality).target([1.0, 2.0]);
    let err = TrajectoryProblem::new(robot.clone(), None, vec![wrong], 10, 2, 1.0, start.clone()).unwrap_err();
    assert!(err.to_string().contains("target has 2 values, the feature has 7"), "{err}");
    let jerk = Objective::control(2).order(3);
    let err = TrajectoryProblem::new(robot.clone(), None, vec![jerk], 10, 2, 1.0, start.clone()).unwrap_err();
    assert!(err.to_string().contains("order 3 exceeds"), "{err}");
    let collide =
        Objective::new("c", Feature::Collision { margin: 0.0, obstacle_margin: 0.0 }, ObjectiveKind::Inequality);
    let err = TrajectoryProblem::new(robot.clone(), None, vec![collide], 10, 2, 1.0, start.clone()).unwrap_err();
    assert!(err.to_string().contains("no collision model"), "{err}");
    // Margins are checked where they enter: NaN would make every row NaN.
    for (feature, expected) in [
        (
            Feature::Collision { margin: 0.0, obstacle_margin: f64::NAN },
            "obstacle_margin must be finite and zero or positive, got NaN",
        ),
        (
            Feature::Collision { margin: -0.01, obstacle_margin: 0.0 },
            "margin must be finite and zero or positive, got -0.01",
        ),
        (Feature::JointLimits { margin: f64::INFINITY }, "margin must be finite and zero or positive, got inf"),
    ] {
        let objective = Objective::new("m", feature, ObjectiveKind::Inequality);
        let err = TrajectoryProblem::new(robot.clone(), None, vec![objective], 10, 2, 1.0, start.clone()).unwrap_err();
        assert!(err.to_string().contains(expected), "{err}");
    }
    let err = TrajectoryProblem::new(robot.clone(), None, vec![], 1, 2, 1.0, start.clone()).unwrap_err();
    assert_eq!(err.to_string(), "horizon must be between 2 and 100000, got 1");
    // `solve -T 1000000` ran, bypassing the limit of problem files.
    let err = TrajectoryProblem::new(robot, None, vec![], 100_001, 2, 1.0, start).unwrap_err();
    assert!(err.to_string().contains("got 100001"), "{err}");
}

#[test]
fn a_repeated_solve_allocates_nothing() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let plan = tandem::plan::plan_problem(&problem, Some(0)).unwrap();
    let t = TrajectoryProblem::from_problem(&problem).unwrap();
    let mut optimizer = TrajectoryOptimizer::new(t, trajectory_solver_settings());
    let mut x = vec![0.0; 50 * 7];
    optimizer.initialize(Initialization::Path(&plan.path), &mut x).unwrap();
    let first = x.clone();
    optimizer.solve_in_place(&mut x).unwrap();
    // The second solve sees the same row counts: every buffer exists.
    x.copy_from_slice(&first);
    let before = allocations();
    let report = optimizer.solve_in_place(&mut x).unwrap();
    let during = allocations() - before;
    assert_eq!(report.termination, Termination::Converged);
    assert_eq!(during, 0, "a solve of {} evaluations allocated {during} times", report.evaluations);
}

#[test]
fn problems_without_objectives_get_the_defaults() {
    // The obstacle problem's file without its [[optimizer.objectives]].
    let text = tandem::problem::BUILTIN_PROBLEMS.iter().find(|(n, _)| *n == "panda_reach_obstacle").unwrap().1;
    let cut = text.find("[[optimizer.objectives]]").unwrap();
    let problem = Problem::from_str_with(&text[..cut], "<defaults>", None).unwrap();
    assert!(problem.optimizer.objectives.is_empty());
    let s = solve_problem(&problem, &SolveSettings::default()).unwrap();
    assert_eq!(s.status(), "converged", "{:?}", s.report);
    let Goal::Joints(goal) = &problem.goal else { unreachable!() };
    let last = s.trajectory.last().unwrap();
    assert!(last.iter().zip(goal).all(|(a, b)| (a - b).abs() < 1e-4));
}

/// Closest approach (m) of the robot to the scene's obstacles (the table
/// included) and to everything else, over the slices of a trajectory,
/// measured by the collision model apart from the optimizer.
fn closest_approach(problem: &Problem, trajectory: &[Vec<f64>]) -> (f64, f64) {
    use tandem::collision::{CollisionWorkspace, ObjectSource};
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let (mut obstacles, mut rest) = (f64::INFINITY, f64::INFINITY);
    for q in trajectory {
        for d in model.distances(&mut ws, q, f64::INFINITY).unwrap() {
            let against_obstacle =
                matches!(model.object_source(model.pair_objects(d.pair).1), ObjectSource::Obstacle(_));
            let closest = if against_obstacle { &mut obstacles } else { &mut rest };
            *closest = closest.min(d.signed.distance);
        }
    }
    (obstacles, rest)
}

/// An obstacle margin holds against obstacles while the robot's own links
/// and the box keep the (smaller) margin: the shipped family with
/// `[optimizer] obstacle_margin = 0.02` keeps its motions 2 cm from the
/// obstacles, where the shipped family's come as close as 5 mm.
#[test]
fn the_obstacle_margin_keeps_demonstrations_clear_of_obstacles() {
    use tandem::problem::ProblemFamily;
    let problems = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("problems");
    let text = std::fs::read_to_string(problems.join("panda_grasp_family.toml")).unwrap();
    let plain = ProblemFamily::from_str_with(&text, "plain", Some(&problems)).unwrap();
    let text = format!("{text}\n[optimizer]\nobstacle_margin = 0.02\n");
    let clearance = ProblemFamily::from_str_with(&text, "clearance", Some(&problems)).unwrap();
    let (mut solved, mut plain_closest, mut clearance_closest) = (0, f64::INFINITY, f64::INFINITY);
    for id in 0..40 {
        let p = plain.sample(11, id).unwrap().problem;
        if p.scene.obstacles().len() < 2 {
            continue; // the table alone
        }
        let c = clearance.sample(11, id).unwrap().problem;
        let (sp, sc) = (solve_problem(&p, &SolveSettings::default()), solve_problem(&c, &SolveSettings::default()));
        let (Ok(sp), Ok(sc)) = (sp, sc) else { continue };
        if !(sp.converged() && sc.converged()) {
            continue;
        }
        solved += 1;
        let (obstacles, rest) = closest_approach(&c, &sc.trajectory);
        // The optimizer's constraint tolerance is 1e-5 m.
        assert!(obstacles >= 0.02 - 1e-4, "sample {id}: {obstacles} m from an obstacle");
        assert!(rest >= 0.005 - 1e-4, "sample {id}: {rest} m between other shapes");
        clearance_closest = clearance_closest.min(obstacles);
        plain_closest = plain_closest.min(closest_approach(&p, &sp.trajectory).0);
    }
    assert!(solved >= 8, "only {solved} samples with obstacles solved");
    // Without the obstacle margin some motion comes closer than 2 cm, and
    // with it the 2 cm are reached: the margin is active.
    assert!(plain_closest < 0.015, "the shipped family's closest approach {plain_closest}");
    assert!(clearance_closest < 0.021, "with the obstacle margin, the closest approach {clearance_closest}");
}

/// With the straight initial guess, a task's motion does not depend on the
/// planner's seed (which of the arm's redundant goal configurations, which
/// way around an obstacle), as demonstrations for learning need; with the
/// planned guess it often does.
#[test]
fn the_straight_guess_makes_the_motion_a_function_of_the_task() {
    use tandem::pipeline::InitialGuess;
    use tandem::problem::ProblemFamily;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("problems/panda_grasp_family.toml");
    let family = ProblemFamily::from_file(path).unwrap();
    let solve = |problem: &Problem, seed: u64, initial_guess: InitialGuess| {
        let settings = SolveSettings { seed: Some(seed), initial_guess, ..SolveSettings::default() };
        solve_problem(problem, &settings).unwrap()
    };
    let (mut tasks, mut straight_same, mut planned_same) = (0, 0, 0);
    for id in 0..30 {
        let problem = family.sample(13, id).unwrap().problem;
        let (a, b) = (solve(&problem, 1, InitialGuess::Straight), solve(&problem, 2, InitialGuess::Straight));
        let (c, d) = (solve(&problem, 1, InitialGuess::Planned), solve(&problem, 2, InitialGuess::Planned));
        if ![&a, &b, &c, &d].iter().all(|s| s.converged()) {
            continue;
        }
        tasks += 1;
        for (s, name) in [(&a, "straight"), (&b, "straight")] {
            assert!(s.report.inequality_violation <= 1e-4 && s.validation.collision_free, "task {id} {name}");
        }
        let gap = |x: &ProblemSolution, y: &ProblemSolution| {
            let joints = x.trajectory.iter().flatten().zip(y.trajectory.iter().flatten());
            joints.map(|(p, q)| (p - q).abs()).fold(0.0, f64::max)
        };
        straight_same += usize::from(gap(&a, &b) < 1e-3);
        planned_same += usize::from(gap(&c, &d) < 1e-3);
    }
    assert!(tasks >= 25, "only {tasks} tasks solved by both guesses and seeds");
    assert!(straight_same * 10 >= tasks * 8, "straight: {straight_same} of {tasks} the same motion for both seeds");
    assert!(planned_same < straight_same, "planned: {planned_same} of {tasks}, straight {straight_same}");
}
