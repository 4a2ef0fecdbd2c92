//! Collision queries against themselves and finite differences: the
//! pruned queries (boolean, minimum, minimum below a bound, cutoff) agree with the exhaustive
//! all-pairs distances, gradients agree with central differences, motion
//! validation agrees with dense sampling, padding, SRDF pairs and attached
//! objects behave, and no query allocates.

mod common;

use common::alloc::{CountingAllocator, allocations};
use common::{random_configurations, repo, worst};

/// Distance gradients against central differences (h = 1e-6): about 100
/// times the largest difference seen (1.7e-10).
const GRADIENT_TOLERANCE: f64 = 2e-8;
use nalgebra::{IsometryMatrix3, Translation3, Vector3};
use std::sync::Arc;
use tandem::collision::{CollisionError, CollisionModel, CollisionWorkspace};
use tandem::problem::Problem;
use tandem::robot::{MeshSearchPath, RobotDescription, RobotModel, Srdf};
use tandem::scene::{Obstacle, Scene, SceneObject, Shape, ShapeError};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn cluttered() -> (Arc<RobotModel>, Scene) {
    let robot = Arc::new(RobotModel::panda());
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04)).unwrap();
    let at = |x, y, z| IsometryMatrix3::translation(x, y, z);
    scene.add_obstacle(Obstacle::new("crate", Shape::cuboid([0.2, 0.3, 0.3]), at(0.5, -0.3, 0.3))).unwrap();
    scene.add_obstacle(Obstacle::new("ball", Shape::sphere(0.1), at(0.4, 0.35, 0.5))).unwrap();
    scene.add_obstacle(Obstacle::new("post", Shape::cylinder(0.05, 0.8), at(-0.3, 0.3, 0.4))).unwrap();
    scene.add_obstacle(Obstacle::new("bar", Shape::capsule(0.04, 0.6), at(0.2, 0.0, 0.9))).unwrap();
    scene.allow_contact("panda_link0", "table");
    (robot, scene)
}

#[test]
fn pruned_queries_agree_with_all_pairs() {
    let (robot, scene) = cluttered();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).padding(0.003).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let (mut colliding, mut free) = (0, 0);
    // Around the ready pose, where free and colliding configurations mix.
    let ready = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let near_ready = random_configurations(&robot, 400, 3)
        .into_iter()
        .map(|q| q.iter().zip(ready).map(|(v, r)| r + 0.5 * (v - r)).collect::<Vec<f64>>());
    for q in near_ready {
        let all = model.distances(&mut ws, &q, f64::INFINITY).unwrap().to_vec();
        assert_eq!(all.len(), model.pair_count());
        let deepest = -all.iter().map(|d| -d.signed.distance).fold(f64::NEG_INFINITY, worst);
        let min = model.min_distance(&mut ws, &q).unwrap().unwrap();
        assert_eq!(min.signed.distance, deepest, "min_distance is not the minimum over all pairs");
        for bound in [-0.02, 0.0, 0.05, f64::INFINITY] {
            let below = model.min_distance_below(&mut ws, &q, bound).unwrap().map(|d| d.signed.distance);
            assert_eq!(below, (deepest < bound).then_some(deepest), "min_distance_below {bound}");
        }
        let is_free = model.collision_free(&mut ws, &q).unwrap();
        assert_eq!(is_free, deepest >= 0.0, "boolean check disagrees with the distances ({deepest})");
        for cutoff in [-0.02, 0.0, 0.05, 0.3] {
            let near: Vec<_> =
                model.distances(&mut ws, &q, cutoff).unwrap().iter().map(|d| (d.pair, d.signed.distance)).collect();
            let expected: Vec<_> =
                all.iter().filter(|d| d.signed.distance < cutoff).map(|d| (d.pair, d.signed.distance)).collect();
            assert_eq!(near, expected, "cutoff {cutoff}");
        }
        if is_free { free += 1 } else { colliding += 1 }
    }
    println!("{free} free, {colliding} colliding configurations");
    assert!(free > 40 && colliding > 40);
}

#[test]
fn distance_gradients_match_central_differences() {
    let (robot, scene) = cluttered();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let mut gradient = vec![0.0; 7];
    let (mut largest, mut checked) = (0.0f64, 0);
    let h = 1e-6;
    for q in random_configurations(&robot, 60, 11) {
        let near = model.distances(&mut ws, &q, 0.15).unwrap().to_vec();
        for d in near.iter().filter(|d| d.signed.distance.abs() > 1e-4) {
            model.pair_distance_at(&mut ws, &q, d.pair).unwrap();
            model.distance_gradient(&ws, d, &mut gradient).unwrap();
            for k in 0..7 {
                let mut value = |delta: f64| {
                    let mut qk = q.clone();
                    qk[k] += delta;
                    model.pair_distance_at(&mut ws, &qk, d.pair).unwrap().signed.distance
                };
                let fd = (value(h) - value(-h)) / (2.0 * h);
                largest = worst(largest, (fd - gradient[k]).abs());
                assert!(
                    (fd - gradient[k]).abs() < GRADIENT_TOLERANCE,
                    "pair {:?} joint {k}: analytic {} vs central difference {fd}",
                    model.pair_names(d.pair),
                    gradient[k]
                );
            }
            checked += 1;
        }
    }
    println!("{checked} pair gradients (penetrating and separated) vs central differences: max error {largest:.2e}");
    assert!(checked > 500);
}

#[test]
fn motion_validation_matches_dense_sampling() {
    let (robot, scene) = cluttered();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let configs = random_configurations(&robot, 400, 17);
    let (mut agree, mut blocked) = (0, 0);
    for pair in configs.chunks(2) {
        let (q0, q1) = (&pair[0], &pair[1]);
        let fast = model.motion_free(&mut ws, q0, q1, 0.02).unwrap();
        // The same grid, walked in order.
        let span = q0.iter().zip(q1).map(|(a, b)| (b - a).abs()).fold(0.0, f64::max);
        let steps = (span / 0.02).ceil() as usize;
        let dense = (0..=steps).all(|k| {
            let t = k as f64 / steps as f64;
            let q: Vec<f64> = q0.iter().zip(q1).map(|(a, b)| a + (b - a) * t).collect();
            model.collision_free(&mut ws, &q).unwrap()
        });
        assert_eq!(fast, dense);
        agree += 1;
        blocked += usize::from(!fast);
    }
    assert!(blocked > 20 && blocked < agree, "{blocked} of {agree} motions blocked");
    let problem = Problem::from_file(repo().join("problems/panda_reach_obstacle.toml")).unwrap();
    let model = problem.collision_model().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let tandem::problem::Goal::Joints(goal) = &problem.goal else { panic!("joint goal expected") };
    assert!(
        !model.motion_free(&mut ws, &problem.start, goal, 0.01).unwrap(),
        "the wall must block the straight motion"
    );
    assert!(model.motion_free(&mut ws, &problem.start, &problem.start, 0.01).unwrap());
    assert!(model.motion_free(&mut ws, &problem.start, goal, 0.0).is_err());
}

#[test]
fn padding_shifts_distances_by_the_padded_sides() {
    let (robot, scene) = cluttered();
    let plain = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let padded = CollisionModel::builder(robot.clone()).scene(&scene).padding(0.02).build().unwrap();
    let (mut a, mut b) = (CollisionWorkspace::new(&plain), CollisionWorkspace::new(&padded));
    for q in random_configurations(&robot, 50, 23) {
        let d0 = plain.distances(&mut a, &q, f64::INFINITY).unwrap().to_vec();
        let d1 = padded.distances(&mut b, &q, f64::INFINITY).unwrap();
        for (x, y) in d0.iter().zip(d1) {
            let robot_sides = if plain.pair_names(x.pair).1.starts_with("panda_") { 2.0 } else { 1.0 };
            assert!((x.signed.distance - robot_sides * 0.02 - y.signed.distance).abs() < 1e-12);
        }
    }
    assert!(matches!(
        CollisionModel::builder(robot).padding(-0.1).build(),
        Err(CollisionError::Shape(ShapeError::InvalidShape { what: "padding", .. }))
    ));
}

#[test]
fn srdf_disabled_pairs_and_spherized_geometry() {
    let mbm = common::mbm();
    let desc = Arc::new(
        RobotDescription::from_urdf_file(mbm.join("panda_spherized.urdf"), &MeshSearchPath::default()).unwrap(),
    );
    let srdf = Srdf::from_srdf_file(mbm.join("panda.srdf")).unwrap();
    let robot = Arc::new(
        RobotModel::builder(desc.clone()).selection(srdf.joint_selection("panda_arm").unwrap()).build().unwrap(),
    );
    let all = CollisionModel::builder(robot.clone()).build().unwrap();
    let model = CollisionModel::builder(robot.clone()).srdf(&srdf).build().unwrap();
    assert!(model.pair_count() < all.pair_count());
    for (a, b) in model.body_pairs() {
        assert!(!srdf.is_disabled(a, b), "{a}-{b} is disabled by the SRDF");
    }
    // The ready pose is free of self-collision with the SRDF's pairs.
    let mut ws = CollisionWorkspace::new(&model);
    let ready = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    assert!(model.collision_free(&mut ws, &ready).unwrap());
    // The VAMP spheres can also dress tandem's own Panda (same link names).
    let ours = Arc::new(RobotModel::panda());
    let dressed = CollisionModel::builder(ours).geometry_from(desc).srdf(&srdf).build().unwrap();
    assert_eq!(dressed.pair_count(), model.pair_count());
    assert!(dressed.collision_free(&mut CollisionWorkspace::new(&dressed), &ready).unwrap());
}

#[test]
fn attached_objects_move_with_the_gripper() {
    let (robot, mut scene) = cluttered();
    scene
        .add_object(SceneObject::new(
            "box",
            Shape::cuboid([0.06, 0.06, 0.12]),
            IsometryMatrix3::translation(0.5, 0.1, 0.06),
        ))
        .unwrap();
    let q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let free_model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    assert!(free_model.body_pairs().any(|p| p == ("panda_hand", "box")));
    scene.attach("box", "panda_hand_tcp", IsometryMatrix3::identity()).unwrap();
    assert!(scene.attach("box", "panda_hand_tcp", IsometryMatrix3::identity()).is_err());
    let held = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    // Held in the hand: never checked against the hand body, always against the table.
    assert!(!held.body_pairs().any(|(a, b)| a == "box" && b == "panda_hand" || b == "box" && a == "panda_hand"));
    assert!(held.body_pairs().any(|p| p == ("box", "table")));
    let mut ws = CollisionWorkspace::new(&held);
    let d = held.distances(&mut ws, &q, f64::INFINITY).unwrap();
    let table = *d.iter().find(|d| held.pair_names(d.pair) == ("box", "table")).unwrap();
    // The tcp is 0.487 m above the table; the box reaches 0.06 m below it.
    assert!((table.signed.distance - (0.48687 - 0.06)).abs() < 1e-4, "{}", table.signed.distance);
    let mut gradient = [0.0; 7];
    held.distance_gradient(&ws, &table, &mut gradient).unwrap();
    assert!(gradient[1] < 0.0, "leaning forward lowers the held box");
    scene.detach("box", IsometryMatrix3::translation(0.6, 0.0, 0.06)).unwrap();
    assert!(scene.detach("box", IsometryMatrix3::identity()).is_err());
    assert!(scene.attach("cup", "panda_hand_tcp", IsometryMatrix3::identity()).is_err());
    let mut bad = scene.clone();
    bad.attach("box", "panda_hnd", IsometryMatrix3::identity()).unwrap();
    let err = CollisionModel::builder(robot).scene(&bad).build().unwrap_err();
    assert!(err.to_string().contains("panda_hnd"), "{err}");
}

#[test]
fn queries_allocate_nothing() {
    let (robot, scene) = cluttered();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).padding(0.005).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let configs = random_configurations(&robot, 100, 29);
    let mut gradient = vec![0.0; 7];
    let mut sink = 0.0;
    let mut queries = |ws: &mut CollisionWorkspace| {
        for (k, q) in configs.iter().enumerate() {
            let next = &configs[(k + 1) % 100];
            sink += f64::from(u8::from(model.collision_free(ws, q).unwrap()));
            let min = model.min_distance(ws, q).unwrap().unwrap();
            model.distance_gradient(ws, &min, &mut gradient).unwrap();
            sink += gradient[0] + model.distances(ws, q, 0.1).unwrap().len() as f64;
            sink += f64::from(u8::from(model.motion_free(ws, q, next, 0.05).unwrap()));
            sink += f64::from(u8::from(model.motion_free_certified(ws, q, next, 0.002).unwrap()));
        }
    };
    // Warm up: the distance buffer grows to the pair count, the certification
    // queue to the longest it needs, once.
    queries(&mut ws);
    let before = allocations();
    queries(&mut ws);
    assert_eq!(allocations() - before, 0, "collision queries allocated");
    assert!(sink.is_finite());
}

#[test]
fn bad_inputs_are_typed_errors() {
    let (robot, scene) = cluttered();
    let model = CollisionModel::builder(robot).scene(&scene).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    assert!(model.collision_free(&mut ws, &[0.0; 6]).is_err());
    assert!(model.min_distance(&mut ws, &[f64::NAN; 7]).is_err());
    let d = model.min_distance(&mut ws, &[0.0; 7]).unwrap().unwrap();
    assert!(model.distance_gradient(&ws, &d, &mut [0.0; 3]).is_err());
    let mut s = Scene::new();
    assert!(s.add_obstacle(Obstacle::new("x", Shape::sphere(-1.0), IsometryMatrix3::identity())).is_err());
    let nan = IsometryMatrix3::from_parts(Translation3::from(Vector3::new(f64::NAN, 0.0, 0.0)), Default::default());
    assert!(s.add_obstacle(Obstacle::new("y", Shape::sphere(1.0), nan)).is_err());
    s.add_obstacle(Obstacle::new("z", Shape::sphere(1.0), IsometryMatrix3::identity())).unwrap();
    assert!(s.add_obstacle(Obstacle::new("z", Shape::sphere(1.0), IsometryMatrix3::identity())).is_err());
    s.allow_contact("z", "nothing_here");
    let err = CollisionModel::builder(Arc::new(RobotModel::panda())).scene(&s).build().unwrap_err();
    assert!(err.to_string().contains("nothing_here"));
}

#[test]
fn certified_motions_keep_their_clearance_everywhere() {
    let (robot, scene) = cluttered();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let mut ws = CollisionWorkspace::new(&model);
    let ready = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    let configs: Vec<Vec<f64>> = random_configurations(&robot, 240, 37)
        .into_iter()
        .map(|q| q.iter().zip(ready).map(|(v, r)| r + 0.4 * (v - r)).collect())
        .collect();
    let clearance = 0.004;
    let (mut certified, mut refused) = (0, 0);
    for pair in configs.chunks(2) {
        // Short motions, a third of the way to the other configuration.
        let end: Vec<f64> = pair[0].iter().zip(&pair[1]).map(|(a, b)| a + (b - a) / 3.0).collect();
        let pair = [pair[0].clone(), end];
        let ok = model.motion_free_certified(&mut ws, &pair[0], &pair[1], clearance).unwrap();
        // Dense sampling: 2000 configurations along the motion.
        let mut lowest = f64::INFINITY;
        for k in 0..=2000 {
            let t = k as f64 / 2000.0;
            let q: Vec<f64> = pair[0].iter().zip(&pair[1]).map(|(a, b)| a + (b - a) * t).collect();
            lowest = lowest.min(model.min_distance(&mut ws, &q).unwrap().unwrap().signed.distance);
        }
        if ok {
            assert!(lowest >= clearance / 2.0, "certified, yet a configuration is {lowest} m close");
            certified += 1;
        } else {
            // Refusals are real near-contacts, not artefacts of a loose bound.
            assert!(lowest < clearance, "refused a motion with {lowest} m of clearance");
            refused += 1;
        }
    }
    println!("{certified} motions certified, {refused} refused");
    assert!(certified > 10 && refused > 10);
}
