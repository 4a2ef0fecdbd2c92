//! Gradient cross-check of the KOMO features against casadi
//! (`python_ref/casadi_features.py` builds the Panda's forward kinematics
//! symbolically from the URDF and differentiates every feature with
//! `casadi.jacobian`). On 200 seeded random configurations within the
//! limits, every feature type's value and Jacobian agree with casadi to a
//! relative 3e-12 (`|a − b| ≤ 3e-12·max(1, |b|)`, about 100 times the
//! largest error seen, 2.3e-14) and with central finite
//! differences; so do the collision rows `margin − d` of sphere pairs
//! (robot–robot, robot–sphere obstacle, robot–box obstacle), both from the
//! collision model and as rows of a trajectory problem (at the slices and
//! at collision substeps between them). The order-1 and
//! order-2 differenced rows of small trajectory problems agree with finite
//! differences of the whole problem. Maximum errors are printed (stderr).

mod common;

use common::{random_configurations, read_f64_file, repo, run_python};
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use std::sync::Arc;
use std::time::Instant;
use tandem::collision::{CollisionModel, CollisionWorkspace, ObjectSource};
use tandem::komo::{
    COLLISION_CUTOFF, Feature, FeatureWorkspace, FrameRef, Objective, TimeSpan, TrajectoryProblem, TrajectoryWorkspace,
};
use tandem::problem::ObjectiveKind;
use tandem::robot::{KinematicsWorkspace, RobotModel};
use tandem::scene::{Obstacle, Scene, Shape};
use tandem_solvers::finite_diff::central_jacobian;
use tandem_solvers::least_squares::Residuals;

/// Random configurations per check.
const CONFIGURATIONS: usize = 200;
/// Relative tolerance against casadi: about 100 × the largest error seen
/// (2.3e-14, orientation-difference Jacobians).
const CASADI_TOLERANCE: f64 = 3e-12;
/// Relative tolerance against central differences with step `FD_STEP`
/// (truncation O(h²) plus rounding O(ε/h) ≈ 1e-10 for features of order one).
const FD_TOLERANCE: f64 = 1e-7;
const FD_STEP: f64 = 1e-6;
/// Step of the differences of whole problems, whose rows reach ~10² (1/τ²
/// = 16 times scales): there rounding (ε·|r|/h) dominates at 1e-6.
const PROBLEM_FD_STEP: f64 = 1e-5;
/// Random trajectories per differenced problem.
const TRAJECTORIES: usize = 20;
/// Rotation angles compared for the orientation difference (the casadi log
/// map is the atan2 one, exact away from 0 and π).
const ANGLES: std::ops::Range<f64> = 0.1..3.0;

/// `|a − b| / max(1, |b|)`.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1.0)
}

/// Largest relative errors of one kind of check (`None`: not checked).
#[derive(Debug, Default, Clone)]
struct Stats {
    value: Option<f64>,
    jacobian: Option<f64>,
    fd: Option<f64>,
    samples: usize,
}

/// Records error `e` into `slot`.
fn record(slot: &mut Option<f64>, e: f64) {
    *slot = Some(slot.map_or(e, |m| common::worst(m, e)));
}

/// Stats by label, in first-seen order.
#[derive(Debug, Default)]
struct Report(Vec<(String, Stats)>);

impl Report {
    fn entry(&mut self, label: &str) -> &mut Stats {
        let k = match self.0.iter().position(|(l, _)| l == label) {
            Some(k) => k,
            None => {
                self.0.push((label.to_string(), Stats::default()));
                self.0.len() - 1
            }
        };
        &mut self.0[k].1
    }

    fn print(&self, title: &str) {
        let show = |v: Option<f64>| v.map_or("-".to_string(), |e| format!("{e:.2e}"));
        eprintln!("{title}");
        eprintln!("  {:<50} {:>7} {:>10} {:>10} {:>10}", "check", "samples", "value", "jacobian", "vs FD");
        for (label, s) in &self.0 {
            let (v, j, f) = (show(s.value), show(s.jacobian), show(s.fd));
            eprintln!("  {label:<50} {:>7} {v:>10} {j:>10} {f:>10}", s.samples);
        }
    }
}

fn pose(p: [f64; 3], rpy: [f64; 3]) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(
        Translation3::from(Vector3::from(p)),
        Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

fn frame_json(robot: &RobotModel, frame: &FrameRef) -> Value {
    match frame {
        FrameRef::Robot(id) => json!(robot.frame_name(*id)),
        FrameRef::Fixed(p) => {
            let r = p.rotation.matrix();
            let rows: Vec<[f64; 3]> = (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect();
            json!({"translation": p.translation.vector.as_slice(), "rotation": rows})
        }
    }
}

/// The feature as `casadi_features.py` reads it.
fn feature_json(robot: &RobotModel, feature: &Feature) -> Value {
    let f = |frame: &FrameRef| frame_json(robot, frame);
    match feature {
        Feature::JointState => json!({"type": "joint_state"}),
        Feature::JointLimits { margin } => json!({"type": "joint_limits", "margin": margin}),
        Feature::Position { frame } => json!({"type": "position", "frame": f(frame)}),
        Feature::PositionDifference { a, b } => json!({"type": "position_difference", "a": f(a), "b": f(b)}),
        Feature::ScalarProduct { a, axis_a, b, axis_b } => {
            json!({"type": "scalar_product", "a": f(a), "axis_a": axis_a, "b": f(b), "axis_b": axis_b})
        }
        Feature::Vector { a, axis, b } => json!({"type": "vector", "a": f(a), "axis": axis, "b": f(b)}),
        Feature::OrientationDifference { a, b } => json!({"type": "orientation_difference", "a": f(a), "b": f(b)}),
        Feature::Collision { margin, obstacle_margin } => {
            assert_eq!(margin, obstacle_margin, "casadi_features.py reads one margin");
            json!({"type": "collision", "margin": margin})
        }
    }
}

/// Values of the movable joints that are not active (the fingers).
fn held(robot: &RobotModel) -> serde_json::Map<String, Value> {
    let values = robot.all_joint_values(&robot.neutral_configuration()).unwrap();
    robot
        .description()
        .joints()
        .iter()
        .enumerate()
        .filter(|(_, j)| j.kind.is_movable() && !robot.joint_names().contains(&j.name))
        .map(|(i, j)| (j.name.clone(), json!(values[i])))
        .collect()
}

/// Runs casadi_features.py on `request` (its "output" set here) and returns
/// the values it wrote.
fn casadi(mut request: Value) -> Vec<f64> {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("casadi.bin");
    request["output"] = json!(output);
    let start = Instant::now();
    let summary = run_python("casadi_features.py", &["features"], &request.to_string());
    eprintln!("casadi ({:.2} s): {}", start.elapsed().as_secs_f64(), summary.trim());
    read_f64_file(&output)
}

fn robot_frame(robot: &RobotModel, name: &str) -> FrameRef {
    FrameRef::Robot(robot.frame_id(name).unwrap())
}

/// Every fixed-size feature type, robot–robot, robot–fixed and fixed–robot.
fn features(robot: &RobotModel) -> Vec<(&'static str, Feature)> {
    let tcp = robot_frame(robot, "panda_hand_tcp");
    let link4 = robot_frame(robot, "panda_link4");
    let link7 = robot_frame(robot, "panda_link7");
    let fixed = FrameRef::Fixed(pose([0.5, 0.1, 0.06], [3.0, 0.2, -0.4]));
    let other = FrameRef::Fixed(pose([-0.2, 0.4, 0.7], [-0.7, 1.1, 2.5]));
    vec![
        ("joint_state", Feature::JointState),
        ("joint_limits", Feature::JointLimits { margin: 0.01 }),
        ("position", Feature::Position { frame: tcp.clone() }),
        ("position (link4)", Feature::Position { frame: link4.clone() }),
        ("position_difference robot-robot", Feature::PositionDifference { a: tcp.clone(), b: link4.clone() }),
        ("position_difference robot-fixed", Feature::PositionDifference { a: tcp.clone(), b: fixed.clone() }),
        ("position_difference fixed-robot", Feature::PositionDifference { a: other.clone(), b: link7.clone() }),
        (
            "scalar_product robot-robot",
            Feature::ScalarProduct { a: tcp.clone(), axis_a: 1, b: link4.clone(), axis_b: 0 },
        ),
        (
            "scalar_product robot-fixed",
            Feature::ScalarProduct { a: tcp.clone(), axis_a: 2, b: fixed.clone(), axis_b: 2 },
        ),
        ("vector robot-robot", Feature::Vector { a: tcp.clone(), axis: 0, b: link4.clone() }),
        ("vector robot-fixed", Feature::Vector { a: tcp.clone(), axis: 2, b: fixed.clone() }),
        ("vector fixed-robot", Feature::Vector { a: other.clone(), axis: 1, b: link7.clone() }),
        ("orientation_difference robot-robot", Feature::OrientationDifference { a: tcp.clone(), b: link4 }),
        ("orientation_difference robot-fixed", Feature::OrientationDifference { a: tcp, b: fixed }),
        ("orientation_difference fixed-robot", Feature::OrientationDifference { a: other, b: link7 }),
    ]
}

#[test]
fn features_match_casadi_and_finite_differences() {
    let start = Instant::now();
    let robot = RobotModel::panda();
    let nq = robot.nq();
    let features = features(&robot);
    let configs = random_configurations(&robot, CONFIGURATIONS, 55);
    let urdf = repo().join("problems/robots/panda/panda.urdf");
    let request = json!({
        "urdf": urdf,
        "joints": robot.joint_names(),
        "held": held(&robot),
        "features": features.iter().map(|(_, f)| feature_json(&robot, f)).collect::<Vec<_>>(),
        "configurations": configs,
    });
    let reference = casadi(request);
    let dims: Vec<usize> = features.iter().map(|(_, f)| f.dim(&robot)).collect();
    assert_eq!(reference.len(), configs.len() * dims.iter().map(|d| d * (1 + nq)).sum::<usize>());

    let mut report = Report::default();
    let (mut kin, mut kin_fd) = (KinematicsWorkspace::new(&robot), KinematicsWorkspace::new(&robot));
    let (mut scratch, mut scratch_fd) = (FeatureWorkspace::new(&robot), FeatureWorkspace::new(&robot));
    let mut cursor = 0;
    for q in &configs {
        robot.forward_kinematics(&mut kin, q).unwrap();
        for ((label, feature), &dim) in features.iter().zip(&dims) {
            let (ref_value, ref_jac) = reference[cursor..cursor + dim * (1 + nq)].split_at(dim);
            cursor += dim * (1 + nq);
            let (mut value, mut jac) = (vec![0.0; dim], vec![0.0; dim * nq]);
            feature.evaluate(&robot, &kin, q, &mut scratch, &mut value, &mut jac).unwrap();
            if matches!(feature, Feature::OrientationDifference { .. })
                && !ANGLES.contains(&Vector3::from_column_slice(&value).norm())
            {
                continue;
            }
            let stats = report.entry(label);
            stats.samples += 1;
            for (i, (a, b)) in value.iter().zip(ref_value).enumerate() {
                let e = rel(*a, *b);
                assert!(e <= CASADI_TOLERANCE, "{label} value {i} at {q:?}: tandem {a}, casadi {b}");
                record(&mut stats.value, e);
            }
            for (k, (a, b)) in jac.iter().zip(ref_jac).enumerate() {
                let e = rel(*a, *b);
                assert!(e <= CASADI_TOLERANCE, "{label} ∂{}/∂q{} at {q:?}: tandem {a}, casadi {b}", k / nq, k % nq);
                record(&mut stats.jacobian, e);
            }
            let mut fd = vec![0.0; dim * nq];
            let mut unused = vec![0.0; dim * nq];
            let f = |x: &[f64], out: &mut [f64]| {
                robot.forward_kinematics(&mut kin_fd, x).unwrap();
                feature.evaluate(&robot, &kin_fd, x, &mut scratch_fd, out, &mut unused).unwrap();
            };
            central_jacobian(f, q, dim, FD_STEP, &mut fd);
            for r in 0..dim {
                for k in 0..nq {
                    let (a, b) = (jac[r * nq + k], fd[k * dim + r]);
                    let e = rel(a, b);
                    assert!(e <= FD_TOLERANCE, "{label} ∂{r}/∂q{k} at {q:?}: tandem {a}, central difference {b}");
                    record(&mut stats.fd, e);
                }
            }
        }
    }
    for (label, _) in &features {
        let n = report.entry(label).samples;
        assert!(n >= 100, "{label}: only {n} configurations compared");
    }
    report.print(&format!(
        "features vs casadi and central differences (relative errors, {} configurations, {:.2} s)",
        configs.len(),
        start.elapsed().as_secs_f64()
    ));
}

/// The wall of `panda_reach_obstacle`, the table, a tilted slab and two balls.
fn collision_scene() -> Scene {
    let mut s = Scene::new();
    let obstacles = [
        Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04),
        Obstacle::new("wall", Shape::cuboid([0.3, 0.04, 0.5]), pose([0.45, 0.0, 0.25], [0.0; 3])),
        Obstacle::new("slab", Shape::cuboid([0.3, 0.05, 0.4]), pose([0.1, -0.45, 0.5], [0.3, -0.2, 0.7])),
        Obstacle::new("ball", Shape::sphere(0.12), pose([0.45, 0.3, 0.55], [0.0; 3])),
        Obstacle::new("small ball", Shape::sphere(0.05), pose([-0.3, 0.3, 0.7], [0.0; 3])),
    ];
    for o in obstacles {
        s.add_obstacle(o).unwrap();
    }
    s.allow_contact("panda_link0", "table");
    s
}

/// Which comparison a pair belongs to (`None`: not a sphere pair).
fn pair_label(model: &CollisionModel, pair: usize, distance: f64) -> &'static str {
    let (_, b) = model.pair_objects(pair);
    match (model.object_source(b), model.object_shape(b)) {
        (ObjectSource::RobotLink { .. }, _) => "collision robot sphere-robot sphere",
        (_, Shape::Sphere { .. }) => "collision robot sphere-sphere obstacle",
        (_, Shape::Box { .. }) if distance > 0.0 => "collision robot sphere-box obstacle (separated)",
        (_, Shape::Box { .. }) => "collision robot sphere-box obstacle (penetrating)",
        (_, other) => panic!("pair {pair}: no casadi counterpart for {}", other.kind_name()),
    }
}

#[test]
fn collision_rows_match_casadi_and_finite_differences() {
    let start = Instant::now();
    let robot = Arc::new(RobotModel::panda());
    let nq = robot.nq();
    let (margin, padding) = (0.01, 0.002);
    let model = CollisionModel::builder(robot.clone()).scene(&collision_scene()).padding(padding).build().unwrap();
    let pairs = model.pair_count();
    let configs = random_configurations(&robot, CONFIGURATIONS, 56);
    let urdf = repo().join("problems/robots/panda/panda.urdf");
    let exchange = model.to_exchange_json(&urdf, &[], &[]).unwrap();
    // The trajectory problem below (start configs[0], x = configs[c], configs[c + 1]
    // for even c, one collision substep) also needs the midpoints of its
    // motions: configuration CONFIGURATIONS + c is start → configs[c], + c + 1
    // is configs[c] → configs[c + 1].
    let lerp = |a: &[f64], b: &[f64], s: f64| -> Vec<f64> { a.iter().zip(b).map(|(a, b)| a + s * (b - a)).collect() };
    let mut all = configs.clone();
    for c in (0..CONFIGURATIONS - 1).step_by(2) {
        all.push(lerp(&configs[0], &configs[c], 0.5));
        all.push(lerp(&configs[c], &configs[c + 1], 0.5));
    }
    let request = json!({
        "urdf": urdf,
        "joints": robot.joint_names(),
        "held": exchange["held"],
        "features": [feature_json(&robot, &Feature::Collision { margin, obstacle_margin: margin })],
        "collision": {
            "robot_elements": exchange["robot_elements"],
            "obstacles": exchange["obstacles"],
            "pairs": exchange["pairs"],
            "padding": padding,
        },
        "configurations": all,
    });
    let reference = casadi(request);
    assert_eq!(reference.len(), all.len() * pairs * (1 + nq));
    // Values (margin − d) and Jacobians of configuration c.
    let at = |c: usize| reference[c * pairs * (1 + nq)..(c + 1) * pairs * (1 + nq)].split_at(pairs);

    let mut report = Report::default();
    let (mut ws, mut ws_fd) = (CollisionWorkspace::new(&model), CollisionWorkspace::new(&model));
    let mut gradient = vec![0.0; nq];
    let mut fd = vec![0.0; pairs * nq];
    for (c, q) in configs.iter().enumerate() {
        let (ref_value, ref_jac) = at(c);
        let f = |x: &[f64], out: &mut [f64]| {
            let ds = model.distances(&mut ws_fd, x, f64::INFINITY).unwrap();
            assert_eq!(ds.len(), out.len());
            for d in ds {
                out[d.pair] = margin - d.signed.distance;
            }
        };
        central_jacobian(f, q, pairs, FD_STEP, &mut fd);
        let distances = model.distances(&mut ws, q, f64::INFINITY).unwrap().to_vec();
        assert_eq!(distances.len(), pairs, "every pair without a cutoff");
        for d in &distances {
            let p = d.pair;
            let label = pair_label(&model, p, d.signed.distance);
            let stats = report.entry(label);
            stats.samples += 1;
            let (a, b) = (margin - d.signed.distance, ref_value[p]);
            let e = rel(a, b);
            assert!(
                e <= CASADI_TOLERANCE,
                "{label} pair {p} {:?} at {q:?}: tandem {a}, casadi {b}",
                model.pair_names(p)
            );
            record(&mut stats.value, e);
            model.distance_gradient(&ws, d, &mut gradient).unwrap();
            for k in 0..nq {
                let (a, b) = (-gradient[k], ref_jac[p * nq + k]);
                let e = rel(a, b);
                assert!(e <= CASADI_TOLERANCE, "{label} pair {p} ∂/∂q{k} at {q:?}: tandem {a}, casadi {b}");
                record(&mut stats.jacobian, e);
                let b = fd[k * pairs + p];
                let e = rel(a, b);
                assert!(e <= FD_TOLERANCE, "{label} pair {p} ∂/∂q{k} at {q:?}: tandem {a}, central difference {b}");
                record(&mut stats.fd, e);
            }
        }
    }

    // The same rows inside a trajectory problem: scale·(m − d) per pair
    // closer than the larger margin + COLLISION_CUTOFF, with m the obstacle
    // margin for pairs against an obstacle and the margin otherwise, at each
    // slice and at the midpoint of the motion into it (gradient split ½–½
    // over both slices, or all on slice 1 after the fixed start).
    let (scale, obstacle_margin) = (2.0, 0.03);
    let pair_margin = |p: usize| match model.object_source(model.pair_objects(p).1) {
        ObjectSource::Obstacle(_) => obstacle_margin,
        _ => margin,
    };
    let feature = Feature::Collision { margin, obstacle_margin };
    let objective = Objective::new("collision", feature, ObjectiveKind::Inequality).scale(scale);
    let problem =
        TrajectoryProblem::new(robot.clone(), Some(model.clone()), vec![objective], 2, 1, 1.0, configs[0].clone())
            .unwrap()
            .with_collision_substeps(1);
    let mut tws = TrajectoryWorkspace::new(&problem);
    let mut rows = Residuals::default();
    for c in (0..CONFIGURATIONS - 1).step_by(2) {
        let x = [configs[c].clone(), configs[c + 1].clone()].concat();
        problem.residuals(&mut tws, &x, &mut rows).unwrap();
        assert!(rows.cost.is_empty() && rows.equality.is_empty());
        let mut r = 0;
        // (reference configuration, slice, fraction of the motion into it)
        let samples = [(CONFIGURATIONS + c, 0, 0.5), (c, 0, 1.0), (CONFIGURATIONS + c + 1, 1, 0.5), (c + 1, 1, 1.0)];
        for (index, t, s) in samples {
            let label = if s < 1.0 {
                "collision rows of a trajectory problem (substeps)"
            } else {
                "collision rows of a trajectory problem (slices)"
            };
            let (ref_value, ref_jac) = at(index);
            let near = model.distances(&mut ws, &all[index], obstacle_margin + COLLISION_CUTOFF).unwrap().to_vec();
            for d in near {
                let stats = report.entry(label);
                stats.samples += 1;
                let p = d.pair;
                // casadi's value is margin − d.
                let (a, b) = (rows.inequality.value(r), scale * (ref_value[p] + pair_margin(p) - margin));
                let e = rel(a, b);
                assert!(e <= CASADI_TOLERANCE, "row {r} (slice {}, s {s}, pair {p}): tandem {a}, casadi {b}", t + 1);
                record(&mut stats.value, e);
                let (first, entries) = rows.inequality.gradient(r);
                let mut dense = vec![0.0; 2 * nq];
                dense[first..first + entries.len()].copy_from_slice(entries);
                for (k, a) in dense.iter().enumerate() {
                    let share = match k / nq {
                        slice if slice == t => s,
                        slice if slice + 1 == t => 1.0 - s,
                        _ => 0.0,
                    };
                    let b = share * scale * ref_jac[p * nq + k % nq];
                    let e = rel(*a, b);
                    assert!(
                        e <= CASADI_TOLERANCE,
                        "row {r} (slice {}, s {s}, pair {p}) ∂/∂x{k}: tandem {a}, casadi {b}",
                        t + 1
                    );
                    record(&mut stats.jacobian, e);
                }
                r += 1;
            }
        }
        assert_eq!(r, rows.inequality.len(), "one row per pair within the cutoff");
    }
    for (label, s) in &report.0 {
        assert!(s.samples >= 100, "{label}: only {} pairs compared", s.samples);
    }
    report.print(&format!(
        "collision rows margin − d vs casadi and central differences ({} pairs × {} configurations + {} midpoints, {:.2} s)",
        pairs,
        configs.len(),
        all.len() - configs.len(),
        start.elapsed().as_secs_f64()
    ));
}

/// Rows of `problem` at `x`: all values (cost, equality, inequality) and
/// the dense Jacobian (row-major, rows × x.len()).
fn dense_rows(problem: &TrajectoryProblem, ws: &mut TrajectoryWorkspace, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut rows = Residuals::default();
    problem.residuals(ws, x, &mut rows).unwrap();
    let (mut values, mut jac) = (Vec::new(), Vec::new());
    for block in [&rows.cost, &rows.equality, &rows.inequality] {
        for r in 0..block.len() {
            values.push(block.value(r));
            let mut dense = vec![0.0; x.len()];
            let (first, entries) = block.gradient(r);
            dense[first..first + entries.len()].copy_from_slice(entries);
            jac.extend(dense);
        }
    }
    (values, jac)
}

/// Rows of order-`order` objectives of every fixed-size feature type, some
/// over part of the motion (so that the differences reach the start).
fn differenced_objectives(robot: &RobotModel, order: usize, fixed: IsometryMatrix3<f64>) -> Vec<Objective> {
    use ObjectiveKind::{Equality, Inequality, SumOfSquares};
    let tcp = robot_frame(robot, "panda_hand_tcp");
    let link4 = robot_frame(robot, "panda_link4");
    let link7 = robot_frame(robot, "panda_link7");
    let fixed = FrameRef::Fixed(fixed);
    let vec3 = |s: f64| vec![0.1 * s, -0.2 * s, 0.3 * s];
    vec![
        Objective::control(order),
        Objective::new("joints", Feature::JointState, SumOfSquares).order(order).scale(0.3).during(0.5, 1.0),
        Objective::new("limits", Feature::JointLimits { margin: 0.05 }, Inequality).order(order),
        Objective::new("tcp", Feature::Position { frame: tcp.clone() }, Equality).order(order).target(vec3(1.0)),
        Objective::new("tcp-link4", Feature::PositionDifference { a: tcp.clone(), b: link4.clone() }, SumOfSquares)
            .order(order)
            .scale(0.5),
        Objective::new("tcp-fixed", Feature::PositionDifference { a: tcp.clone(), b: fixed.clone() }, Equality)
            .order(order)
            .time(TimeSpan::Slices { first: 1, last: 3 }),
        Objective::new(
            "axes",
            Feature::ScalarProduct { a: tcp.clone(), axis_a: 2, b: link4.clone(), axis_b: 1 },
            Inequality,
        )
        .order(order),
        Objective::new("down", Feature::Vector { a: tcp.clone(), axis: 2, b: fixed.clone() }, Equality)
            .order(order)
            .target(vec3(0.5)),
        Objective::new("turn", Feature::OrientationDifference { a: tcp.clone(), b: fixed }, SumOfSquares)
            .order(order)
            .scale(2.0),
        Objective::new("wrist", Feature::OrientationDifference { a: link7, b: link4 }, SumOfSquares)
            .order(order)
            .during(0.4, 0.8),
        Objective::new("reach", Feature::Position { frame: tcp }, Equality).time(TimeSpan::END).target(vec3(1.0)),
    ]
}

#[test]
fn differenced_rows_match_finite_differences_of_the_whole_problem() {
    let start_time = Instant::now();
    let robot = Arc::new(RobotModel::panda());
    let n = robot.nq();
    let start = vec![0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let mut kin = KinematicsWorkspace::new(&robot);
    robot.forward_kinematics(&mut kin, &start).unwrap();
    let tcp = robot.frame_pose(&kin, robot.frame_id("panda_hand_tcp").unwrap());
    // A fixed frame turned ~0.8 rad from the gripper at the start.
    let fixed = tcp * pose([0.05, -0.1, 0.2], [0.6, -0.4, 0.3]);
    let mut report = Report::default();
    let mut rng = ChaCha8Rng::seed_from_u64(57);
    let horizon = 6;
    for order in [1, 2] {
        let label = format!("order-{order} rows (T = {horizon}, k = {order})");
        let objectives = differenced_objectives(&robot, order, fixed);
        let problem =
            TrajectoryProblem::new(robot.clone(), None, objectives, horizon, order, 1.5, start.clone()).unwrap();
        let (mut ws, mut ws_fd) = (TrajectoryWorkspace::new(&problem), TrajectoryWorkspace::new(&problem));
        let expected_rows: usize = problem
            .objectives()
            .iter()
            .map(|o| {
                let (first, last) = o.time.slices(horizon);
                o.feature.dim(&robot) * (last - first + 1)
            })
            .sum();
        for _ in 0..TRAJECTORIES {
            // A random walk from the start, within the limits.
            let mut q = start.clone();
            let mut x = Vec::with_capacity(horizon * n);
            for _ in 0..horizon {
                for (v, l) in q.iter_mut().zip(robot.limits()) {
                    *v = (*v + rng.random_range(-0.15..=0.15)).clamp(l.lower + 0.01, l.upper - 0.01);
                }
                x.extend_from_slice(&q);
            }
            let (values, jac) = dense_rows(&problem, &mut ws, &x);
            let m = values.len();
            assert_eq!(m, expected_rows, "one row per objective component and slice");
            let mut fd = vec![0.0; m * x.len()];
            let f = |x: &[f64], out: &mut [f64]| {
                let (v, _) = dense_rows(&problem, &mut ws_fd, x);
                out.copy_from_slice(&v);
            };
            central_jacobian(f, &x, m, PROBLEM_FD_STEP, &mut fd);
            let stats = report.entry(&label);
            stats.samples += m;
            for r in 0..m {
                for k in 0..x.len() {
                    let (a, b) = (jac[r * x.len() + k], fd[k * m + r]);
                    let e = rel(a, b);
                    assert!(e <= FD_TOLERANCE, "{label}: row {r} ∂/∂x{k}: analytic {a}, central difference {b}");
                    record(&mut stats.fd, e);
                }
            }
        }
    }
    report.print(&format!(
        "differenced rows vs central differences of the whole problem (samples: rows × {TRAJECTORIES} trajectories, {:.2} s)",
        start_time.elapsed().as_secs_f64()
    ));
}
