//! Problem families: one base problem plus distributions over its start
//! configuration, object poses and extra obstacles, sampled reproducibly
//! from (seed, id).

use super::toml_source::KeyPath;
use super::{Problem, ProblemError, Source, SourceFile};
use crate::collision::{CollisionModel, CollisionWorkspace, signed_distance};
use crate::scene::{Obstacle, Scene, Shape};
use crate::settings::readable;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFamily {
    base: String,
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default)]
    start: RawStartDistribution,
    #[serde(default)]
    objects: Vec<RawObjectDistribution>,
    #[serde(default)]
    obstacles: Option<RawObstacleDistribution>,
    #[serde(default)]
    optimizer: Option<RawFamilyOptimizer>,
}

/// What a family changes in its base problem's optimizer.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFamilyOptimizer {
    /// The base's collision objectives keep this far (m) from the scene's
    /// obstacles (their `obstacle_margin`).
    obstacle_margin: f64,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStartDistribution {
    #[serde(default)]
    jitter: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObjectDistribution {
    name: String,
    x: Option<[f64; 2]>,
    y: Option<[f64; 2]>,
    yaw: Option<[f64; 2]>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObstacleDistribution {
    count: [usize; 2],
    shapes: Vec<String>,
    size: [f64; 2],
    region_min: [f64; 3],
    region_max: [f64; 3],
    #[serde(default = "default_clearance")]
    clearance: f64,
}

fn default_clearance() -> f64 {
    0.05
}

/// Uniform range `[lo, hi]`.
type Range2 = [f64; 2];

#[derive(Debug, Clone)]
struct ObjectDistribution {
    object: String,
    x: Option<Range2>,
    y: Option<Range2>,
    yaw: Option<Range2>,
}

#[derive(Debug, Clone)]
struct ObstacleDistribution {
    count: [usize; 2],
    shapes: Vec<String>,
    size: Range2,
    region: [Vector3<f64>; 2],
    clearance: f64,
}

/// A family of problems around a base problem; see the module docs and
/// `problems/README.md`.
#[derive(Debug, Clone)]
pub struct ProblemFamily {
    /// The family's name.
    pub name: String,
    /// One line for humans.
    pub description: String,
    /// The base problem every member varies.
    pub base: Problem,
    start_jitter: f64,
    objects: Vec<ObjectDistribution>,
    obstacles: Option<ObstacleDistribution>,
}

/// One sampled problem and how its sampling went.
#[derive(Debug, Clone)]
pub struct FamilySample {
    /// Sample id.
    pub id: u64,
    /// The seed this sample's random stream was drawn from.
    pub seed: u64,
    /// The sampled problem.
    pub problem: Problem,
    /// Obstacles that could not be placed clear of the robot and objects
    /// within the attempt budget (and were left out).
    pub skipped_obstacles: usize,
}

/// Largest tries for a collision-free start or a clear obstacle placement.
const ATTEMPTS: usize = 100;

/// Seed of sample `id` of a run seeded `seed`: a SplitMix64 mix, so
/// neighbouring ids get unrelated streams.
pub fn sample_seed(seed: u64, id: u64) -> u64 {
    let mut z = seed ^ id.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl ProblemFamily {
    /// Loads a family file; its `base` problem is resolved against the
    /// family file's folder.
    ///
    /// # Errors
    /// [`ProblemError`] naming the file, key and line (of the family file, or
    /// of the base problem file for errors there).
    pub fn from_file(path: impl AsRef<Path>) -> Result<ProblemFamily, ProblemError> {
        ProblemFamily::from_source(&SourceFile::read(path.as_ref())?.source())
    }

    /// Parses family text as if read from `origin`, resolving a relative
    /// `base` against `base_dir` (the working directory for `None`); a base
    /// of `builtin:NAME` is a shipped problem ([`Problem::builtin`]).
    ///
    /// # Errors
    /// As [`from_file`](Self::from_file).
    pub fn from_str_with(text: &str, origin: &str, base_dir: Option<&Path>) -> Result<ProblemFamily, ProblemError> {
        ProblemFamily::from_source(&Source { origin, text, base: base_dir })
    }

    /// The most random obstacles a sample draws (0 without an
    /// `[obstacles]` table).
    pub fn max_obstacles(&self) -> usize {
        self.obstacles.as_ref().map_or(0, |d| d.count[1])
    }

    fn from_source(src: &Source) -> Result<ProblemFamily, ProblemError> {
        let raw: RawFamily = toml::from_str(src.text).map_err(|e| src.toml_error(&e))?;
        let base_key = KeyPath::root().key("base");
        let problem = match raw.base.strip_prefix("builtin:") {
            Some(name) => Problem::builtin(name).map_err(|e| src.error(&base_key, e.to_string()))?,
            None => Problem::from_file(src.resolve(&raw.base)).map_err(|e| match e {
                // Errors inside the base file name that file; a missing one is the family's.
                ProblemError::Io { path, source } => {
                    src.error(&base_key, format!("cannot read {}: {source}", path.display()))
                }
                e => e,
            })?,
        };
        raw.build(src, problem)
    }

    /// Sample `id` of the family for run seed `seed`: the same (seed, id)
    /// always gives the same problem. Starts are jittered until
    /// collision-free (the base start when no draw is); obstacles are placed
    /// clear of the start arm, the objects and the space above grasp frames.
    ///
    /// # Errors
    /// The base problem's collision model cannot be built.
    pub fn sample(&self, seed: u64, id: u64) -> Result<FamilySample, crate::collision::CollisionError> {
        let stream_seed = sample_seed(seed, id);
        let mut rng = ChaCha8Rng::seed_from_u64(stream_seed);
        let mut problem = self.base.clone();
        for d in &self.objects {
            move_object(&mut problem.scene, d, &mut rng);
        }
        problem.start = self.sample_start(&problem, &mut rng)?;
        let mut skipped = 0;
        if let Some(d) = &self.obstacles {
            let count = rng.random_range(d.count[0]..=d.count[1]);
            for k in 0..count {
                match place_obstacle(&problem, d, k, &mut rng)? {
                    Some(o) => problem.scene.add_obstacle(o).expect("fresh name and validated shape"),
                    None => skipped += 1,
                }
            }
        }
        problem.name = format!("{}#{id}", self.name);
        Ok(FamilySample { id, seed: stream_seed, problem, skipped_obstacles: skipped })
    }

    fn sample_start(
        &self,
        problem: &Problem,
        rng: &mut ChaCha8Rng,
    ) -> Result<Vec<f64>, crate::collision::CollisionError> {
        if self.start_jitter == 0.0 {
            return Ok(problem.start.clone());
        }
        let model = problem.collision_model()?;
        let mut ws = CollisionWorkspace::new(&model);
        for _ in 0..ATTEMPTS {
            let q: Vec<f64> = problem
                .start
                .iter()
                .zip(problem.robot.limits())
                .map(|(v, l)| (v + rng.random_range(-self.start_jitter..=self.start_jitter)).clamp(l.lower, l.upper))
                .collect();
            if model.collision_free(&mut ws, &q)? {
                return Ok(q);
            }
        }
        Ok(problem.start.clone())
    }
}

fn move_object(scene: &mut Scene, d: &ObjectDistribution, rng: &mut ChaCha8Rng) {
    let Some(obj) = scene.objects_mut().iter_mut().find(|o| o.name == d.object) else { return };
    let mut draw = |r: &Option<Range2>| r.map(|[a, b]| rng.random_range(a..=b));
    let (x, y, yaw) = (draw(&d.x), draw(&d.y), draw(&d.yaw));
    let t = &mut obj.pose.translation.vector;
    t.x = x.unwrap_or(t.x);
    t.y = y.unwrap_or(t.y);
    if let Some(yaw) = yaw {
        obj.pose.rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw) * obj.pose.rotation;
    }
}

/// A random obstacle clear of the start arm, the objects and the space
/// 0.25 m above each grasp frame; `None` after [`ATTEMPTS`] failures.
fn place_obstacle(
    problem: &Problem,
    d: &ObstacleDistribution,
    k: usize,
    rng: &mut ChaCha8Rng,
) -> Result<Option<Obstacle>, crate::collision::CollisionError> {
    for _ in 0..ATTEMPTS {
        let shape_name = &d.shapes[rng.random_range(0..d.shapes.len())];
        let s = rng.random_range(d.size[0]..=d.size[1]);
        let shape = match shape_name.as_str() {
            "sphere" => Shape::sphere(s / 2.0),
            "cylinder" => Shape::cylinder(s / 2.0, s),
            "capsule" => Shape::capsule(s / 4.0, s / 2.0),
            _ => Shape::cuboid([s, s * rng.random_range(0.5..=1.5), s * rng.random_range(0.5..=1.5)]),
        };
        let p = Vector3::from_fn(|i, _| rng.random_range(d.region[0][i]..=d.region[1][i]));
        let yaw = rng.random_range(-std::f64::consts::PI..=std::f64::consts::PI);
        let pose =
            IsometryMatrix3::from_parts(Translation3::from(p), Rotation3::from_axis_angle(&Vector3::z_axis(), yaw));
        let obstacle = Obstacle::new(format!("random_{k}"), shape, pose);
        if is_clear(problem, &obstacle, d.clearance)? {
            return Ok(Some(obstacle));
        }
    }
    Ok(None)
}

fn is_clear(problem: &Problem, o: &Obstacle, clearance: f64) -> Result<bool, crate::collision::CollisionError> {
    let scene = &problem.scene;
    for obj in scene.objects() {
        if signed_distance(&o.shape, &o.pose, &obj.shape, &obj.pose).distance < clearance {
            return Ok(false);
        }
        for g in &obj.grasps {
            // The approach corridor: a capsule from the grasp frame up 0.25 m.
            let top = obj.pose * g.pose;
            let corridor = IsometryMatrix3::from_parts(
                Translation3::from(top.translation.vector + Vector3::z() * 0.125),
                Rotation3::identity(),
            );
            if signed_distance(&o.shape, &o.pose, &Shape::capsule(0.08, 0.25), &corridor).distance < clearance {
                return Ok(false);
            }
        }
    }
    for other in scene.obstacles() {
        if signed_distance(&o.shape, &o.pose, &other.shape, &other.pose).distance < 0.0 {
            return Ok(false);
        }
    }
    let mut alone = Scene::new();
    alone.add_obstacle(o.clone()).expect("validated obstacle");
    // The robot's own collision geometry and padding, as in `Problem::collision_model`.
    let mut builder = CollisionModel::builder(problem.robot.clone()).scene(&alone).padding(problem.robot_spec.padding);
    if let Some(geometry) = &problem.collision_geometry {
        builder = builder.geometry_from(geometry.clone());
    }
    let model = builder.build()?;
    let mut ws = CollisionWorkspace::new(&model);
    // Only pairs with the obstacle count: the arm's own clearance is not at stake.
    let near = model.distances(&mut ws, &problem.start, clearance)?;
    Ok(near.iter().all(|d| model.pair_names(d.pair).1 != o.name))
}

/// The largest coordinate, range end or size a family may give (m or rad):
/// finite values far beyond any workspace (±1.7e308) overflow the samplers
/// and the collision solvers, so they are refused where they enter.
const FAMILY_LIMIT: f64 = 1000.0;

/// The largest random obstacle size and clearance (m).
const MAX_OBSTACLE_SIZE: f64 = 10.0;
/// The largest start jitter (rad or m).
const MAX_JITTER: f64 = 10.0;

impl RawFamily {
    fn build(self, src: &Source, mut base: Problem) -> Result<ProblemFamily, ProblemError> {
        let root = KeyPath::root();
        if let Some(optimizer) = &self.optimizer {
            let path = root.key("optimizer").key("obstacle_margin");
            let m = optimizer.obstacle_margin;
            if !(m.is_finite() && (0.0..=MAX_OBSTACLE_SIZE).contains(&m)) {
                let msg = format!("must be between 0 and {MAX_OBSTACLE_SIZE} m, got {}", readable(m));
                return Err(src.error(&path, msg));
            }
            let collisions = base.optimizer.objectives.iter_mut().filter(|o| o.feature == "collision");
            if collisions.map(|o| o.obstacle_margin = Some(m)).count() == 0 {
                return Err(src.error(&path, "the base problem lists no collision objective"));
            }
        }
        let jitter = self.start.jitter;
        if !(jitter.is_finite() && (0.0..=MAX_JITTER).contains(&jitter)) {
            let msg = format!("must be between 0 and {MAX_JITTER} rad, got {}", readable(jitter));
            return Err(src.error(&root.key("start").key("jitter"), msg));
        }
        let range = |path: KeyPath, r: Option<Range2>| match r {
            Some([a, b]) if !(a.is_finite() && b.is_finite() && a <= b) => Err(src
                .error(&path, format!("must be [low, high] with low ≤ high, got [{}, {}]", readable(a), readable(b)))),
            Some([a, b]) if a.abs().max(b.abs()) > FAMILY_LIMIT => {
                Err(src
                    .error(&path, format!("must lie within ±{FAMILY_LIMIT}, got [{}, {}]", readable(a), readable(b))))
            }
            _ => Ok(r),
        };
        let mut objects = Vec::new();
        for (i, o) in self.objects.into_iter().enumerate() {
            let p = root.key("objects").index(i);
            if base.scene.object(&o.name).is_none() {
                return Err(src.error(&p.key("name"), format!("the base problem has no object '{}'", o.name)));
            }
            objects.push(ObjectDistribution {
                x: range(p.key("x"), o.x)?,
                y: range(p.key("y"), o.y)?,
                yaw: range(p.key("yaw"), o.yaw)?,
                object: o.name,
            });
        }
        let obstacles = match self.obstacles {
            Some(o) => Some(o.build(src)?),
            None => None,
        };
        Ok(ProblemFamily {
            name: self.name,
            description: self.description,
            base,
            start_jitter: jitter,
            objects,
            obstacles,
        })
    }
}

impl RawObstacleDistribution {
    fn build(self, src: &Source) -> Result<ObstacleDistribution, ProblemError> {
        let p = KeyPath::root().key("obstacles");
        if self.count[0] > self.count[1] || self.count[1] > 1000 {
            let [lo, hi] = self.count;
            return Err(
                src.error(&p.key("count"), format!("must be [min, max] with min ≤ max ≤ 1000, got [{lo}, {hi}]"))
            );
        }
        if self.shapes.is_empty() {
            return Err(src.error(&p.key("shapes"), "needs at least one shape"));
        }
        for (i, s) in self.shapes.iter().enumerate() {
            if !["box", "sphere", "cylinder", "capsule"].contains(&s.as_str()) {
                let msg = format!("unknown shape '{s}' (expected box, sphere, cylinder or capsule)");
                return Err(src.error(&p.key("shapes").index(i), msg));
            }
        }
        let [lo, hi] = self.size;
        if !(lo > 0.0 && lo <= hi && hi <= MAX_OBSTACLE_SIZE) {
            let (lo, hi) = (readable(lo), readable(hi));
            let msg = format!("must be [low, high] with 0 < low ≤ high ≤ {MAX_OBSTACLE_SIZE} m, got [{lo}, {hi}]");
            return Err(src.error(&p.key("size"), msg));
        }
        let (min, max) = (Vector3::from(self.region_min), Vector3::from(self.region_max));
        let within = |v: f64| v.is_finite() && v.abs() <= FAMILY_LIMIT;
        if let Some(i) = (0..3).find(|&i| !within(min[i])) {
            let msg = format!("must lie within ±{FAMILY_LIMIT} m, got {}", readable(min[i]));
            return Err(src.error(&p.key("region_min").index(i), msg));
        }
        if let Some(i) = (0..3).find(|&i| !within(max[i])) {
            let msg = format!("must lie within ±{FAMILY_LIMIT} m, got {}", readable(max[i]));
            return Err(src.error(&p.key("region_max").index(i), msg));
        }
        if let Some(i) = (0..3).find(|&i| min[i] > max[i]) {
            let msg = format!("must be ≥ region_min[{i}], got {} < {}", readable(max[i]), readable(min[i]));
            return Err(src.error(&p.key("region_max").index(i), msg));
        }
        if !(self.clearance.is_finite() && (0.0..=MAX_OBSTACLE_SIZE).contains(&self.clearance)) {
            let msg = format!("must be between 0 and {MAX_OBSTACLE_SIZE} m, got {}", readable(self.clearance));
            return Err(src.error(&p.key("clearance"), msg));
        }
        Ok(ObstacleDistribution {
            count: self.count,
            shapes: self.shapes,
            size: self.size,
            region: [min, max],
            clearance: self.clearance,
        })
    }
}
