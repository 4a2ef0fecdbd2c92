//! Point clouds as obstacles, from 10,000 to 1,000,000 points: what the
//! k-d tree (`tandem::point_cloud::PointTree`) costs to build and to query,
//! and what a cloud added to `builtin:panda_grasp_box` costs the arbiter's
//! tick.
//!
//!   cargo bench --bench point_cloud [-- --quick --json FILE --ticks N --radius R]
//!
//! The clouds (seeded ChaCha8, one seed per size) are what a depth camera
//! sees of a cluttered workspace around the Panda: points drawn uniformly by
//! area on the table top, a back wall behind the robot, two shelf units
//! (three boards, two sides and a back each) beside the table, and four
//! clutter boxes on the table away from the grasp box, each point moved by
//! 1 mm Gaussian noise per axis. Points within 3 cm of the grasp box (the
//! object a camera's segmentation takes out) and within 3 cm of the arm's
//! spheres anywhere along the recorded approach (below) are drawn again, so
//! every cloud has exactly its count, the start is free and the approach
//! stays feasible; the table shows how many were drawn again. Each point is
//! a ball of `--radius` (default 5 mm); `panda_link0` may touch the cloud
//! (it stands on the table, as the problem allows it to touch the table).
//!
//! Figures, for 10K, 100K and 1M points (`--quick`: 10K and 100K):
//! * **build**: `PointTree::new` (median of several builds, ms), and
//!   `Obstacle::point_cloud` (the tree) plus `Arbiter::for_problem` (the
//!   collision model with its sphere fast path, and the arbiter) on the
//!   scene with the cloud (median, ms), beside the same without a cloud;
//! * **queries** (ns per query, median over batches of 100): `any_closer`
//!   (is a point closer than the ball's radius plus the point radius),
//!   `nearest` uncapped (what exact distances ask) and `nearest` capped at
//!   5 cm beyond the ball (what the sphere fast path asks), for three sets
//!   of balls: `free` (centres uniform in the workspace box, radii 1–8 cm:
//!   mostly free), `near` (centres within 0–5 cm of a surface point, radii
//!   1–8 cm) and `panda` (the Panda's collision spheres at uniform random
//!   configurations); the share of balls that hit is shown;
//! * **tick** (µs, median / p99 / max): the arbiter on the grasp problem
//!   with 0, 10K, 100K and 1M points in its scene, modes `constrained` and
//!   `sos`, replaying an Approach-operator episode recorded under `sos`
//!   without a cloud (as benches/arbitration.rs does: the same states,
//!   velocities and commands for every cloud) for `--ticks` ticks (default
//!   5000, `--quick` 1000) at 1 kHz (the arbiter's default is the
//!   dissertation's 15 Hz; a real arm's controller runs at 1 kHz), after
//!   one warm-up pass over the episode, with the mean number of distance
//!   rows and of solves per tick; then the same operator closed loop with
//!   the cloud (outcome, ticks, smallest clearance). The goals' references
//!   are optimized once, without the cloud (the cloud stays clear of them):
//!   only the arbiter's collision model differs between the rows;
//! * **stages** (µs, at the replayed states): the two that read the cloud,
//!   `distances` of the arbiter's collision model at a 1 cm cutoff (what
//!   the rows ask) and `motion_free_certified` of the replayed step, with
//!   the pairs found within the cutoff; and, for comparison, the cloud
//!   pairs' searches capped at that cutoff (`nearest` and `any_closer` for
//!   every sphere paired with the cloud).
//!
//! The target: with 100K points the tick median at most twice the
//! tick without a cloud, and its p99 at most 100 µs (checked and printed).
//!
//! A human-readable table goes to stdout; `--json FILE` writes every figure.
//! Under `cargo test --all-targets` (no `--bench` argument) a smoke run:
//! 10K points, 200 ticks, few queries.

#[allow(dead_code)]
#[path = "support/mbm.rs"]
mod mbm;
#[path = "support/recorded.rs"]
mod recorded;

use mbm::{full_run, option, text};
use nalgebra::IsometryMatrix3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use recorded::{Recorded, recorded_ticks};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::hint::black_box;
use std::time::Instant;
use tandem::arbitration::{
    Arbiter, ArbiterSettings, ArbiterWorkspace, ArbitrationMode, GoalSettings, HumanCommand, ProblemGoal, TickInput,
    problem_goals,
};
use tandem::collision::{CollisionModel, CollisionWorkspace, ObjectSource};
use tandem::point_cloud::{PointCloud, PointTree};
use tandem::problem::Problem;
use tandem::scene::{Obstacle, Shape};
use tandem::sim::{Approach, Episode, EpisodeSettings, TaskJudge, percentiles};

/// The cloud obstacle's name.
const CLOUD: &str = "camera";
/// Clearance kept from the grasp box and from the recorded approach (m).
const CLEARANCE: f64 = 0.03;
/// Point noise (m, standard deviation per axis).
const NOISE: f64 = 0.001;
/// The arbiter's period (s): 1 kHz, as a real arm's controller runs it
/// (the settings' default is the dissertation's 15 Hz).
const PERIOD: f64 = 0.001;

/// What the run covers.
struct Plan {
    sizes: Vec<usize>,
    ticks: usize,
    queries: usize,
    radius: f64,
}

impl Plan {
    fn from_args(args: &[String]) -> Plan {
        let quick = args.iter().any(|a| a == "--quick");
        let radius = option(args, "--radius").unwrap_or(0.005);
        assert!(radius.is_finite() && radius > 0.0, "--radius must be positive");
        let (sizes, ticks, queries) = if !full_run() {
            (vec![10_000], 200, 1_000)
        } else if quick {
            (vec![10_000, 100_000], 1_000, 10_000)
        } else {
            (vec![10_000, 100_000, 1_000_000], 5_000, 20_000)
        };
        let ticks = option(args, "--ticks").map_or(ticks, |t| t as usize).max(1);
        Plan { sizes, ticks, queries, radius }
    }
}

/// A flat patch: centre and two orthogonal half-sides (m, world).
#[derive(Clone, Copy)]
struct Patch {
    c: [f64; 3],
    u: [f64; 3],
    v: [f64; 3],
}

impl Patch {
    fn area(&self) -> f64 {
        let n = |a: &[f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        4.0 * n(&self.u) * n(&self.v)
    }
}

/// The patch of the rectangle at `c` spanned by half-sides `u` and `v`.
fn patch(c: [f64; 3], u: [f64; 3], v: [f64; 3]) -> Patch {
    Patch { c, u, v }
}

/// Top and four sides of a box on the table (centre `x`, `y` of its
/// footprint, `size`).
fn clutter_box(x: f64, y: f64, size: [f64; 3], out: &mut Vec<Patch>) {
    let [a, b, h] = size.map(|s| s / 2.0);
    out.push(patch([x, y, 2.0 * h], [a, 0.0, 0.0], [0.0, b, 0.0]));
    for s in [-1.0, 1.0] {
        out.push(patch([x + s * a, y, h], [0.0, b, 0.0], [0.0, 0.0, h]));
        out.push(patch([x, y + s * b, h], [a, 0.0, 0.0], [0.0, 0.0, h]));
    }
}

/// The surfaces the camera sees (world, m): the problem's table top
/// (x −0.4…1.0, y ±0.8 at z = 0), a wall 0.38 m behind the base, shelf
/// units at |y| 0.55…0.8, and four boxes of clutter.
fn surfaces() -> Vec<Patch> {
    let mut out = vec![
        patch([0.3, 0.0, 0.0], [0.7, 0.0, 0.0], [0.0, 0.8, 0.0]),
        patch([-0.38, 0.0, 0.6], [0.0, 0.8, 0.0], [0.0, 0.0, 0.6]),
    ];
    for s in [-1.0, 1.0] {
        let (y, depth, height) = (s * 0.675, 0.125, 0.525);
        for z in [0.35, 0.7, 1.05] {
            out.push(patch([0.45, y, z], [0.3, 0.0, 0.0], [0.0, depth, 0.0]));
        }
        for x in [0.15, 0.75] {
            out.push(patch([x, y, height], [0.0, depth, 0.0], [0.0, 0.0, height]));
        }
        out.push(patch([0.45, s * 0.8, height], [0.3, 0.0, 0.0], [0.0, 0.0, height]));
    }
    clutter_box(0.75, -0.3, [0.12, 0.1, 0.2], &mut out);
    clutter_box(0.8, 0.32, [0.1, 0.15, 0.1], &mut out);
    clutter_box(0.25, -0.42, [0.08, 0.08, 0.25], &mut out);
    clutter_box(0.88, 0.02, [0.1, 0.1, 0.15], &mut out);
    out
}

/// One standard normal draw (Box–Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Where points may not be: near the grasp box, near the recorded approach.
struct Keepout {
    /// The grasp box's bounds (m, world).
    object: ([f64; 3], [f64; 3]),
    /// Centres of the arm's spheres along the recorded approach, one tree
    /// per radius (m): a point closer than radius + [`CLEARANCE`] is out.
    swept: Vec<(f64, PointTree)>,
}

impl Keepout {
    fn rejects(&self, p: &[f64; 3]) -> bool {
        let (lo, hi) = &self.object;
        let d2: f64 = (0..3).map(|i| (lo[i] - p[i]).max(p[i] - hi[i]).max(0.0).powi(2)).sum();
        d2 < CLEARANCE * CLEARANCE || self.swept.iter().any(|(r, tree)| tree.any_closer(p, r + CLEARANCE))
    }
}

/// `n` points on the surfaces (seed `seed`), none in `keepout`, and how
/// many draws it rejected.
fn sample_cloud(n: usize, seed: u64, keepout: &Keepout) -> (PointCloud, usize) {
    let patches = surfaces();
    let mut cumulative = Vec::with_capacity(patches.len());
    let mut total = 0.0;
    for p in &patches {
        total += p.area();
        cumulative.push(total);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut points, mut rejected) = (Vec::with_capacity(n), 0);
    while points.len() < n {
        let pick = rng.random_range(0.0..total);
        let patch = &patches[cumulative.partition_point(|&c| c <= pick).min(patches.len() - 1)];
        let (a, b) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let p: [f64; 3] =
            std::array::from_fn(|i| patch.c[i] + a * patch.u[i] + b * patch.v[i] + NOISE * gaussian(&mut rng));
        if keepout.rejects(&p) {
            rejected += 1;
        } else {
            points.push(p);
        }
    }
    (PointCloud::from_points(points), rejected)
}

/// The grasp problem, its goals and an Approach episode recorded under
/// SumOfSquares without a cloud (as benches/arbitration.rs records it).
struct Setup {
    problem: Problem,
    goals: Vec<ProblemGoal>,
    ticks: Vec<Recorded>,
    /// Every configuration of the episode, the start first.
    path: Vec<Vec<f64>>,
}

fn setup() -> Setup {
    let problem = Problem::builtin("panda_grasp_box").expect("builtin problem");
    let goals = problem_goals(&problem, &GoalSettings::default()).expect("goal references");
    let arbiter = arbiter(&problem, &goals, ArbitrationMode::SumOfSquares);
    let (record, _) = closed_loop(&arbiter, &problem, &goals);
    assert!(record.steps > 0, "the recorded episode has no ticks ({})", record.outcome.as_str());
    let dt = arbiter.settings().period;
    let ticks = recorded_ticks(&record, dt);
    eprintln!("recorded {} ticks at {} s ({})", ticks.len(), dt, record.outcome.as_str());
    Setup { problem, goals, ticks, path: record.q }
}

fn arbiter(problem: &Problem, goals: &[ProblemGoal], mode: ArbitrationMode) -> Arbiter {
    let settings = ArbiterSettings { mode, period: PERIOD, ..ArbiterSettings::default() };
    Arbiter::for_problem(problem, goals, settings).expect("arbiter")
}

/// The Approach operator's episode under `arbiter`, and its wall time (s).
fn closed_loop(arbiter: &Arbiter, problem: &Problem, goals: &[ProblemGoal]) -> (tandem::sim::EpisodeRecord, f64) {
    let episode = Episode {
        arbiter,
        start: &problem.start,
        target: goals[0].position,
        true_goal: 0,
        settings: EpisodeSettings::default(),
    };
    let mut judge = TaskJudge::new(&goals[0]);
    let began = Instant::now();
    let record = episode.run(&mut arbiter.workspace(), &mut Approach::default(), &mut judge).expect("episode");
    (record, began.elapsed().as_secs_f64())
}

/// The robot's collision spheres at `q` (world centre, padded radius; m).
fn robot_spheres(model: &CollisionModel, ws: &mut CollisionWorkspace, q: &[f64]) -> Vec<([f64; 3], f64)> {
    model.pair_distance_at(ws, q, 0).expect("valid q");
    (0..model.object_count())
        .filter(|&i| matches!(model.object_source(i), ObjectSource::RobotLink { .. }))
        .filter_map(|i| match model.object_shape(i) {
            Shape::Sphere { radius } => {
                let t = model.object_world_pose(ws, i).translation.vector;
                Some(([t.x, t.y, t.z], radius + model.padding()))
            }
            _ => None,
        })
        .collect()
}

/// The keep-out of `s`'s scene: its grasp box and the arm's spheres at
/// every configuration of the recorded approach.
fn keepout(s: &Setup) -> Keepout {
    let box_ = s.problem.scene.object("box").expect("the grasp box");
    let (lo, hi) = {
        let c = box_.pose.translation.vector;
        let e = box_.shape.extents() / 2.0;
        ([c.x - e.x, c.y - e.y, c.z - e.z], [c.x + e.x, c.y + e.y, c.z + e.z])
    };
    let model = s.problem.collision_model().expect("collision model");
    let mut ws = CollisionWorkspace::new(&model);
    let mut by_radius: BTreeMap<u64, (f64, Vec<[f64; 3]>)> = BTreeMap::new();
    for q in &s.path {
        for (c, r) in robot_spheres(&model, &mut ws, q) {
            by_radius.entry((r * 1e6).round() as u64).or_insert((r, vec![])).1.push(c);
        }
    }
    let swept = by_radius.into_values().map(|(r, centres)| (r, PointTree::new(&centres))).collect();
    Keepout { object: (lo, hi), swept }
}

/// Median of `f`'s wall time over `runs` runs (ms).
fn median_ms(runs: usize, mut f: impl FnMut()) -> f64 {
    let times: Vec<f64> = (0..runs)
        .map(|_| {
            let began = Instant::now();
            f();
            began.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    percentiles(&times).0
}

/// A set of query balls (centre, radius; m).
type Balls = Vec<([f64; 3], f64)>;

/// The three query sets for `cloud`: `free`, `near` and `panda`.
fn query_sets(s: &Setup, cloud: &PointCloud, count: usize, seed: u64) -> Vec<(&'static str, Balls)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let free = (0..count)
        .map(|_| {
            let c = [rng.random_range(-0.35..0.95), rng.random_range(-0.75..0.75), rng.random_range(0.02..1.1)];
            (c, rng.random_range(0.01..0.08))
        })
        .collect();
    let near = (0..count)
        .map(|_| {
            let p = cloud.points[rng.random_range(0..cloud.len())];
            let d: [f64; 3] = std::array::from_fn(|_| gaussian(&mut rng));
            let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
            let at = rng.random_range(0.0..0.05);
            (std::array::from_fn(|i| p[i] + d[i] / norm * at), rng.random_range(0.01..0.08))
        })
        .collect();
    let model = s.problem.collision_model().expect("collision model");
    let mut ws = CollisionWorkspace::new(&model);
    let mut panda = Vec::with_capacity(count);
    while panda.len() < count {
        let q: Vec<f64> = model.robot().limits().iter().map(|l| rng.random_range(l.lower..=l.upper)).collect();
        panda.extend(robot_spheres(&model, &mut ws, &q));
    }
    panda.truncate(count);
    vec![("free", free), ("near", near), ("panda", panda)]
}

/// Median time per query (ns) of `query` over batches of 100 balls, three
/// passes over `balls` after a warm-up pass.
fn per_query_ns(balls: &Balls, mut query: impl FnMut(&[f64; 3], f64) -> f64) -> f64 {
    const BATCH: usize = 100;
    let mut sink = 0.0;
    for (c, r) in balls {
        sink += query(c, *r);
    }
    let mut times = Vec::new();
    for _ in 0..3 {
        for batch in balls.chunks(BATCH) {
            let began = Instant::now();
            for (c, r) in batch {
                sink += query(black_box(c), *r);
            }
            times.push(began.elapsed().as_secs_f64() * 1e9 / batch.len() as f64);
        }
    }
    black_box(sink);
    percentiles(&times).0
}

/// The query figures of `tree` (ball radius `radius` on every point).
fn queries(tree: &PointTree, sets: &[(&'static str, Balls)], radius: f64) -> Vec<Value> {
    sets.iter()
        .map(|(name, balls)| {
            let hits = balls.iter().filter(|(c, r)| tree.any_closer(c, r + radius)).count();
            let any = per_query_ns(balls, |c, r| f64::from(u8::from(tree.any_closer(c, r + radius))));
            let uncapped = per_query_ns(balls, |c, _| tree.nearest(c, f64::INFINITY).map_or(0.0, |(d2, _)| d2));
            let capped = per_query_ns(balls, |c, r| tree.nearest(c, r + radius + 0.05).map_or(0.0, |(d2, _)| d2));
            json!({"set": name, "queries": balls.len(), "hit_fraction": hits as f64 / balls.len() as f64,
                "any_closer_ns": any, "nearest_ns": uncapped, "nearest_capped_ns": capped})
        })
        .collect()
}

/// Tick times (µs) of `a` over `count` replayed ticks after a warm-up
/// pass, and the mean number of distance rows and of solves per tick.
fn replay(a: &Arbiter, ws: &mut ArbiterWorkspace, s: &Setup, count: usize) -> (Vec<f64>, f64, f64) {
    let n = s.ticks.len();
    let tick = |ws: &mut ArbiterWorkspace, k: usize| {
        let r = &s.ticks[k % n];
        if k.is_multiple_of(n) {
            a.reset(ws);
        }
        let input = TickInput {
            q: &r.q,
            velocity: Some(&r.velocity),
            command: HumanCommand::Linear(&r.command),
            beliefs: None,
        };
        let out = a.tick(ws, &input);
        black_box(out.qdot[0]);
        (out.diagnostics.distance_pairs, out.diagnostics.solves)
    };
    for k in 0..n {
        tick(ws, k);
    }
    let (mut times, mut rows, mut solves) = (Vec::with_capacity(count), 0usize, 0u64);
    for k in 0..count {
        let began = Instant::now();
        let (r, sv) = tick(ws, k);
        times.push(began.elapsed().as_secs_f64() * 1e6);
        rows += r;
        solves += u64::from(sv);
    }
    (times, rows as f64 / count as f64, solves as f64 / count as f64)
}

/// Per replayed state, the time (µs, median and p99) of the two stages that
/// read the cloud: the distances at a 1 cm cutoff, and the certification
/// of the replayed step; the mean number of pairs within the cutoff; and,
/// for comparison, what the cloud pairs' searches cost when capped at the
/// cutoff: `nearest` capped at the cutoff beyond the sphere, and
/// `any_closer` at it, for every sphere of a cloud pair.
fn stages(model: &CollisionModel, s: &Setup) -> Value {
    let mut ws = CollisionWorkspace::new(model);
    let (mut distances, mut certify, mut pairs, mut cloud_pairs) = (vec![], vec![], 0usize, 0usize);
    let (mut capped, mut any) = (vec![], vec![]);
    let cloud = (0..model.object_count()).find(|&i| matches!(model.object_shape(i), Shape::Points { .. }));
    let spheres: Vec<(usize, f64)> = (0..model.pair_count())
        .map(|p| model.pair_objects(p))
        .filter(|&(_, j)| Some(j) == cloud)
        .filter_map(|(i, _)| match model.object_shape(i) {
            Shape::Sphere { radius } => Some((i, radius + model.padding())),
            _ => None,
        })
        .collect();
    let model_cloud_pairs = (0..model.pair_count()).filter(|&p| Some(model.pair_objects(p).1) == cloud).count();
    for pass in 0..2 {
        for t in 0..s.ticks.len() {
            let (q, next) = (&s.path[t], &s.path[t + 1]);
            let began = Instant::now();
            let found = model.distances(&mut ws, q, 0.01).expect("valid q");
            let elapsed = began.elapsed().as_secs_f64() * 1e6;
            if pass == 1 {
                distances.push(elapsed);
                pairs += found.len();
                cloud_pairs += found.iter().filter(|d| Some(model.pair_objects(d.pair).1) == cloud).count();
            }
            let began = Instant::now();
            black_box(model.motion_free_certified(&mut ws, q, next, 1e-4).expect("valid q"));
            if pass == 1 {
                certify.push(began.elapsed().as_secs_f64() * 1e6);
            }
            let Some(Shape::Points { points: tree, radius }) = cloud.map(|c| model.object_shape(c)) else { continue };
            model.pair_distance_at(&mut ws, q, 0).expect("valid q");
            let centres: Vec<([f64; 3], f64)> = spheres
                .iter()
                .map(|&(i, r)| {
                    let t = model.object_world_pose(&ws, i).translation.vector;
                    ([t.x, t.y, t.z], r + radius + 0.01)
                })
                .collect();
            let began = Instant::now();
            for (c, reach) in &centres {
                black_box(tree.nearest(c, *reach));
            }
            let between = Instant::now();
            for (c, reach) in &centres {
                black_box(tree.any_closer(c, *reach));
            }
            if pass == 1 {
                capped.push((between - began).as_secs_f64() * 1e6);
                any.push(between.elapsed().as_secs_f64() * 1e6);
            }
        }
    }
    let n = s.ticks.len() as f64;
    let (dm, dp, _) = percentiles(&distances);
    let (cm, cp, _) = percentiles(&certify);
    let (capped, any) = (percentiles(&capped).0, percentiles(&any).0);
    json!({"distances_median_us": dm, "distances_p99_us": dp, "certify_median_us": cm, "certify_p99_us": cp,
        "cloud_pairs_nearest_capped_median_us": capped, "cloud_pairs_any_closer_median_us": any,
        "pairs_within_1cm": pairs as f64 / n, "cloud_pairs_within_1cm": cloud_pairs as f64 / n,
        "pairs": model.pair_count(), "cloud_pairs": model_cloud_pairs})
}

/// The problem with `cloud` (balls of `radius`) in its scene.
fn with_cloud(problem: &Problem, cloud: Obstacle) -> Problem {
    let mut p = problem.clone();
    p.scene.add_obstacle(cloud).expect("the cloud");
    p.scene.allow_contact("panda_link0", CLOUD);
    p
}

const MODES: [ArbitrationMode; 2] = [ArbitrationMode::Constrained, ArbitrationMode::SumOfSquares];

/// Everything measured for one cloud size (0: no cloud).
fn measure(s: &Setup, plan: &Plan, keepout: &Keepout, size: usize) -> Value {
    let mut out = serde_json::Map::new();
    out.insert("points".into(), json!(size));
    let problem = if size == 0 {
        let runs = 3;
        let build = median_ms(runs, || drop(black_box(arbiter(&s.problem, &s.goals, ArbitrationMode::SumOfSquares))));
        out.insert("build".into(), json!({"arbiter_ms": build}));
        s.problem.clone()
    } else {
        let began = Instant::now();
        let (cloud, rejected) = sample_cloud(size, size as u64, keepout);
        let sampling = began.elapsed().as_secs_f64() * 1e3;
        let runs = if size >= 1_000_000 { 3 } else { 5 };
        let tree = median_ms(runs, || drop(black_box(PointTree::new(&cloud.points))));
        let obstacle = median_ms(runs, || {
            drop(black_box(Obstacle::point_cloud(CLOUD, &cloud, plan.radius, IsometryMatrix3::identity())))
        });
        let make = || Obstacle::point_cloud(CLOUD, &cloud, plan.radius, IsometryMatrix3::identity()).expect("radius");
        let obstacle_arbiter = median_ms(runs, || {
            let p = with_cloud(&s.problem, make());
            drop(black_box(arbiter(&p, &s.goals, ArbitrationMode::SumOfSquares)));
        });
        out.insert(
            "build".into(),
            json!({"sampling_ms": sampling, "rejected_draws": rejected, "point_tree_ms": tree,
                "obstacle_ms": obstacle, "obstacle_and_arbiter_ms": obstacle_arbiter}),
        );
        let tree = PointTree::new(&cloud.points);
        let sets = query_sets(s, &cloud, plan.queries, 1000 + size as u64);
        out.insert("queries".into(), json!(queries(&tree, &sets, plan.radius)));
        with_cloud(&s.problem, make())
    };
    let model = problem.collision_model_grasping(&["box"], 0.0).expect("collision model");
    let mut ws = CollisionWorkspace::new(&model);
    let start_free = model.collision_free(&mut ws, &problem.start).expect("valid start");
    let start_clearance = model.min_distance(&mut ws, &problem.start).expect("valid start").map(|d| d.signed.distance);
    out.insert("start_free".into(), json!(start_free));
    out.insert("start_clearance_m".into(), json!(start_clearance));
    out.insert("stages".into(), stages(&model, s));
    let mut ticks = vec![];
    for mode in MODES {
        let a = arbiter(&problem, &s.goals, mode);
        let mut ws = a.workspace();
        let (times, rows, solves) = replay(&a, &mut ws, s, plan.ticks);
        let (median, p99, max) = percentiles(&times);
        let (record, wall) = closed_loop(&a, &problem, &s.goals);
        let (live_median, live_p99, _) = percentiles(&record.tick_us);
        ticks.push(json!({"mode": mode.as_str(), "ticks": times.len(), "median_us": median, "p99_us": p99,
            "max_us": max, "distance_rows": rows, "solves": solves,
            "closed_loop": {"outcome": record.outcome.as_str(), "ticks": record.steps,
                "min_clearance_m": record.min_clearance, "fallbacks": record.fallbacks,
                "tick_median_us": live_median, "tick_p99_us": live_p99, "wall_s": wall}}));
    }
    out.insert("ticks".into(), json!(ticks));
    Value::Object(out)
}

fn f(v: &Value, path: &[&str]) -> f64 {
    path.iter().try_fold(v, |v, k| v.get(k)).and_then(Value::as_f64).unwrap_or(f64::NAN)
}

fn print(results: &[Value]) {
    println!("\n## Build (ms)\n");
    println!("| points | sampling | PointTree::new | Obstacle::point_cloud | + Arbiter::for_problem | redrawn |");
    println!("|---:|---:|---:|---:|---:|---:|");
    for r in results {
        let b = |k: &str| f(r, &["build", k]);
        let n = r["points"].as_u64().unwrap_or(0);
        if n == 0 {
            println!("| 0 | – | – | – | {:.2} | – |", b("arbiter_ms"));
        } else {
            println!(
                "| {n} | {:.1} | {:.2} | {:.2} | {:.2} | {} |",
                b("sampling_ms"),
                b("point_tree_ms"),
                b("obstacle_ms"),
                b("obstacle_and_arbiter_ms"),
                r["build"]["rejected_draws"]
            );
        }
    }
    println!("\n## Queries (ns per query, median over batches of 100)\n");
    println!("| points | set | queries | hit | any_closer | nearest (∞) | nearest (cap r + 5 cm) |");
    println!("|---:|---|---:|---:|---:|---:|---:|");
    for r in results {
        for q in r["queries"].as_array().into_iter().flatten() {
            println!(
                "| {} | {} | {} | {:.0} % | {:.0} | {:.0} | {:.0} |",
                r["points"],
                q["set"].as_str().unwrap_or(""),
                q["queries"],
                100.0 * f(q, &["hit_fraction"]),
                f(q, &["any_closer_ns"]),
                f(q, &["nearest_ns"]),
                f(q, &["nearest_capped_ns"])
            );
        }
    }
    println!("\n## Arbiter tick on panda_grasp_box (µs; replayed Approach episode)\n");
    println!(
        "| points | mode | ticks | median | p99 | max | rows | solves | closed loop | its ticks | min clearance (mm) |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---|---:|---:|");
    for r in results {
        for t in r["ticks"].as_array().into_iter().flatten() {
            println!(
                "| {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {} | {} | {:.1} |",
                r["points"],
                t["mode"].as_str().unwrap_or(""),
                t["ticks"],
                f(t, &["median_us"]),
                f(t, &["p99_us"]),
                f(t, &["max_us"]),
                f(t, &["distance_rows"]),
                f(t, &["solves"]),
                t["closed_loop"]["outcome"].as_str().unwrap_or(""),
                t["closed_loop"]["ticks"],
                1e3 * f(t, &["closed_loop", "min_clearance_m"])
            );
        }
    }
    println!("\n## Stages that read the cloud, at the replayed states (µs)\n");
    println!(
        "| points | start free | pairs (cloud) | distances ≤ 1 cm median / p99 | found (cloud) | certified step median / p99 | cloud pairs capped: nearest / any_closer |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|");
    for r in results {
        let g = |k: &str| f(r, &["stages", k]);
        println!(
            "| {} | {} | {} ({}) | {:.1} / {:.1} | {:.2} ({:.2}) | {:.1} / {:.1} | {:.1} / {:.1} |",
            r["points"],
            r["start_free"],
            r["stages"]["pairs"],
            r["stages"]["cloud_pairs"],
            g("distances_median_us"),
            g("distances_p99_us"),
            g("pairs_within_1cm"),
            g("cloud_pairs_within_1cm"),
            g("certify_median_us"),
            g("certify_p99_us"),
            g("cloud_pairs_nearest_capped_median_us"),
            g("cloud_pairs_any_closer_median_us")
        );
    }
}

/// The target at 100K points, per mode: median ≤ 2 × the median
/// without a cloud, p99 ≤ 100 µs.
fn targets(results: &[Value]) -> Vec<Value> {
    let tick = |n: u64, mode: &str| {
        results
            .iter()
            .find(|r| r["points"].as_u64() == Some(n))
            .and_then(|r| r["ticks"].as_array()?.iter().find(|t| t["mode"] == mode).cloned())
    };
    let mut out = vec![];
    for mode in MODES.map(|m| m.as_str()) {
        let (Some(base), Some(cloud)) = (tick(0, mode), tick(100_000, mode)) else { continue };
        let ratio = f(&cloud, &["median_us"]) / f(&base, &["median_us"]);
        let p99 = f(&cloud, &["p99_us"]);
        let met = ratio <= 2.0 && p99 <= 100.0;
        println!(
            "target at 100K points, {mode}: median {ratio:.2} × without a cloud (≤ 2), p99 {p99:.1} µs (≤ 100): {}",
            if met { "met" } else { "MISSED" }
        );
        out.push(json!({"mode": mode, "median_ratio": ratio, "p99_us": p99, "met": met}));
    }
    out
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let plan = Plan::from_args(&args);
    let s = setup();
    let began = Instant::now();
    let keepout = keepout(&s);
    eprintln!("keep-out: {} sphere radii, {:.0} ms", keepout.swept.len(), began.elapsed().as_secs_f64() * 1e3);
    let mut results = vec![];
    for size in std::iter::once(0).chain(plan.sizes.iter().copied()) {
        eprintln!("measuring {size} points");
        results.push(measure(&s, &plan, &keepout, size));
    }
    print(&results);
    let targets = targets(&results);
    if let Some(path) = text(&args, "--json") {
        let json = json!({"problem": "builtin:panda_grasp_box", "point_radius_m": plan.radius, "noise_m": NOISE,
            "clearance_m": CLEARANCE, "recorded_ticks": s.ticks.len(), "period_s": PERIOD,
            "results": results, "targets": targets});
        std::fs::write(path, serde_json::to_string_pretty(&json).expect("JSON")).expect("write --json FILE");
        eprintln!("wrote {path}");
    }
}
