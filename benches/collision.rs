//! Collision queries of the Panda (81 spheres) in `panda_grasp_box.toml`
//! (table and box) plus 10 seeded random obstacles (boxes, spheres,
//! cylinders), cycling through 1000 seeded random configurations:
//! `collision_free` (boolean, early exit; on the sphere fast path and on
//! the general path), `motion_free` (0.3 rad motions checked every 0.005
//! rad, both paths), `distance_all_pairs` (every
//! pair's signed distance with witness points), `min_distance` (closest
//! pair, branch and bound). The same geometry, pairs and configurations are
//! written to target/peers/collision_scene.json for coal
//! (benches/peers/compare_collision.sh).
//!
//! `model_build`: compiling the collision model (pairs, movers, sphere
//! fast path) of a humanoid-like tree (62 links, 4 spheres each) and of
//! 250- and 1,000-link chains; listing every pair's movers made this
//! O(n⁴) (10 s for 1,000 links).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::problem::Problem;
use tandem::robot::{MeshSearchPath, RobotDescription, RobotModel};
use tandem::scene::{Obstacle, Shape};

#[path = "support/large_robots.rs"]
mod large;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The benchmark problem: the grasp scene and 10 random obstacles.
fn model() -> CollisionModel {
    let mut problem = Problem::from_file(repo().join("problems/panda_grasp_box.toml")).expect("shipped problem");
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    for k in 0..10 {
        let s = rng.random_range(0.05..0.15);
        let shape = match k % 3 {
            0 => Shape::cuboid([s, rng.random_range(0.05..0.15), rng.random_range(0.05..0.15)]),
            1 => Shape::sphere(s / 2.0),
            _ => Shape::cylinder(s / 2.0, rng.random_range(0.1..0.3)),
        };
        let p = Vector3::new(rng.random_range(-0.6..0.8), rng.random_range(-0.7..0.7), rng.random_range(0.1..1.0));
        let r = Rotation3::from_euler_angles(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-3.0..3.0),
        );
        let obstacle =
            Obstacle::new(format!("random_{k}"), shape, IsometryMatrix3::from_parts(Translation3::from(p), r));
        problem.scene.add_obstacle(obstacle).expect("valid obstacle");
    }
    problem.collision_model().expect("collision model")
}

fn configurations(model: &CollisionModel) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    (0..1000).map(|_| model.robot().limits().iter().map(|l| rng.random_range(l.lower..=l.upper)).collect()).collect()
}

fn export(model: &CollisionModel, configs: &[Vec<f64>]) {
    let urdf = repo().join("problems/robots/panda/panda.urdf");
    let request = model.to_exchange_json(&urdf, &[], configs).expect("primitive scene");
    let dir = repo().join("target/peers");
    std::fs::create_dir_all(&dir).expect("create target/peers");
    std::fs::write(dir.join("collision_scene.json"), request.to_string()).expect("write the scene");
}

fn collision(c: &mut Criterion) {
    let model = model();
    let configs = configurations(&model);
    export(&model, &configs);
    let mut ws = CollisionWorkspace::new(&model);
    let colliding = configs.iter().filter(|q| !model.collision_free(&mut ws, q).expect("valid q")).count();
    eprintln!("{} pairs, {colliding} of {} configurations in collision", model.pair_count(), configs.len());
    let mut group = c.benchmark_group("panda_grasp_box_10");
    let mut i = 0;
    group.bench_function("collision_free", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            black_box(model.collision_free(&mut ws, black_box(&configs[i])).expect("valid q"))
        })
    });
    let mut general = model.clone();
    general.set_fast_path(false);
    let mut general_ws = CollisionWorkspace::new(&general);
    group.bench_function("collision_free_general", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            black_box(general.collision_free(&mut general_ws, black_box(&configs[i])).expect("valid q"))
        })
    });
    // Motions of 0.3 rad (Euclidean) from each configuration towards the next.
    let ends: Vec<Vec<f64>> = (0..configs.len())
        .map(|k| {
            let (a, b) = (&configs[k], &configs[(k + 1) % configs.len()]);
            let d = a.iter().zip(b).map(|(x, y)| (y - x) * (y - x)).sum::<f64>().sqrt();
            a.iter().zip(b).map(|(x, y)| x + (y - x) * 0.3 / d).collect()
        })
        .collect();
    let free = (0..configs.len())
        .filter(|&k| model.motion_free(&mut ws, &configs[k], &ends[k], 0.005).expect("valid"))
        .count();
    eprintln!("{free} of {} motions free", configs.len());
    for (name, m, w) in [("motion_free", &model, &mut ws), ("motion_free_general", &general, &mut general_ws)] {
        group.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) % configs.len();
                black_box(m.motion_free(w, black_box(&configs[i]), &ends[i], 0.005).expect("valid q"))
            })
        });
    }
    group.bench_function("distance_all_pairs", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            black_box(model.distances(&mut ws, black_box(&configs[i]), f64::INFINITY).expect("valid q").len())
        })
    });
    group.bench_function("min_distance", |b| {
        b.iter(|| {
            i = (i + 1) % configs.len();
            black_box(model.min_distance(&mut ws, black_box(&configs[i])).expect("valid q"))
        })
    });
    group.finish();
}

fn model_build(c: &mut Criterion) {
    let robot = |urdf: String| {
        let desc = RobotDescription::from_urdf_str(&urdf, &MeshSearchPath::default()).expect("generated URDF");
        Arc::new(RobotModel::builder(Arc::new(desc)).build().expect("model"))
    };
    let mut group = c.benchmark_group("model_build");
    group.sample_size(10);
    for (name, robot) in [
        ("humanoid_62_links", robot(large::humanoid_urdf())),
        ("chain_250_links", robot(large::chain_urdf(250, false))),
        ("chain_1000_links", robot(large::chain_urdf(1000, false))),
    ] {
        let pairs = CollisionModel::builder(robot.clone()).build().expect("model").pair_count();
        eprintln!("{name}: {pairs} pairs");
        group.bench_function(name, |b| {
            b.iter(|| black_box(CollisionModel::builder(robot.clone()).build().expect("model")))
        });
    }
    group.finish();
}

criterion_group!(benches, collision, model_build);
criterion_main!(benches);
