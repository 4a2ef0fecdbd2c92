//! Point clouds as obstacles, against references outside tandem's model:
//!
//! - distances from every robot sphere to the nearest point against
//!   SciPy's `cKDTree` (exact nearest neighbours), and their gradients
//!   against central finite differences;
//! - the covering claim of `Shape::surface_points` by brute force;
//! - plans on MotionBenchMaker scenes seen as clouds (2 cm apart on every
//!   surface, 1.5 cm balls), checked against the primitives themselves by
//!   coal: the plan keeps clear of the real obstacles, because every
//!   surface point lies within the covering radius (≤ 2 cm / √2 ≈ 1.41 cm)
//!   of a sample and the balls are wider than that.

mod common;

use common::{random_configurations, read_f64_file, run_python};
use nalgebra::{IsometryMatrix3, Point3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::plan::{PlanStatus, plan_problem};
use tandem::problem::Problem;
use tandem::robot::RobotModel;
use tandem::scene::{Obstacle, Scene, Shape};

/// Distances against cKDTree (m): both are exact; seen 5.6e-17.
const DISTANCE_TOLERANCE: f64 = 1e-14;
/// Gradients against central differences with h = 1e-6 (their own error,
/// O(h²) and rounding); seen 9.7e-10.
const GRADIENT_TOLERANCE: f64 = 1e-7;

/// A cloud through the Panda's reach: a noisy shelf of points and a random
/// scatter, placed by a sensor pose that is not the identity.
fn cloud(seed: u64) -> (Vec<[f64; 3]>, IsometryMatrix3<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut points: Vec<[f64; 3]> = (0..3000)
        .map(|_| [rng.random_range(-0.6..0.6), rng.random_range(-0.6..0.6), rng.random_range(0.0..1.0)])
        .collect();
    points.extend(
        (0..2000).map(|_| [rng.random_range(0.3..0.7), rng.random_range(-0.4..0.4), 0.4 + 0.002 * rng.random::<f64>()]),
    );
    let pose = IsometryMatrix3::from_parts(
        nalgebra::Translation3::new(0.05, -0.02, 0.1),
        nalgebra::Rotation3::from_euler_angles(0.1, -0.05, 0.3),
    );
    (points, pose)
}

#[test]
fn nearest_distances_match_scipy_and_gradients_match_finite_differences() {
    let robot = Arc::new(RobotModel::panda());
    let (points, pose) = cloud(11);
    let radius = 0.004;
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::new("camera", Shape::points(&points, radius).unwrap(), pose)).unwrap();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    // Every robot sphere's centre (world) at every configuration, with the
    // pair's distance, for SciPy.
    let configs = random_configurations(&robot, 40, 5);
    let (mut queries, mut ours, mut reaches) = (Vec::new(), Vec::new(), Vec::new());
    let mut gradients_checked = 0;
    let mut worst_gradient = 0.0f64;
    for q in &configs {
        let distances = model.distances(&mut ws, q, f64::INFINITY).unwrap().to_vec();
        for d in distances.iter().filter(|d| model.pair_names(d.pair).1 == "camera") {
            let (a, _) = model.pair_objects(d.pair);
            let Shape::Sphere { radius: r } = model.object_shape(a) else { panic!("spheres expected") };
            let c = model.object_world_pose(&ws, a).translation.vector;
            queries.push([c.x, c.y, c.z]);
            ours.push(d.signed.distance);
            reaches.push(r + model.padding() + radius);
            assert!(d.signed.distance.is_finite());
            // Witnesses: p_b − p_a = distance · normal.
            let gap = d.signed.point_b - d.signed.point_a - d.signed.normal * d.signed.distance;
            assert!(gap.norm() < 1e-12, "witnesses off by {}", gap.norm());
        }
        // Gradients of the closest few pairs by central differences.
        let mut closest = distances.clone();
        closest.retain(|d| model.pair_names(d.pair).1 == "camera");
        closest.sort_by(|a, b| a.signed.distance.total_cmp(&b.signed.distance));
        for d in closest.iter().take(3) {
            let mut gradient = vec![0.0; robot.nq()];
            model.distance_gradient(&ws, d, &mut gradient).unwrap();
            let h = 1e-6;
            let mut fd = vec![0.0; robot.nq()];
            for (k, g) in fd.iter_mut().enumerate() {
                let at = |s: f64| {
                    let mut qq = q.clone();
                    qq[k] += s;
                    model.pair_distance_at(&mut CollisionWorkspace::new(&model), &qq, d.pair).unwrap()
                };
                let (plus, minus) = (at(h), at(-h));
                *g = (plus.signed.distance - minus.signed.distance) / (2.0 * h);
            }
            let err = gradient.iter().zip(&fd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            // The nearest point may change within ±h: then the distance has
            // a kink there and differences say nothing; those are skipped.
            let kink = (0..robot.nq()).any(|k| {
                let nearest_at = |s: f64| {
                    let mut qq = q.clone();
                    qq[k] += s;
                    let mut w = CollisionWorkspace::new(&model);
                    model.pair_distance_at(&mut w, &qq, d.pair).unwrap().signed.point_b
                };
                (nearest_at(h) - nearest_at(-h)).norm() > 1e-4
            });
            if kink {
                continue;
            }
            assert!(err < GRADIENT_TOLERANCE, "gradient off by {err}: {gradient:?} vs {fd:?}");
            worst_gradient = worst_gradient.max(err);
            gradients_checked += 1;
        }
    }
    // The cloud in world coordinates, as SciPy gets it.
    let world: Vec<[f64; 3]> = points.iter().map(|p| (pose * Point3::from(*p)).coords.into()).collect();
    let request = serde_json::json!({"points": world, "queries": queries});
    let reply: serde_json::Value =
        serde_json::from_str(&run_python("point_cloud_reference.py", &[], &request.to_string())).unwrap();
    let nearest: Vec<f64> = reply["distances"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(nearest.len(), ours.len());
    let mut worst = 0.0f64;
    for ((ours, reference), reach) in ours.iter().zip(&nearest).zip(&reaches) {
        let err = (ours - (reference - reach)).abs();
        worst = common::worst(worst, err);
    }
    println!(
        "{} sphere-to-cloud distances against SciPy {}: largest difference {worst:e} m; {gradients_checked} gradients, largest difference {worst_gradient:e}",
        ours.len(),
        reply["scipy_version"]
    );
    assert!(worst < DISTANCE_TOLERANCE, "distances differ from SciPy's by {worst}");
    assert!(gradients_checked > 60, "{gradients_checked} gradients checked");
    // With a cutoff (the arbiter's rows, the optimizer's feature: a cloud's
    // nearest point is searched for only within it), exactly the pairs and
    // distances of the full list below the cutoff.
    for q in &configs {
        let all = model.distances(&mut ws, q, f64::INFINITY).unwrap().to_vec();
        for cutoff in [0.0, 0.02, 0.1] {
            let want: Vec<_> =
                all.iter().filter(|d| d.signed.distance < cutoff).map(|d| (d.pair, d.signed.distance)).collect();
            let got: Vec<_> =
                model.distances(&mut ws, q, cutoff).unwrap().iter().map(|d| (d.pair, d.signed.distance)).collect();
            assert_eq!(got, want, "cutoff {cutoff}");
        }
    }
    // Boolean checks agree with the distances.
    for q in &configs {
        let free = model.collision_free(&mut ws, q).unwrap();
        let nearest = model.min_distance(&mut ws, q).unwrap().unwrap().signed.distance;
        assert_eq!(free, nearest > 0.0, "collision_free {free}, nearest {nearest}");
    }
}

#[test]
fn surface_samples_cover_every_surface_point_within_the_spacing() {
    let spacing = 0.02;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let shapes = [
        Shape::cuboid([0.3, 0.05, 0.41]),
        Shape::sphere(0.12),
        Shape::cylinder(0.07, 0.6),
        Shape::capsule(0.05, 0.5),
        Shape::capsule(0.03, 0.0),
    ];
    for shape in shapes {
        let samples: Vec<[f64; 3]> = shape.surface_points(spacing).unwrap().iter().map(|p| [p.x, p.y, p.z]).collect();
        let tree = tandem::point_cloud::PointTree::new(&samples);
        // Random surface points: project random directions onto the surface.
        let mut worst = 0.0f64;
        for _ in 0..20000 {
            let v = nalgebra::Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let far = Point3::from(v.normalize() * 10.0);
            // The surface point nearest a far point, by the exact distance.
            let probe = Shape::sphere(1e-9);
            let d = tandem::collision::signed_distance(
                &probe,
                &IsometryMatrix3::translation(far.x, far.y, far.z),
                &shape,
                &IsometryMatrix3::identity(),
            );
            let p = d.point_b;
            let (d2, _) = tree.nearest(&[p.x, p.y, p.z], f64::INFINITY).unwrap();
            worst = worst.max(d2.sqrt());
        }
        println!("{}: {} samples, farthest surface point {worst:.5} m from one", shape.kind_name(), samples.len());
        assert!(worst <= spacing, "{}: a surface point {worst} m from every sample", shape.kind_name());
        assert!(samples.iter().all(|p| p.iter().all(|c| c.is_finite())));
    }
    assert!(Shape::sphere(0.1).surface_points(0.0).is_none());
    assert!(Shape::sphere(0.1).surface_points(f64::NAN).is_none());
}

#[test]
fn plans_on_sampled_motionbenchmaker_scenes_keep_clear_of_the_primitives_by_coal() {
    let mbm = common::mbm();
    let dir = tempfile::tempdir().unwrap();
    let problems = common::unpack_mbm(dir.path());
    let (urdf, srdf) = (mbm.join("panda_spherized.urdf"), mbm.join("panda.srdf"));
    let (spacing, radius) = (0.02, 0.015);
    let (mut solved, mut inflated_ends, mut configurations, mut worst) = (0, 0, 0, f64::INFINITY);
    for family in ["bookshelf_small", "box", "table_pick", "table_under_pick"] {
        for k in 1..=3 {
            let at = |f: &str| problems.join(format!("{family}_panda/{f}{k:04}.yaml"));
            let primitives = Problem::from_moveit(&urdf, &srdf, &at("scene"), &at("request")).unwrap();
            let mut problem = primitives.clone();
            problem.scene = common::sampled_scene(&primitives.scene, spacing, radius);
            problem.planner.time_limit = 5.0;
            let report = plan_problem(&problem, Some(0)).unwrap();
            if matches!(report.result.status, PlanStatus::StartInvalid | PlanStatus::GoalInvalid) {
                // The balls reach up to 1.5 cm past the surfaces: a start or
                // goal closer than that to an obstacle is in collision.
                inflated_ends += 1;
                continue;
            }
            assert_eq!(report.result.status, PlanStatus::Solved, "{family} {k}");
            assert!(report.certified, "{family} {k}: path not certified");
            solved += 1;
            // The path, densely, against the primitives by coal.
            let mut dense = Vec::new();
            for w in report.path.windows(2) {
                for s in 0..50 {
                    let t = s as f64 / 50.0;
                    dense.push(w[0].iter().zip(&w[1]).map(|(a, b)| a + (b - a) * t).collect::<Vec<f64>>());
                }
            }
            dense.push(report.path.last().unwrap().clone());
            let model = primitives.collision_model().unwrap();
            let output = dir.path().join("coal.bin");
            let mut request = model.to_exchange_json(&urdf, &[], &dense).unwrap();
            request["output"] = serde_json::json!(output);
            run_python("coal_reference.py", &["distances"], &request.to_string());
            let reference = read_f64_file(&output);
            let pairs = model.pair_count();
            assert_eq!(reference.len(), dense.len() * pairs * 10);
            for c in 0..dense.len() {
                for p in 0..pairs {
                    let (_, b) = model.pair_names(p);
                    if primitives.scene.obstacle(b).is_none() {
                        continue;
                    }
                    let d = reference[(c * pairs + p) * 10];
                    assert!(d.is_finite() && d > 0.0, "{family} {k}: coal finds {:?} at {d} m", model.pair_names(p));
                    worst = worst.min(d);
                }
            }
            configurations += dense.len();
        }
    }
    println!(
        "{solved} plans on clouds, {configurations} configurations checked by coal, nearest obstacle {worst:.4} m; {inflated_ends} problems with a start or goal inside the balls"
    );
    assert!(solved >= 8, "{solved} solved");
}
