//! Signed distances against coal (hpp-fcl) through Pinocchio's collision
//! module: the embedded Panda (81 spheres) against a table, boxes, a
//! sphere, a cylinder and a capsule, plus its self-collision pairs, on
//! 1000 random configurations; distances agree to 1e-13 m (about 100
//! times the largest difference seen, 8.9e-16 m), penetrating pairs
//! included, witness points and normals of separated pairs to 1e-12
//! (seen: 9.6e-15). Where coal is known wrong (a sphere centre inside a
//! cylinder near a cap) ours must equal the exact depth, in both directions.

mod common;

use common::{random_configurations, read_f64_file, repo, run_python, worst};

/// Signed distances against coal (m): ~100 × the largest difference seen.
const DISTANCE_TOLERANCE: f64 = 1e-13;
/// Witness points (m) and unit normals of separated pairs.
const WITNESS_TOLERANCE: f64 = 1e-12;
/// GJK/EPA pairs (box, cylinder): parry3d's tolerance; seen 8.5e-9 m.
const GJK_TOLERANCE: f64 = 1e-6;
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3, Vector3};
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::robot::RobotModel;
use tandem::scene::{Obstacle, Scene, Shape};

fn pose(p: [f64; 3], rpy: [f64; 3]) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(
        Translation3::from(Vector3::from(p)),
        Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// Obstacles spread through the arm's reach so that random configurations
/// both clear and penetrate every shape kind.
pub fn test_scene() -> Scene {
    let mut s = Scene::new();
    let obstacles = [
        Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04),
        Obstacle::new("box", Shape::cuboid([0.06, 0.06, 0.12]), pose([0.5, 0.1, 0.06], [0.0, 0.0, 0.4])),
        Obstacle::new("slab", Shape::cuboid([0.3, 0.05, 0.4]), pose([0.1, -0.45, 0.5], [0.3, -0.2, 0.7])),
        Obstacle::new("ball", Shape::sphere(0.12), pose([0.45, 0.3, 0.55], [0.0; 3])),
        Obstacle::new("post", Shape::cylinder(0.07, 0.6), pose([-0.3, 0.35, 0.4], [0.5, 0.2, 0.0])),
        Obstacle::new("bar", Shape::capsule(0.05, 0.5), pose([0.3, -0.1, 0.85], [1.2, 0.3, -0.4])),
    ];
    for o in obstacles {
        s.add_obstacle(o).unwrap();
    }
    s.allow_contact("panda_link0", "table");
    s
}

/// coal's sphere-cylinder distance is wrong when the sphere centre is
/// inside the cylinder nearer a cap (it pushes out radially; see
/// python_ref/coal_reference.py): for those pairs, the exact signed
/// distance — the nearer of the side and the cap, minus the radius.
fn coal_cylinder_cap_case(model: &CollisionModel, ws: &CollisionWorkspace, pair: usize, scene: &Scene) -> Option<f64> {
    let (_, b) = model.pair_names(pair);
    let o = scene.obstacle(b)?;
    let Shape::Cylinder { radius, half_length } = o.shape else { return None };
    let (a, _) = model.pair_objects(pair);
    let Shape::Sphere { radius: r } = *model.object_shape(a) else { return None };
    let c = model.object_world_pose(ws, a).translation.vector;
    let local = o.pose.inverse() * Point3::from(c);
    let (dr, dz) = (local.x.hypot(local.y) - radius, local.z.abs() - half_length);
    (dr < 0.0 && dz < 0.0 && dz > dr).then_some(dz - r)
}

#[test]
fn signed_distances_match_coal_on_1000_configurations() {
    let robot = Arc::new(RobotModel::panda());
    let scene = test_scene();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let configs = random_configurations(&robot, 1000, 31);
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("coal.bin");
    let urdf = repo().join("problems/robots/panda/panda.urdf");
    let mut request = model.to_exchange_json(&urdf, &[], &configs).unwrap();
    request["output"] = serde_json::json!(output);
    let summary = run_python("coal_reference.py", &["distances"], &request.to_string());
    println!("coal: {}", summary.trim());
    let reference = read_f64_file(&output);
    let pairs = model.pair_count();
    assert_eq!(reference.len(), configs.len() * pairs * 10);

    let mut ws = CollisionWorkspace::new(&model);
    let (mut worst_d, mut worst_points, mut penetrating, mut cap_cases) = (0.0f64, 0.0f64, 0, 0);
    for (c, q) in configs.iter().enumerate() {
        let ours = model.distances(&mut ws, q, f64::INFINITY).unwrap().to_vec();
        assert_eq!(ours.len(), pairs);
        for d in &ours {
            let r = &reference[(c * pairs + d.pair) * 10..][..10];
            if let Some(exact) = coal_cylinder_cap_case(&model, &ws, d.pair, &scene) {
                // coal over-estimates the depth there: ours must be the exact,
                // shallower one — in both directions, so a missed collision fails.
                let err = (d.signed.distance - exact).abs();
                worst_d = worst(worst_d, err);
                assert!(
                    err < DISTANCE_TOLERANCE && d.signed.distance < 0.0 && d.signed.distance >= r[0],
                    "{:?}: {} vs exact {exact}, coal {}",
                    model.pair_names(d.pair),
                    d.signed.distance,
                    r[0]
                );
                cap_cases += 1;
                continue;
            }
            let err = (d.signed.distance - r[0]).abs();
            worst_d = worst(worst_d, err);
            assert!(
                err < DISTANCE_TOLERANCE,
                "config {c} pair {:?}: tandem {} coal {}",
                model.pair_names(d.pair),
                d.signed.distance,
                r[0]
            );
            if d.signed.distance < 0.0 {
                penetrating += 1;
            } else if d.signed.distance > 1e-6 {
                let s = &d.signed;
                let e = [
                    (s.point_a - Point3::new(r[1], r[2], r[3])).norm(),
                    (s.point_b - Point3::new(r[4], r[5], r[6])).norm(),
                    (s.normal - Vector3::new(r[7], r[8], r[9])).norm(),
                ]
                .into_iter()
                .fold(0.0, worst);
                worst_points = worst(worst_points, e);
                assert!(
                    e < WITNESS_TOLERANCE,
                    "config {c} pair {:?}: witness points/normal differ by {e:e}",
                    model.pair_names(d.pair)
                );
            }
        }
    }
    println!(
        "{} configurations x {pairs} pairs: max |Δd| = {worst_d:.2e} m, max |Δ witness|,|Δ normal| (separated) = {worst_points:.2e}; {penetrating} penetrating pairs compared; {cap_cases} sphere-in-cylinder-cap cases where coal is deeper",
        configs.len()
    );
    assert!(penetrating > 1000, "too few penetrating pairs ({penetrating}) to test penetration");
    assert!(cap_cases > 5, "too few sphere-in-cylinder-cap cases ({cap_cases})");
}

/// A three-joint arm whose links are a box, a cylinder and a box with a
/// sphere: box–box, box–cylinder and cylinder–cylinder pairs go through
/// GJK/EPA (parry3d here, coal's own there).
const PRIMITIVE_ARM: &str = r#"<robot name="primitive_arm">
  <link name="base"><collision><origin xyz="0 0 0.05"/><geometry><box size="0.3 0.3 0.1"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="l1"><collision><origin xyz="0 0 0.2"/><geometry><cylinder radius="0.05" length="0.4"/></geometry></collision></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.4"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
  <link name="l2"><collision><origin xyz="0.2 0 0" rpy="0 1.5708 0"/><geometry><cylinder radius="0.04" length="0.4"/></geometry></collision></link>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.4 0 0"/><axis xyz="0 1 0"/><limit lower="-2.8" upper="2.8" effort="1" velocity="1"/></joint>
  <link name="l3">
    <collision><origin xyz="0.15 0 0" rpy="0.3 0 0"/><geometry><box size="0.3 0.06 0.04"/></geometry></collision>
    <collision><origin xyz="0.32 0 0"/><geometry><sphere radius="0.04"/></geometry></collision>
  </link>
</robot>"#;

#[test]
fn gjk_epa_pairs_match_coal() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("primitive_arm.urdf");
    std::fs::write(&urdf, PRIMITIVE_ARM).unwrap();
    let description = tandem::robot::RobotDescription::from_urdf_file(&urdf, &Default::default()).unwrap();
    let robot = Arc::new(RobotModel::builder(Arc::new(description)).build().unwrap());
    let mut scene = Scene::new();
    scene
        .add_obstacle(Obstacle::new("crate", Shape::cuboid([0.2, 0.3, 0.25]), pose([0.45, 0.1, 0.35], [0.2, 0.1, 0.5])))
        .unwrap();
    scene
        .add_obstacle(Obstacle::new("pipe", Shape::cylinder(0.06, 0.5), pose([-0.2, -0.4, 0.5], [1.2, 0.0, 0.3])))
        .unwrap();
    scene.add_obstacle(Obstacle::new("ball", Shape::sphere(0.1), pose([0.0, 0.45, 0.7], [0.0; 3]))).unwrap();
    let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
    let configs = random_configurations(&robot, 1000, 5);
    let output = dir.path().join("coal.bin");
    let mut request = model.to_exchange_json(&urdf, &[], &configs).unwrap();
    request["output"] = serde_json::json!(output);
    run_python("coal_reference.py", &["distances"], &request.to_string());
    let reference = read_f64_file(&output);
    let pairs = model.pair_count();
    let mut ws = CollisionWorkspace::new(&model);
    let (mut largest, mut penetrating, mut coal_deeper) = (0.0f64, 0, 0);
    for (c, q) in configs.iter().enumerate() {
        for d in &model.distances(&mut ws, q, f64::INFINITY).unwrap().to_vec() {
            let r = reference[(c * pairs + d.pair) * 10];
            let err = (d.signed.distance - r).abs();
            penetrating += usize::from(r < 0.0);
            if err > GJK_TOLERANCE && r < 0.0 && d.signed.distance > r {
                // EPA may stop at a non-minimal face: then the shallower
                // answer wins if its translation really separates the shapes.
                assert!(
                    separates(&model, &ws, d),
                    "config {c} pair {:?}: tandem {} coal {r}",
                    model.pair_names(d.pair),
                    d.signed.distance
                );
                coal_deeper += 1;
                continue;
            }
            largest = worst(largest, err);
            assert!(
                err < GJK_TOLERANCE,
                "config {c} pair {:?}: tandem {} coal {r}",
                model.pair_names(d.pair),
                d.signed.distance
            );
        }
    }
    println!(
        "{} configurations x {pairs} pairs (GJK/EPA): max |Δd| = {largest:.2e} m, {penetrating} penetrating; {coal_deeper} where coal's EPA reports a deeper, non-minimal penetration",
        configs.len()
    );
    assert!(penetrating > 100);
}

/// Whether translating object b by the penetration depth along the normal
/// leaves the pair touching (distance ≈ 0): the depth is a real separation.
fn separates(model: &CollisionModel, ws: &CollisionWorkspace, d: &tandem::collision::PairDistance) -> bool {
    let (i, j) = model.pair_objects(d.pair);
    let (pa, pb) = (model.object_world_pose(ws, i), model.object_world_pose(ws, j));
    let shift = d.signed.normal * -d.signed.distance;
    let moved = IsometryMatrix3::from_parts(Translation3::from(pb.translation.vector + shift), pb.rotation);
    let after = tandem::collision::signed_distance(model.object_shape(i), pa, model.object_shape(j), &moved).distance;
    after.abs() < 1e-6
}
