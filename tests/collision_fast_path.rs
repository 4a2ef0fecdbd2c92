//! The sphere fast path of boolean checks gives the general path's answers:
//! configuration checks and motion checks on thousands of random and
//! near-contact configurations, in a cluttered scene with every obstacle
//! shape, with padding and an attached sphere, and in MotionBenchMaker
//! scenes with the spherized Panda — for every compiled variant of the
//! fast path this CPU runs (baseline, AVX2, AVX-512; `SimdLevel`).

mod common;

use common::random_configurations;
use nalgebra::IsometryMatrix3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace, SimdLevel};
use tandem::problem::{Goal, Problem};
use tandem::robot::RobotModel;
use tandem::scene::{Obstacle, Scene, SceneObject, Shape};

/// Both paths of `model` on the same queries; returns (free, colliding) counts.
struct Pair {
    fast: CollisionModel,
    general: CollisionModel,
    fast_ws: CollisionWorkspace,
    general_ws: CollisionWorkspace,
}

/// The fast path's variants this CPU runs; every test runs on each.
fn levels() -> Vec<SimdLevel> {
    let levels = SimdLevel::available();
    assert_eq!(levels[0], SimdLevel::Baseline);
    levels
}

impl Pair {
    /// The fast path at `level` against the general path.
    fn at(mut model: CollisionModel, level: SimdLevel) -> Pair {
        assert_eq!(model.set_simd(Some(level)), Some(level), "{level:?} is available");
        Pair::new(model)
    }

    fn new(model: CollisionModel) -> Pair {
        assert!(model.has_fast_path(), "the fast path should apply");
        let mut general = model.clone();
        general.set_fast_path(false);
        assert!(!general.has_fast_path());
        let (fast_ws, general_ws) = (CollisionWorkspace::new(&model), CollisionWorkspace::new(&general));
        Pair { fast: model, general, fast_ws, general_ws }
    }

    fn config(&mut self, q: &[f64]) -> bool {
        let fast = self.fast.collision_free(&mut self.fast_ws, q).unwrap();
        let general = self.general.collision_free(&mut self.general_ws, q).unwrap();
        assert_eq!(fast, general, "collision_free differs at {q:?}");
        fast
    }

    fn motion(&mut self, q0: &[f64], q1: &[f64], resolution: f64) -> bool {
        let fast = self.fast.motion_free(&mut self.fast_ws, q0, q1, resolution).unwrap();
        let general = self.general.motion_free(&mut self.general_ws, q0, q1, resolution).unwrap();
        assert_eq!(fast, general, "motion_free differs on {q0:?} -> {q1:?}");
        fast
    }

    /// Random configurations, configurations around `centre` (where free
    /// and colliding ones mix), and motions between them.
    fn compare(&mut self, robot: &RobotModel, centre: &[f64], count: usize, seed: u64) -> (usize, usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let random = random_configurations(robot, count, seed);
        let mut near = Vec::new();
        for q in &random {
            let s = rng.random_range(0.05..0.6);
            near.push(q.iter().zip(centre).map(|(v, c)| c + s * (v - c)).collect::<Vec<f64>>());
        }
        let (mut free, mut colliding) = (0, 0);
        for q in random.iter().chain(&near) {
            if self.config(q) { free += 1 } else { colliding += 1 }
        }
        for w in near.chunks(2).take(count / 4) {
            self.motion(&w[0], &w[1], 0.02);
        }
        (free, colliding)
    }
}

fn cluttered() -> (Arc<RobotModel>, Scene) {
    let robot = Arc::new(RobotModel::panda());
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04)).unwrap();
    let pose = |p: [f64; 3], rpy: [f64; 3]| {
        IsometryMatrix3::from_parts(p.into(), nalgebra::Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]))
    };
    for o in [
        Obstacle::new("crate", Shape::cuboid([0.2, 0.3, 0.3]), pose([0.5, -0.3, 0.3], [0.2, 0.0, 0.5])),
        Obstacle::new("ball", Shape::sphere(0.1), pose([0.4, 0.35, 0.5], [0.0; 3])),
        Obstacle::new("post", Shape::cylinder(0.05, 0.8), pose([-0.3, 0.3, 0.4], [0.5, 0.2, 0.0])),
        Obstacle::new("bar", Shape::capsule(0.04, 0.6), pose([0.2, 0.0, 0.9], [1.2, 0.3, -0.4])),
    ] {
        scene.add_obstacle(o).unwrap();
    }
    scene.allow_contact("panda_link0", "table");
    (robot, scene)
}

const READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

#[test]
fn fast_path_matches_the_general_path_in_a_cluttered_scene() {
    let (robot, mut scene) = cluttered();
    for level in levels() {
        for padding in [0.0, 0.001, 0.003] {
            let model = CollisionModel::builder(robot.clone()).scene(&scene).padding(padding).build().unwrap();
            let (free, colliding) = Pair::at(model, level).compare(&robot, &READY, 2000, 7);
            println!("{level:?}, padding {padding}: {free} free, {colliding} colliding");
            assert!(free > 500 && colliding > 500);
        }
    }
    // A ball held in the hand is one more moving sphere.
    scene
        .add_object(SceneObject::new("orange", Shape::sphere(0.04), IsometryMatrix3::translation(0.5, 0.1, 0.04)))
        .unwrap();
    scene.attach("orange", "panda_hand_tcp", IsometryMatrix3::translation(0.0, 0.0, 0.05)).unwrap();
    for level in levels() {
        let model = CollisionModel::builder(robot.clone()).scene(&scene).padding(0.001).build().unwrap();
        let (free, colliding) = Pair::at(model, level).compare(&robot, &READY, 1000, 8);
        assert!(free > 200 && colliding > 200);
    }
    // A held box is not a sphere: no fast path, the general one answers.
    scene
        .add_object(SceneObject::new("brick", Shape::cuboid([0.05; 3]), IsometryMatrix3::translation(0.5, 0.3, 0.03)))
        .unwrap();
    scene.attach("brick", "panda_link7", IsometryMatrix3::identity()).unwrap();
    assert!(!CollisionModel::builder(robot).scene(&scene).build().unwrap().has_fast_path());
}

#[test]
fn fast_path_matches_at_contact() {
    // Configurations bisected onto the boundary between free and colliding:
    // the pairs there sit within nanometres of their thresholds.
    let (robot, scene) = cluttered();
    for level in levels() {
        let model = CollisionModel::builder(robot.clone()).scene(&scene).padding(0.001).build().unwrap();
        let mut pair = Pair::at(model, level);
        let configs = random_configurations(&robot, 600, 5);
        let mut boundary = 0;
        for q in &configs {
            let (mut free, mut hit) = (READY.to_vec(), q.clone());
            if !pair.config(&free) || pair.config(&hit) {
                continue;
            }
            for _ in 0..60 {
                let mid: Vec<f64> = free.iter().zip(&hit).map(|(a, b)| 0.5 * (a + b)).collect();
                if pair.config(&mid) { free = mid } else { hit = mid }
            }
            boundary += 1;
        }
        assert!(boundary > 100, "{level:?}: {boundary}");
    }
}

#[test]
fn fast_path_matches_on_motionbenchmaker_scenes() {
    let mbm = common::mbm();
    let dir = tempfile::tempdir().unwrap();
    let problems = common::unpack_mbm(dir.path());
    let (urdf, srdf) = (mbm.join("panda_spherized.urdf"), mbm.join("panda.srdf"));
    let (mut free, mut colliding) = (0, 0);
    for family in
        ["bookshelf_small", "bookshelf_tall", "bookshelf_thin", "box", "cage", "table_pick", "table_under_pick"]
    {
        for k in [1, 37, 74] {
            let at = |f: &str| problems.join(format!("{family}_panda/{f}{k:04}.yaml"));
            let problem = Problem::from_moveit(&urdf, &srdf, &at("scene"), &at("request")).unwrap();
            let Goal::Joints(goal) = &problem.goal else { panic!("joint goal expected") };
            for (padding, level) in
                [0.0, problem.planner.clearance].into_iter().flat_map(|p| levels().into_iter().map(move |l| (p, l)))
            {
                let model = problem.collision_model_padded(padding).unwrap();
                // Single-precision checks first, within a band of about 0.1 mm.
                let band = model.single_precision_band().expect("single precision on MotionBenchMaker scenes");
                assert!(band > 1e-6 && band < 1e-3, "{band:e}");
                let mut pair = Pair::at(model, level);
                let (f, c) = pair.compare(&problem.robot, goal, 300, k);
                pair.motion(&problem.start, goal, 0.005);
                free += f;
                colliding += c;
            }
        }
    }
    println!("{free} free, {colliding} colliding");
    assert!(free > 2000 && colliding > 2000);
}

#[test]
fn fast_path_matches_on_point_clouds() {
    // MotionBenchMaker's scenes as a camera sees them: 2 cm apart on every
    // surface, balls of 1.5 cm (the spacing over √2 and a little).
    let mbm = common::mbm();
    let dir = tempfile::tempdir().unwrap();
    let problems = common::unpack_mbm(dir.path());
    let (urdf, srdf) = (mbm.join("panda_spherized.urdf"), mbm.join("panda.srdf"));
    let (mut free, mut colliding) = (0, 0);
    for family in ["bookshelf_small", "box", "table_pick"] {
        for k in [1, 37] {
            let at = |f: &str| problems.join(format!("{family}_panda/{f}{k:04}.yaml"));
            let mut problem = Problem::from_moveit(&urdf, &srdf, &at("scene"), &at("request")).unwrap();
            problem.scene = common::sampled_scene(&problem.scene, 0.02, 0.015);
            let Goal::Joints(goal) = &problem.goal else { panic!("joint goal expected") };
            for level in levels() {
                let mut pair = Pair::at(problem.collision_model().unwrap(), level);
                let (f, c) = pair.compare(&problem.robot, goal, 200, k);
                pair.motion(&problem.start, goal, 0.005);
                free += f;
                colliding += c;
            }
        }
    }
    println!("{free} free, {colliding} colliding");
    assert!(free > 500 && colliding > 500);
}

#[test]
fn certified_motions_against_a_point_cloud_keep_half_the_clearance() {
    let (robot, scene) = cluttered();
    let scene = common::sampled_scene(&scene, 0.02, 0.015);
    let mut verdicts_by_level = Vec::new();
    for level in levels() {
        let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
        verdicts_by_level.push(certified_motions(&robot, Pair::at(model, level)));
    }
    assert!(verdicts_by_level.windows(2).all(|w| w[0] == w[1]));
}

#[test]
fn certified_motions_on_the_fast_path_keep_half_the_clearance() {
    let (robot, scene) = cluttered();
    let mut verdicts_by_level = Vec::new();
    for level in levels() {
        let model = CollisionModel::builder(robot.clone()).scene(&scene).build().unwrap();
        verdicts_by_level.push(certified_motions(&robot, Pair::at(model, level)));
    }
    // Every variant certifies exactly the same motions.
    assert!(verdicts_by_level.windows(2).all(|w| w[0] == w[1]));
}

/// Certifies 400 motions on the fast path, checks each certified one
/// densely on the general path; returns the verdicts.
fn certified_motions(robot: &RobotModel, pair: Pair) -> Vec<bool> {
    let Pair { fast, general, mut fast_ws, mut general_ws } = pair;
    let mut verdicts = Vec::new();
    let clearance = 0.002;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (mut certified, mut agree, mut total) = (0, 0, 0);
    for q in random_configurations(robot, 400, 13) {
        // Short and long motions around the ready pose, free ones and blocked ones.
        let s = rng.random_range(0.05..0.5);
        let q0: Vec<f64> = q.iter().zip(READY).map(|(v, r)| r + s * (v - r)).collect();
        let q1: Vec<f64> = q0.iter().map(|v| v + rng.random_range(-0.4..0.4)).collect();
        let ok = fast.motion_free_certified(&mut fast_ws, &q0, &q1, clearance).unwrap();
        verdicts.push(ok);
        // What the workspace remembers of earlier motions (the pair that
        // failed last, a plain probe after a failure) changes no verdict.
        let fresh = fast.motion_free_certified(&mut CollisionWorkspace::new(&fast), &q0, &q1, clearance).unwrap();
        assert_eq!(ok, fresh, "{q0:?} -> {q1:?}");
        let reference = general.motion_free_certified(&mut general_ws, &q0, &q1, clearance).unwrap();
        total += 1;
        agree += usize::from(ok == reference);
        if !ok {
            continue;
        }
        certified += 1;
        common::assert_motion_keeps(&general, &mut general_ws, (&q0, &q1), clearance / 2.0, 300);
    }
    println!("{certified} of {total} motions certified; the general path agrees on {agree}");
    assert!(certified > 50 && certified < total - 50);
    assert!(agree * 100 >= total * 95);
    verdicts
}

#[test]
fn the_variant_can_be_chosen() {
    let (robot, scene) = cluttered();
    let mut model = CollisionModel::builder(robot).scene(&scene).build().unwrap();
    let best = *levels().last().unwrap();
    assert_eq!(model.set_simd(None), Some(best));
    assert_eq!(model.set_simd(Some(SimdLevel::Baseline)), Some(SimdLevel::Baseline));
    assert_eq!(model.simd(), Some(SimdLevel::Baseline));
    // Asking for more than the CPU has gives the best it has.
    assert_eq!(model.set_simd(Some(SimdLevel::Avx512)), Some(best));
    model.set_fast_path(false);
    assert_eq!(model.set_simd(Some(SimdLevel::Avx2)), None);
}
