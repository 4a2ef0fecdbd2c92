//! The second-order certification bound (`narrow` in `check.rs`) against
//! the geometry it bounds: along straight motions of a Panda and of a
//! TIAGo sliding its torso, every sphere's velocity matches finite
//! differences of its centre, and every pair's distance stays above
//! `d(m) − |τ| rate − τ² accel / 2` at configurations `m + τ`, measured
//! by placing the spheres there. The single-precision plain check
//! (`single.rs`) stays within its rounding band of the f64 placements and
//! distances, and gives the f64 check's verdicts, close calls included.

use super::SphereModel;
use super::check::Verdict;
use super::lanes::{LANES, Lane, Real, distance_rate, lane_distance_squared};
use super::workspace::SphereWorkspace;
use crate::collision::CollisionModel;
use crate::robot::{RobotDescription, RobotModel, Srdf};
use crate::scene::{Obstacle, Scene, Shape};
use nalgebra::{IsometryMatrix3, Rotation3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

/// One obstacle of every static kind, turned off the axes.
fn scene() -> Scene {
    let pose = |p: [f64; 3], rpy: [f64; 3]| {
        IsometryMatrix3::from_parts(p.into(), Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]))
    };
    let mut scene = Scene::new();
    for o in [
        Obstacle::new("bin", Shape::cuboid([0.3, 0.25, 0.2]), pose([0.45, 0.25, 0.35], [0.3, -0.2, 0.9])),
        Obstacle::new("globe", Shape::sphere(0.12), pose([0.35, -0.4, 0.6], [0.0; 3])),
        Obstacle::new("pillar", Shape::cylinder(0.06, 0.9), pose([-0.35, -0.25, 0.45], [0.4, -0.3, 0.2])),
        Obstacle::new("rail", Shape::capsule(0.03, 0.7), pose([0.1, 0.2, 0.95], [1.0, -0.5, 0.3])),
    ] {
        scene.add_obstacle(o).unwrap();
    }
    scene
}

fn robots() -> Vec<Arc<RobotModel>> {
    let tiago = spherized("robots/tiago/tiago_spheres.urdf", Some(("robots/tiago/tiago.srdf", "arm_torso")));
    vec![Arc::new(RobotModel::panda()), tiago]
}

/// Every sphere centre at `q0 + t (q1 − q0)`, per lane.
fn place<T: Real>(model: &SphereModel<T>, ws: &mut SphereWorkspace<T>, (q0, q1): (&[f64], &[f64]), t: &Lane) {
    model.set_along(ws, q0, q1, t);
    model.forward_kinematics(ws);
    ws.spheres_placed.fill(false);
    ws.tangent_done = false;
    for c in 0..model.clusters.len() {
        model.place_spheres(ws, c);
    }
}

/// Each sphere's cluster and body.
fn owners(model: &SphereModel) -> Vec<(usize, usize)> {
    let mut owners = vec![(0, 0); model.spheres.len()];
    for (c, cluster) in model.clusters.iter().enumerate() {
        let body = model.groups[model.cluster_group[c] as usize].body;
        owners[cluster.spheres.clone()].fill((c, body));
    }
    owners
}

/// Per lane, pair distances (m) of the placed spheres: every sphere
/// against every static shape's core, then the self pairs' spheres.
/// Computed in `T`, as the checks do.
fn distances<T: Real + Into<f64>>(model: &SphereModel<T>, ws: &SphereWorkspace<T>) -> Vec<Lane> {
    let root = |d2: T| -> f64 { super::lanes::max(d2, T::ZERO).sqrt().into() };
    let mut out = Vec::new();
    for s in 0..model.spheres.len() {
        for shape in &model.statics {
            out.push(shape.core_distance_squared(&ws.centers[s]).0.map(root));
        }
    }
    for_self_spheres(model, |i, j| out.push(lane_distance_squared(&ws.centers[i], &ws.centers[j]).map(root)));
    out
}

fn for_self_spheres<T>(model: &SphereModel<T>, mut visit: impl FnMut(usize, usize)) {
    for pair in &model.self_pairs {
        let [a, b] = pair.map(|g| &model.groups[g as usize]);
        for ca in a.clusters.clone() {
            for cb in b.clusters.clone() {
                for i in model.clusters[ca].spheres.clone() {
                    for j in model.clusters[cb].spheres.clone() {
                        visit(i, j);
                    }
                }
            }
        }
    }
}

/// Per pair (in the order of [`distances`]) and lane, the rate of
/// change of its distance at the placed configurations, and its
/// acceleration bound.
fn rates(model: &SphereModel, ws: &mut SphereWorkspace) -> Vec<(Lane, f64)> {
    let owners = owners(model);
    let mut out = Vec::new();
    for (s, &(c, body)) in owners.iter().enumerate() {
        let velocity = model.sphere_velocity(ws, body, s);
        for shape in &model.statics {
            let distance = shape.core_distance_squared(&ws.centers[s]).0.map(|d2| d2.max(0.0).sqrt());
            let rate = distance_rate(&shape.core_approach(&ws.centers[s], &velocity), &distance);
            out.push((rate, model.cluster_accel(ws, c)));
        }
    }
    let mut pairs = Vec::new();
    for_self_spheres(model, |i, j| pairs.push((i, j)));
    for (i, j) in pairs {
        let ((ci, bi), (cj, bj)) = (owners[i], owners[j]);
        let distance = std::array::from_fn(|l| {
            (0..3).map(|k| (ws.centers[i][k][l] - ws.centers[j][k][l]).powi(2)).sum::<f64>().sqrt()
        });
        let rate = model.separation_rate(ws, (bi, i), (bj, j), &distance);
        out.push((rate, model.cluster_accel(ws, ci) + model.cluster_accel(ws, cj)));
    }
    out
}

#[test]
fn sphere_velocities_match_finite_differences() {
    for robot in robots() {
        let model = CollisionModel::builder(robot.clone()).scene(&scene()).build().unwrap();
        let fast = model.spheres.as_ref().expect("sphere fast path");
        let mut ws = SphereWorkspace::new(fast, robot.nq());
        let owners = owners(fast);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..20 {
            let (q0, q1) = (random(&robot, &mut rng), random(&robot, &mut rng));
            fast.start_sweeps(&mut ws, &q0, &q1);
            let m: Lane = std::array::from_fn(|_| rng.random_range(0.1..0.9));
            let h = 1e-6;
            let mut ahead = Vec::new();
            for sign in [1.0, -1.0] {
                place(fast, &mut ws, (&q0, &q1), &m.map(|t| t + sign * h));
                ahead.push(ws.centers.clone());
            }
            place(fast, &mut ws, (&q0, &q1), &m);
            for (s, &(_, body)) in owners.iter().enumerate() {
                let v = fast.sphere_velocity(&mut ws, body, s);
                for k in 0..3 {
                    for l in 0..LANES {
                        let fd = (ahead[0][s][k][l] - ahead[1][s][k][l]) / (2.0 * h);
                        assert!((v[k][l] - fd).abs() < 1e-6 * (1.0 + fd.abs()), "sphere {s}: {} vs {fd}", v[k][l]);
                    }
                }
            }
        }
    }
}

#[test]
fn pair_distances_stay_above_the_second_order_bound() {
    let (mut checked, mut tightest) = (0usize, f64::INFINITY);
    for robot in robots() {
        let model = CollisionModel::builder(robot.clone()).scene(&scene()).build().unwrap();
        let fast = model.spheres.as_ref().expect("sphere fast path");
        let mut ws = SphereWorkspace::new(fast, robot.nq());
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for _ in 0..20 {
            let (q0, q1) = (random(&robot, &mut rng), random(&robot, &mut rng));
            fast.start_sweeps(&mut ws, &q0, &q1);
            let m: Lane = std::array::from_fn(|_| rng.random_range(0.2..0.8));
            place(fast, &mut ws, (&q0, &q1), &m);
            let (at_m, bounds) = (distances(fast, &ws), rates(fast, &mut ws));
            for tau in [-0.2, -0.05, -0.01, -1e-3, 1e-3, 0.01, 0.05, 0.2] {
                place(fast, &mut ws, (&q0, &q1), &m.map(|t| t + tau));
                for ((d, d_m), (rate, accel)) in distances(fast, &ws).iter().zip(&at_m).zip(&bounds) {
                    for l in (0..LANES).filter(|&l| d_m[l] > 0.0) {
                        let bound = d_m[l] - tau.abs() * rate[l] - tau * tau * accel / 2.0;
                        assert!(d[l] >= bound - 1e-12, "{} m below the bound {bound} m at τ = {tau}", bound - d[l]);
                        if *accel > 0.0 {
                            tightest = tightest.min((d[l] - bound) / (tau * tau * accel / 2.0));
                        }
                        checked += 1;
                    }
                }
            }
        }
    }
    // How much of the second-order allowance the closest distance left.
    println!("{checked} distances checked; at the closest, {tightest:.3} of τ² accel / 2 was left");
    assert!(checked > 100_000);
}

/// A configuration drawn uniformly within the joint limits.
fn random(robot: &RobotModel, rng: &mut ChaCha8Rng) -> Vec<f64> {
    robot.limits().iter().map(|l| rng.random_range(l.lower..l.upper)).collect()
}

/// A robot of problems/: every movable joint active, or those of an SRDF
/// group.
fn spherized(urdf: &str, srdf_group: Option<(&str, &str)>) -> Arc<RobotModel> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("problems");
    let desc = Arc::new(RobotDescription::from_urdf_file(root.join(urdf), &Default::default()).unwrap());
    let mut builder = RobotModel::builder(desc);
    if let Some((srdf, group)) = srdf_group {
        builder = builder.selection(Srdf::from_srdf_file(root.join(srdf)).unwrap().joint_selection(group).unwrap());
    }
    Arc::new(builder.build().unwrap())
}

/// The fast path takes URDFs' eleven-digit quarter turns as exact ones
/// (`quarter_turns.rs`): on robots written that way, every sphere centre
/// it places lies within its stated bound of the exact model's forward
/// kinematics, the bound within a quarter of the tolerance band.
#[test]
fn snapped_quarter_turns_keep_spheres_within_their_bound() {
    let robots = [
        spherized("motionbenchmaker/panda_spherized.urdf", None),
        spherized("robots/baxter/baxter_spheres.urdf", Some(("robots/baxter/baxter.srdf", "both_arms"))),
        spherized("robots/tiago/tiago_spheres.urdf", Some(("robots/tiago/tiago.srdf", "arm_torso"))),
        spherized("robots/ur5/ur5_spheres.urdf", None),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for robot in robots {
        let collision = CollisionModel::builder(robot.clone()).build().unwrap();
        let model = SphereModel::compile(collision.geometry()).unwrap();
        let snapped = model.snapped();
        assert_eq!(collision.snapped_quarter_turns(), Some(snapped));
        assert!(snapped.frames >= 2, "{}: {snapped:?}", robot.nq());
        assert!(snapped.error > 0.0 && snapped.error <= super::TOLERANCE / 4.0, "{snapped:?}");
        let mut ws = SphereWorkspace::new(&model, robot.nq());
        let mut kin = crate::robot::KinematicsWorkspace::new(&robot);
        let owners = owners(&model);
        let mut worst = 0.0f64;
        for _ in 0..50 {
            let (q0, q1) = (random(&robot, &mut rng), random(&robot, &mut rng));
            let t: Lane = std::array::from_fn(|l| l as f64 / (LANES - 1) as f64);
            place(&model, &mut ws, (&q0, &q1), &t);
            for (l, &t) in t.iter().enumerate() {
                let q: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| a + (b - a) * t).collect();
                robot.forward_kinematics(&mut kin, &q).unwrap();
                for (s, &(_, body)) in owners.iter().enumerate() {
                    let exact = robot.body_pose(&kin, body) * nalgebra::Point3::from(model.spheres[s].center);
                    let fast = nalgebra::Point3::new(ws.centers[s][0][l], ws.centers[s][1][l], ws.centers[s][2][l]);
                    worst = worst.max((exact - fast).norm());
                }
            }
        }
        // Rounding adds ~1e-15 m on top of the snapping bound.
        assert!(worst <= snapped.error + 1e-13, "{worst:e} m against the bound {:e} m", snapped.error);
        assert!(worst > 1e-13, "snapping should show: {worst:e}");
    }
}

/// The four robots of the benchmarks, each with the scene of every static kind.
pub(super) fn benchmark_robots() -> Vec<(Arc<RobotModel>, CollisionModel)> {
    [
        spherized("motionbenchmaker/panda_spherized.urdf", None),
        spherized("robots/baxter/baxter_spheres.urdf", Some(("robots/baxter/baxter.srdf", "both_arms"))),
        spherized("robots/tiago/tiago_spheres.urdf", Some(("robots/tiago/tiago.srdf", "arm_torso"))),
        spherized("robots/ur5/ur5_spheres.urdf", None),
    ]
    .into_iter()
    .map(|robot| {
        let model = CollisionModel::builder(robot.clone()).scene(&scene()).build().unwrap();
        (robot, model)
    })
    .collect()
}

/// The single-precision placements and pair distances lie within an
/// eighth of the band the check assumes, on every benchmark robot.
#[test]
fn single_precision_stays_well_within_its_band() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for (robot, model) in benchmark_robots() {
        let fast = model.spheres.as_ref().expect("sphere fast path");
        let single = fast.single.as_deref().expect("single precision");
        let band = single.band();
        assert!(band > 0.0 && band < 1e-3, "{band:e}");
        let (mut ws, mut ws32) =
            (SphereWorkspace::new(fast, robot.nq()), SphereWorkspace::new(&single.model, robot.nq()));
        let (mut worst_center, mut worst_distance) = (0.0f64, 0.0f64);
        for _ in 0..200 {
            let (q0, q1) = (random(&robot, &mut rng), random(&robot, &mut rng));
            let t: Lane = std::array::from_fn(|_| rng.random_range(0.0..1.0));
            place(fast, &mut ws, (&q0, &q1), &t);
            place(&single.model, &mut ws32, (&q0, &q1), &t);
            for (a, b) in ws.centers.iter().zip(&ws32.centers) {
                for l in 0..LANES {
                    let e = (0..3).map(|k| (a[k][l] - b[k][l] as f64).powi(2)).sum::<f64>().sqrt();
                    worst_center = worst_center.max(e);
                }
            }
            for (a, b) in distances(fast, &ws).iter().zip(distances(&single.model, &ws32)) {
                for l in (0..LANES).filter(|&l| a[l] > 0.0) {
                    worst_distance = worst_distance.max((a[l] - b[l]).abs());
                }
            }
        }
        println!(
            "nq {}: band {band:.2e} m, worst centre {worst_center:.2e} m, worst distance {worst_distance:.2e} m",
            robot.nq()
        );
        assert!(worst_center > 0.0 && worst_center <= band / 8.0, "{worst_center:e} against {band:e}");
        assert!(worst_distance <= band / 8.0, "{worst_distance:e} against {band:e}");
    }
}

/// The plain check's verdict, single precision first, is the f64 check's
/// for every batch: random ones, and batches a few nanometres to a
/// millimetre of motion around the configurations where the f64 verdict
/// changes (found by bisection), where the single-precision check must
/// defer.
#[test]
fn single_precision_checks_give_the_f64_verdicts() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let (mut deferred, mut decided) = (0usize, 0usize);
    for (robot, model) in benchmark_robots() {
        let fast = model.spheres.as_ref().expect("sphere fast path");
        let single = fast.single.as_deref().expect("single precision");
        let mut ws = SphereWorkspace::new(fast, robot.nq());
        let mut ws32 = SphereWorkspace::new(&single.model, robot.nq());
        let mut ws_one = SphereWorkspace::new(fast, robot.nq());
        let mut compare = |q0: &[f64], q1: &[f64], t: &Lane| {
            fast.set_along(&mut ws, q0, q1, t);
            let exact = fast.check::<false>(&mut ws);
            assert_eq!(fast.check_plain(&mut ws), exact, "at t = {t:?}");
            single.model.set_along(&mut ws32, q0, q1, t);
            match single.model.check::<false>(&mut ws32) {
                Verdict::Free { unsure, .. } if unsure.contains(&true) => deferred += 1,
                _ => decided += 1,
            }
        };
        for _ in 0..300 {
            let (q0, q1) = (random(&robot, &mut rng), random(&robot, &mut rng));
            compare(&q0, &q1, &std::array::from_fn(|_| rng.random_range(0.0..1.0)));
            // Where the verdict of one configuration changes along the motion.
            let mut one = |t: f64| {
                fast.set_along(&mut ws_one, &q0, &q1, &[t; LANES]);
                fast.check::<false>(&mut ws_one) == Verdict::Collides
            };
            let (Some(mut free), Some(mut hit)) = (
                (0..=16).map(|k| k as f64 / 16.0).find(|&t| !one(t)),
                (0..=16).map(|k| k as f64 / 16.0).find(|&t| one(t)),
            ) else {
                continue;
            };
            for _ in 0..50 {
                let mid = 0.5 * (free + hit);
                if one(mid) { hit = mid } else { free = mid }
            }
            for scale in [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8] {
                let t: Lane = std::array::from_fn(|l| (free + (l as f64 - 3.5) * scale).clamp(0.0, 1.0));
                compare(&q0, &q1, &t);
                compare(&q0, &q1, &[free + scale; LANES]);
                compare(&q0, &q1, &[free - scale; LANES]);
            }
        }
        // Beyond the limits (a slide's, the bound's assumption): f64 decides.
        let beyond: Vec<f64> = robot.limits().iter().map(|l| l.upper + 0.5).collect();
        let slides = fast.bodies.iter().any(|b| b.motion.is_prismatic());
        fast.set_along(&mut ws_one, &beyond, &beyond, &[0.0; LANES]);
        assert_eq!(single.covers(&ws_one.q), !slides);
        compare(&beyond, &beyond, &[0.0; LANES]);
    }
    println!("{decided} batches decided in single precision, {deferred} deferred to f64");
    assert!(deferred > 20 && decided > 1000, "{deferred} deferred, {decided} decided");
}

/// Self pairs in blocks (`segments.rs`): the blocks hold every self pair
/// once; segments cut the groups into runs along one chain; a culled
/// block joins two segments; a robot without one boxes nothing. The
/// Baxter's two arms make culled blocks.
#[test]
fn self_pair_blocks_hold_every_pair_between_separate_segments() {
    for (robot, model) in benchmark_robots() {
        let fast = model.spheres.as_ref().expect("sphere fast path");
        let mut covered = 0;
        for block in &fast.self_blocks {
            assert_eq!(block.pairs.start, covered, "blocks in order, without gaps");
            covered = block.pairs.end;
            let Some([a, b]) = block.segments else { continue };
            assert!(a < b && block.pairs.len() >= 10);
            for pair in &fast.self_pairs[block.pairs.clone()] {
                let mut sides = pair.map(|g| fast.segment_groups[fast.segments[a as usize].clone()].contains(&g));
                sides.sort_unstable();
                assert_eq!(sides, [false, true], "a pair of the block joins its two segments");
            }
        }
        assert_eq!(covered, fast.self_pairs.len());
        let culled = fast.self_blocks.iter().filter(|b| b.segments.is_some()).count();
        if culled == 0 {
            assert!(fast.segments.is_empty() && fast.self_blocks.len() <= 1, "nothing to box");
            continue;
        }
        let mut members: Vec<u32> = fast.segment_groups.clone();
        members.sort_unstable();
        assert_eq!(members, (0..fast.groups.len() as u32).collect::<Vec<_>>(), "segments partition the groups");
        let parents: Vec<usize> = fast.bodies.iter().map(|b| b.parent).collect();
        let descends = |mut b: usize, a: usize| loop {
            if b == a {
                return true;
            }
            if b == 0 {
                return false;
            }
            b = parents[b];
        };
        for range in &fast.segments {
            let mut bodies: Vec<usize> =
                fast.segment_groups[range.clone()].iter().map(|&g| fast.groups[g as usize].body).collect();
            bodies.sort_unstable();
            assert!(range.len() <= 4 && bodies.windows(2).all(|w| descends(w[1], w[0])), "one chain: {bodies:?}");
        }
        if robot.nq() == 14 {
            assert!(culled >= 8, "the Baxter's arms: {culled} culled blocks");
        }
    }
}

/// `model` checking its self pairs one by one.
fn every_pair<T: Real>(model: &SphereModel<T>) -> SphereModel<T> {
    let mut model = model.clone();
    model.self_blocks = vec![super::segments::SelfBlock { pairs: 0..model.self_pairs.len(), segments: None }];
    model
}

/// Culling self pairs block by block changes no answer: plain and
/// certification checks of random batches (no obstacles, so that every
/// check reaches the self pairs) give the same verdicts, split flags and
/// rooms as checking every pair, in f64 and in single precision.
#[test]
fn culling_self_pairs_in_blocks_keeps_every_verdict() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let (mut checks, mut culled) = (0usize, 0usize);
    for (robot, _) in benchmark_robots() {
        let model = CollisionModel::builder(robot.clone()).build().unwrap();
        let fast = model.spheres.as_ref().expect("sphere fast path");
        let (unculled, single) = (every_pair(fast), fast.single.as_deref().expect("single precision"));
        let single_unculled = every_pair(&single.model);
        let mut ws = [SphereWorkspace::new(fast, robot.nq()), SphereWorkspace::new(fast, robot.nq())];
        let mut ws32 =
            [SphereWorkspace::new(&single.model, robot.nq()), SphereWorkspace::new(&single.model, robot.nq())];
        for _ in 0..400 {
            let (q0, q1) = (random(&robot, &mut rng), random(&robot, &mut rng));
            let t: Lane = std::array::from_fn(|_| rng.random_range(0.0..1.0));
            let width: Lane = std::array::from_fn(|_| rng.random_range(0.0..0.05));
            let mut verdicts = Vec::new();
            for (m, ws) in [fast, &unculled].into_iter().zip(&mut ws) {
                m.set_along(ws, &q0, &q1, &t);
                let plain = m.check::<false>(ws);
                m.start_sweeps(ws, &q0, &q1);
                ws.margins = super::workspace::Margins { half: 0.01, full: 0.02, width };
                m.set_along(ws, &q0, &q1, &t);
                let certified = m.check::<true>(ws);
                verdicts.push((plain, certified, ws.room.map(f64::to_bits)));
            }
            assert_eq!(verdicts[0], verdicts[1], "{q0:?} -> {q1:?} at {t:?}");
            let mut single_verdicts = Vec::new();
            for (m, ws) in [&single.model, &single_unculled].into_iter().zip(&mut ws32) {
                m.set_along(ws, &q0, &q1, &t);
                single_verdicts.push(m.check::<false>(ws));
            }
            assert_eq!(single_verdicts[0], single_verdicts[1]);
            checks += 1;
            culled += fast
                .self_blocks
                .iter()
                .filter_map(|b| b.segments)
                .filter(|&s| fast.segments_apart::<false>(&mut ws[0], s))
                .count();
        }
    }
    println!("{checks} batches, {culled} blocks culled in their plain checks");
    assert!(culled > 1000, "the test should cull: {culled}");
}
