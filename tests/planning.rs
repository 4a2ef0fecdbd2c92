//! RRT-Connect, shortcutting and IK on the shipped problems and on
//! MotionBenchMaker problems: paths are collision-free at a resolution 4×
//! finer than the planner's and within limits, end where asked, and the
//! same seed gives the same path.

mod common;

use std::time::{Duration, Instant};
use tandem::collision::{CollisionWorkspace, MAX_MOTION_SAMPLES, MIN_CLEARANCE, MIN_RESOLUTION};
use tandem::plan::{IkError, IkSettings, IkTarget, PlanStatus, plan_problem, resample, rrt_connect, solve_ik};
use tandem::problem::{DynamicDomain, Goal, PlannerSettings, Problem, RootBias};
use tandem::robot::{KinematicsWorkspace, RobotError};

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
    let mbm = common::mbm();
    let dir = tempfile::tempdir().unwrap();
    common::unpack_mbm(dir.path());
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

/// The root bias leads goals out of their pocket: on MotionBenchMaker's
/// first ten Panda `cage` problems (a grasp between the bars, 1 cm from
/// them), four seeds each, the search with it takes fewer extension
/// rounds in total than with uniform samples only, and solves every run
/// either way.
#[test]
fn root_bias_leads_cage_goals_out() {
    use tandem::plan::ProblemPlanner;
    let mbm = common::mbm();
    let dir = tempfile::tempdir().unwrap();
    common::unpack_mbm(dir.path());
    let (urdf, srdf) = (mbm.join("panda_spherized.urdf"), mbm.join("panda.srdf"));
    let mut rounds = [0; 2];
    for k in 1..=10 {
        let folder = dir.path().join("problems/cage_panda");
        let at = |f: &str| folder.join(format!("{f}{k:04}.yaml"));
        let problem = Problem::from_moveit(&urdf, &srdf, &at("scene"), &at("request")).unwrap();
        let mut planner = ProblemPlanner::new(&problem, Some(0)).unwrap();
        for (biased, total) in rounds.iter_mut().enumerate() {
            planner.search_settings_mut().root_bias = (biased == 1).then(RootBias::default);
            for seed in 0..4 {
                let report = planner.run(seed).unwrap();
                assert!(report.certified, "cage {k}, seed {seed}, bias {biased}: {:?}", report.result.status);
                *total += report.result.iterations;
            }
        }
    }
    let [uniform, biased] = rounds;
    eprintln!("extension rounds: uniform {uniform}, with the root bias {biased}");
    assert!(biased < uniform, "uniform {uniform}, with the root bias {biased}");
}

/// The wall problem's start and goal: the straight motion between them
/// goes through the wall.
fn wall() -> (Problem, Vec<f64>, Vec<f64>) {
    let problem = Problem::builtin("panda_reach_obstacle").unwrap();
    let Goal::Joints(goal) = problem.goal.clone() else { unreachable!() };
    let start = problem.start.clone();
    (problem, start, goal)
}

#[test]
fn edge_checks_have_a_resolution_floor_and_never_skip_the_middle() {
    let (problem, start, goal) = wall();
    for fast_path in [true, false] {
        let mut model = problem.collision_model().unwrap();
        model.set_fast_path(fast_path);
        let mut ws = CollisionWorkspace::new(&model);
        // 1e-300 overflowed the sample count to 0: only the ends were
        // checked and the motion through the wall passed.
        for resolution in [1e-300, 1e-9, MIN_RESOLUTION / 2.0, 0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = model.motion_free(&mut ws, &start, &goal, resolution).unwrap_err();
            assert!(
                matches!(&e, RobotError::InvalidSetting(s) if s.field == "resolution")
                    && e.to_string().contains("0.00001"),
                "{resolution}: {e}"
            );
        }
        assert!(!model.motion_free(&mut ws, &start, &goal, MIN_RESOLUTION).unwrap(), "through the wall");
        assert!(!model.motion_free(&mut ws, &start, &goal, 0.005).unwrap());
        // A motion needing more samples than the cap is refused, not run for hours.
        let robot = &problem.robot;
        let far: Vec<f64> = robot.limits().iter().map(|l| l.upper).collect();
        let near: Vec<f64> = robot.limits().iter().map(|l| l.lower).collect();
        let span = near.iter().zip(&far).map(|(a, b)| b - a).fold(0.0, f64::max);
        assert!(span / MIN_RESOLUTION < MAX_MOTION_SAMPLES as f64, "the Panda's ranges fit the cap");
        // Certified checks: a clearance floor too.
        for clearance in [1e-300, MIN_CLEARANCE / 2.0, 0.0, f64::NAN] {
            let e = model.motion_free_certified(&mut ws, &start, &goal, clearance).unwrap_err();
            assert!(matches!(&e, RobotError::InvalidSetting(s) if s.field == "clearance"), "{clearance}: {e}");
        }
        // Deadlines are honoured inside one edge check: a passed deadline
        // stops a long check before its answer.
        let past = Some(Instant::now());
        // Turning the wrist at the start: free, and 50,000 samples long.
        let free = start.clone();
        let mut other = free.clone();
        other[6] += 0.5;
        assert_eq!(model.motion_free_by(&mut ws, &free, &other, MIN_RESOLUTION, past).unwrap(), None);
        assert_eq!(model.motion_free_by(&mut ws, &free, &other, MIN_RESOLUTION, None).unwrap(), Some(true));
        assert_eq!(model.motion_free_certified_by(&mut ws, &free, &other, MIN_CLEARANCE, None).unwrap(), Some(true));
    }
}

#[test]
fn an_extension_check_takes_its_start_as_passed() {
    let (problem, start, goal) = wall();
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    // A configuration in the wall, on the straight line to the goal.
    let blocked = (1..100)
        .map(|k| start.iter().zip(&goal).map(|(a, b)| a + (b - a) * k as f64 / 100.0).collect::<Vec<f64>>())
        .find(|q| !model.collision_free(&mut ws, q).unwrap())
        .expect("the wall blocks the straight line");
    // At a resolution wider than the motion only its two ends are checked:
    // the extension check leaves out its start, so only the end counts.
    for (from, to, whole, extension) in [(&blocked, &start, false, true), (&start, &blocked, false, false)] {
        assert_eq!(model.motion_free_by(&mut ws, from, to, 10.0, None).unwrap(), Some(whole));
        assert_eq!(model.extension_free_by(&mut ws, (from, to), 10.0, None).unwrap(), Some(extension));
    }
    // Otherwise the same verdicts: the motion through the wall is blocked.
    for resolution in [MIN_RESOLUTION * 100.0, 0.005, 0.1] {
        assert_eq!(model.extension_free_by(&mut ws, (&start, &goal), resolution, None).unwrap(), Some(false));
    }
    assert_eq!(model.extension_free_by(&mut ws, (&start, &goal), f64::NAN, None).ok(), None, "a NaN resolution");
}

#[test]
fn the_planner_stops_at_its_time_limit_inside_edge_checks() {
    let (problem, start, goal) = wall();
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    // 0.5 rad edges at the finest resolution: ~50,000 samples each.
    let settings =
        PlannerSettings { clearance: 0.0, resolution: MIN_RESOLUTION, time_limit: 1e-3, ..PlannerSettings::default() };
    let began = Instant::now();
    let result = rrt_connect(&model, &mut ws, &start, &[goal], &settings).unwrap();
    assert_eq!(result.status, PlanStatus::TimeLimit);
    // Generous for a loaded machine: one edge check is ~10 ms, a hang is minutes.
    assert!(began.elapsed() < Duration::from_secs(2), "{:?}", began.elapsed());
}

/// Sampling settings out of range are refused by name before the search
/// starts: a step of 0 would add the same node forever within one round,
/// a NaN spread would draw NaN samples.
#[test]
fn search_settings_out_of_range_are_refused_by_name() {
    let (problem, start, goal) = wall();
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let base = PlannerSettings::default();
    let domain = base.dynamic_domain.unwrap();
    let bias = base.root_bias.unwrap();
    let mut cases: Vec<(&str, PlannerSettings)> = Vec::new();
    for step in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        cases.push(("step", PlannerSettings { step, ..base.clone() }));
    }
    for radius in [0.0, -1.0, f64::NAN] {
        let dynamic_domain = Some(DynamicDomain { radius, ..domain });
        cases.push(("dynamic_domain.radius", PlannerSettings { dynamic_domain, ..base.clone() }));
    }
    for min_radius in [-0.5, f64::NAN] {
        let dynamic_domain = Some(DynamicDomain { min_radius, ..domain });
        cases.push(("dynamic_domain.min_radius", PlannerSettings { dynamic_domain, ..base.clone() }));
    }
    for rate in [1.0, -0.1, f64::NAN] {
        let dynamic_domain = Some(DynamicDomain { rate, ..domain });
        cases.push(("dynamic_domain.rate", PlannerSettings { dynamic_domain, ..base.clone() }));
    }
    for probability in [1.0, -0.1, f64::NAN] {
        let root_bias = Some(RootBias { probability, ..bias });
        cases.push(("root_bias.probability", PlannerSettings { root_bias, ..base.clone() }));
    }
    for spread in [-1.0, f64::NAN, f64::INFINITY] {
        let root_bias = Some(RootBias { spread, ..bias });
        cases.push(("root_bias.spread", PlannerSettings { root_bias, ..base.clone() }));
    }
    for (expected, settings) in &cases {
        assert!(settings.validate().is_err(), "{expected}");
        let e = rrt_connect(&model, &mut ws, &start, std::slice::from_ref(&goal), settings).unwrap_err();
        assert!(matches!(&e, RobotError::InvalidSetting(s) if s.field == *expected), "{expected}: {e}");
        assert!(e.to_string().starts_with(expected), "{e}");
    }
    // The edges of each range are taken: no domain, no bias, a bias of 0.
    let edges = [
        PlannerSettings { dynamic_domain: None, root_bias: None, ..base.clone() },
        PlannerSettings { root_bias: Some(RootBias { probability: 0.0, spread: 0.0 }), ..base.clone() },
        PlannerSettings {
            dynamic_domain: Some(DynamicDomain { min_radius: 0.0, rate: 0.0, ..domain }),
            ..base.clone()
        },
    ];
    for settings in &edges {
        settings.validate().unwrap();
        let result = rrt_connect(&model, &mut ws, &start, std::slice::from_ref(&goal), settings).unwrap();
        assert_eq!(result.status, PlanStatus::Solved);
    }
}

#[test]
fn problem_files_bound_planner_settings() {
    let base = std::fs::read_to_string(common::repo().join("problems/panda_reach_obstacle.toml")).unwrap();
    let urdf = common::repo().join("problems/robots/panda/panda.urdf");
    let load = |from: &str, to: &str| {
        assert!(base.contains(from));
        let text = base.replace(from, to).replace("robots/panda/panda.urdf", urdf.to_str().unwrap());
        Problem::from_str_with(&text, "wall.toml", None).map(|p| p.planner)
    };
    let e = load("resolution = 0.005", "resolution = 1e-300\nclearance = 0.0").unwrap_err().to_string();
    assert!(e.contains("planner.resolution: must be at least 0.00001 rad, got 1e-300"), "{e}");
    let e = load("resolution = 0.005", "resolution = 1e-9").unwrap_err().to_string();
    assert!(e.contains("planner.resolution"), "{e}");
    let e = load("resolution = 0.005", "resolution = 0.005\nclearance = 1e-9").unwrap_err().to_string();
    assert!(e.contains("planner.clearance: must be at least 0.00001 m"), "{e}");
    // Duration::from_secs_f64 panicked beyond u64::MAX seconds.
    let e = load("time_limit = 1.0", "time_limit = 1e300").unwrap_err().to_string();
    assert!(e.contains("planner.time_limit: must be at most 86400 s"), "{e}");
    let p = load("resolution = 0.005", "resolution = 0.00001\nclearance = 0.0").unwrap();
    assert_eq!((p.resolution, p.clearance), (MIN_RESOLUTION, 0.0));
}

/// Lazy certification: the trees grow on discrete checks of the padded
/// shapes, and the path's edges are certified when the trees meet. With
/// discrete checks far too coarse to see the wall, edges through it are
/// searched, fail certification and are cut, and the search still ends
/// with a path whose every edge is certified, the same for the same seed.
#[test]
fn lazy_certification_cuts_failed_branches_and_certifies_the_path() {
    use tandem::plan::{LazySearch, rrt_connect_lazy};
    let (problem, start, goal) = wall();
    let clearance = 1e-3;
    let model = problem.collision_model().unwrap();
    let padded = problem.collision_model_padded(clearance).unwrap();
    let (mut ws, mut padded_ws) = (CollisionWorkspace::new(&model), CollisionWorkspace::new(&padded));
    let goals = std::slice::from_ref(&goal);
    let mut cut = 0;
    for resolution in [0.1, 1.0] {
        for seed in 0..6 {
            let settings = PlannerSettings { clearance, seed, ..PlannerSettings::default() };
            let plan = |ws: &mut CollisionWorkspace, padded_ws: &mut CollisionWorkspace| {
                let lazy = LazySearch { padded: &padded, ws: padded_ws, resolution };
                rrt_connect_lazy(&model, ws, lazy, &start, goals, &settings).unwrap()
            };
            let result = plan(&mut ws, &mut padded_ws);
            assert_eq!(result.status, PlanStatus::Solved, "resolution {resolution}, seed {seed}");
            assert_valid(&problem, &result.path, goals);
            for w in result.path.windows(2) {
                assert!(model.motion_free_certified(&mut ws, &w[0], &w[1], clearance / 2.0).unwrap());
            }
            let again = plan(&mut ws, &mut padded_ws);
            assert_eq!((result.path, result.cut), (again.path, again.cut), "same seed, same path");
            cut += result.cut;
        }
    }
    assert!(cut > 0, "no branch was ever cut: the test does not reach the repair");
    let settings = PlannerSettings { clearance, ..PlannerSettings::default() };
    let lazy = LazySearch { padded: &padded, ws: &mut padded_ws, resolution: 0.0 };
    let e = rrt_connect_lazy(&model, &mut ws, lazy, &start, goals, &settings).unwrap_err();
    assert!(matches!(&e, RobotError::InvalidSetting(s) if s.field == "resolution"), "{e}");
}

/// Dynamic-domain sampling with a domain so small that every blocked node
/// rejects nearly every sample: the rejection cap keeps the trees
/// extending, and the plan is still found, free and deterministic. The
/// plain alternating planner (no domain, no balancing) solves it too.
#[test]
fn dynamic_domain_and_balancing_never_starve_a_tree() {
    let (problem, start, goal) = wall();
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let clearance = 1e-3;
    let tiny = DynamicDomain { radius: 1e-9, min_radius: 1e-9, ..DynamicDomain::default() };
    let variants = [
        PlannerSettings { clearance, dynamic_domain: Some(tiny), ..PlannerSettings::default() },
        PlannerSettings {
            clearance,
            dynamic_domain: None,
            root_bias: None,
            balance: false,
            ..PlannerSettings::default()
        },
        PlannerSettings {
            clearance,
            root_bias: Some(RootBias { probability: 0.5, spread: 0.0 }),
            ..PlannerSettings::default()
        },
        PlannerSettings { clearance, ..PlannerSettings::default() },
    ];
    for settings in &variants {
        for seed in 0..5 {
            let settings = PlannerSettings { seed, ..settings.clone() };
            let result = rrt_connect(&model, &mut ws, &start, std::slice::from_ref(&goal), &settings).unwrap();
            assert_eq!(result.status, PlanStatus::Solved, "{settings:?}");
            assert_valid(&problem, &result.path, std::slice::from_ref(&goal));
            let again = rrt_connect(&model, &mut ws, &start, std::slice::from_ref(&goal), &settings).unwrap();
            assert_eq!(result.path, again.path, "same seed, same path");
            assert_eq!(result.iterations, again.iterations);
        }
    }
}

/// The dynamic domain's first radius is given for a 7-joint arm and grows
/// with the square root of the joints (distances between random
/// configurations do): the same on 7 joints, √2 times on two arms.
#[test]
fn dynamic_domain_radius_grows_with_the_square_root_of_the_joints() {
    let domain = DynamicDomain::default();
    assert_eq!(DynamicDomain::REFERENCE_JOINTS, 7);
    assert_eq!(domain.radius_for(7), domain.radius, "a 7-joint arm keeps the radius bit for bit");
    assert!((domain.radius_for(14) - domain.radius * 2f64.sqrt()).abs() < 1e-12);
    assert!((domain.radius_for(28) - 2.0 * domain.radius).abs() < 1e-12);
    for joints in 1..40 {
        assert!(domain.radius_for(joints) < domain.radius_for(joints + 1));
    }
}
