//! RRT-Connect (Kuffner & LaValle 2000) in the active joint space: two
//! trees, one from the start and one from the goal set, grown towards
//! uniform samples and towards each other until they meet. Three additions
//! keep hard problems from a long tail of run times: the smaller tree is
//! the one that takes the next sample (balancing), a node whose extension
//! was blocked only takes samples near it (dynamic-domain sampling,
//! [`DynamicDomain`]), and one sample in ten is drawn near the other
//! tree's roots ([`RootBias`]), which leads a goal out of a pocket. On
//! MotionBenchMaker's 700 Panda problems the first two cut the mean
//! planning time several times over (docs/notes/planning.md).
//! [`rrt_connect_lazy`] certifies only the edges of a path found (lazy
//! certification, as in Lazy PRM, Bohlin & Kavraki 2000), cutting any
//! branch whose edge fails.

use super::nearest::NearestNeighbors;
use super::postprocess::distance;
use crate::collision::{CollisionModel, CollisionWorkspace, SimdLevel};
use crate::robot::{JointLimits, RobotError};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use std::time::{Duration, Instant};

use crate::problem::{DynamicDomain, PlannerSettings, RootBias};

/// How a straight joint-space motion is validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EdgeCheck {
    /// Configurations at most this far apart in every joint (rad or m) are
    /// checked; contacts thinner than that can slip between them.
    Resolution(f64),
    /// Every configuration of the motion keeps at least `clearance / 2`
    /// (m) between all pairs, and none sampled is closer than `clearance`
    /// ([`CollisionModel::motion_free_certified`]).
    Certified {
        /// Clearance (m): every configuration keeps half of it.
        clearance: f64,
    },
}

impl EdgeCheck {
    /// The check `settings` ask for: certified with their `clearance`
    /// when it is above 0, else sampled at their `resolution`.
    pub fn of(settings: &PlannerSettings) -> EdgeCheck {
        if settings.clearance > 0.0 {
            EdgeCheck::Certified { clearance: settings.clearance }
        } else {
            EdgeCheck::Resolution(settings.resolution)
        }
    }

    /// Whether the motion from `a` to `b` passes.
    ///
    /// # Errors
    /// Bad configurations or settings.
    pub fn is_free(
        self,
        model: &CollisionModel,
        ws: &mut CollisionWorkspace,
        a: &[f64],
        b: &[f64],
    ) -> Result<bool, RobotError> {
        match self {
            EdgeCheck::Resolution(r) => model.motion_free(ws, a, b, r),
            EdgeCheck::Certified { clearance } => model.motion_free_certified(ws, a, b, clearance),
        }
    }

    /// [`is_free`](Self::is_free) that gives up at `deadline` (`None`:
    /// the clock ran out before the answer).
    ///
    /// # Errors
    /// Bad configurations or settings.
    pub fn is_free_by(
        self,
        model: &CollisionModel,
        ws: &mut CollisionWorkspace,
        (a, b): (&[f64], &[f64]),
        deadline: Instant,
    ) -> Result<Option<bool>, RobotError> {
        match self {
            EdgeCheck::Resolution(r) => model.motion_free_by(ws, a, b, r, Some(deadline)),
            EdgeCheck::Certified { clearance } => model.motion_free_certified_by(ws, a, b, clearance, Some(deadline)),
        }
    }

    /// Whether configuration `q` may start or end a motion that passes:
    /// collision-free, and for certified motions at least the clearance
    /// away from everything.
    ///
    /// # Errors
    /// Bad configurations or settings.
    pub fn is_valid(self, model: &CollisionModel, ws: &mut CollisionWorkspace, q: &[f64]) -> Result<bool, RobotError> {
        match self {
            EdgeCheck::Resolution(_) => model.collision_free(ws, q),
            EdgeCheck::Certified { .. } => self.is_free(model, ws, q, q),
        }
    }
}

/// Why the planner stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanStatus {
    /// The trees met: the path is collision-free at the resolution.
    Solved,
    /// The time budget ran out.
    TimeLimit,
    /// The iteration budget ran out.
    IterationLimit,
    /// The start configuration collides, is closer to something than a
    /// certified edge check's clearance, or is outside the limits.
    StartInvalid,
    /// So does every goal configuration, or none was given.
    GoalInvalid,
}

impl PlanStatus {
    /// Lower-case name, as in JSON output.
    pub fn name(self) -> &'static str {
        match self {
            PlanStatus::Solved => "solved",
            PlanStatus::TimeLimit => "time_limit",
            PlanStatus::IterationLimit => "iteration_limit",
            PlanStatus::StartInvalid => "start_invalid",
            PlanStatus::GoalInvalid => "goal_invalid",
        }
    }
}

/// What [`rrt_connect`] found.
#[derive(Debug, Clone)]
pub struct PlanResult {
    /// Why the planner stopped.
    pub status: PlanStatus,
    /// Start to goal, each edge collision-free at the resolution; empty unless solved.
    pub path: Vec<Vec<f64>>,
    /// Extension rounds run (samples dynamic-domain sampling rejects are not counted).
    pub iterations: usize,
    /// Nodes in both trees (those cut included).
    pub nodes: usize,
    /// Nodes cut from the trees by lazy certification ([`rrt_connect_lazy`]):
    /// an edge on their branch failed; 0 for [`rrt_connect`].
    pub cut: usize,
    /// Wall-clock time of the search.
    pub time: Duration,
}

/// One tree: configurations and parent links (roots are their own parent).
struct Tree {
    nn: NearestNeighbors,
    parent: Vec<u32>,
    /// Whether each node's edge from its parent passed the edge check
    /// (roots: true); in a lazy search, edges are certified only once a
    /// path uses them.
    certified: Vec<bool>,
    /// Each node's dynamic-domain radius (infinite until an extension
    /// from it is blocked).
    radius: Vec<f64>,
    /// Samples rejected since this tree last extended.
    rejected: u32,
    /// Roots, the first nodes (the start, or the valid goals).
    roots: usize,
}

impl Tree {
    fn new(dim: usize, simd: SimdLevel) -> Tree {
        let nn = NearestNeighbors::new(dim, simd);
        Tree { nn, parent: Vec::new(), certified: Vec::new(), radius: Vec::new(), rejected: 0, roots: 0 }
    }

    /// Nodes not cut (a cut node is removed from the nearest-neighbour
    /// answers, which keep the count).
    fn len(&self) -> usize {
        self.nn.alive()
    }

    /// Adds `q` below `parent` (a root without one), its edge certified or not.
    fn add(&mut self, q: &[f64], parent: Option<usize>, certified: bool) -> usize {
        let i = self.nn.insert(q);
        self.parent.push(parent.unwrap_or(i) as u32);
        self.certified.push(certified || parent.is_none());
        self.roots += usize::from(parent.is_none());
        self.radius.push(f64::INFINITY);
        i
    }

    /// Cuts node `i` and every node grown from it (children come after
    /// their parents).
    fn cut_branch(&mut self, i: usize) {
        for k in i..self.parent.len() {
            if k == i || self.nn.is_removed(self.parent[k] as usize) {
                self.nn.remove(k);
            }
        }
    }

    /// Nodes from `i` up to its root.
    fn lineage(&self, mut i: usize) -> impl Iterator<Item = usize> + '_ {
        let mut done = false;
        std::iter::from_fn(move || {
            if done {
                return None;
            }
            let here = i;
            done = self.parent[i] as usize == i;
            i = self.parent[i] as usize;
            Some(here)
        })
    }

    /// Adapts node `i`'s sampling radius after an extension from it.
    fn adapt(&mut self, i: usize, blocked: bool, domain: &DynamicDomain) {
        let r = &mut self.radius[i];
        if blocked {
            *r = if r.is_finite() { (*r * (1.0 - domain.rate)).max(domain.min_radius) } else { domain.radius };
        } else if r.is_finite() {
            *r *= 1.0 + domain.rate;
        }
    }

    /// Configurations from node `i` up to its root.
    fn branch(&self, i: usize) -> Vec<Vec<f64>> {
        self.lineage(i).map(|k| self.nn.point(k).to_vec()).collect()
    }
}

enum Extension {
    Reached(usize),
    Advanced(usize),
    Trapped,
    /// The time budget ran out during the edge check.
    OutOfTime,
}

/// A lazy search ([`rrt_connect_lazy`]): the trees grow on discrete edge
/// checks of a model whose shapes are padded by the clearance, and only
/// the edges of a path found are certified.
pub struct LazySearch<'a> {
    /// The model's shapes padded by the certified edge check's clearance
    /// (m), as [`crate::problem::Problem::collision_model_padded`] builds.
    pub padded: &'a CollisionModel,
    /// A workspace of `padded`.
    pub ws: &'a mut CollisionWorkspace,
    /// Largest joint move between the configurations checked along a
    /// searched edge (rad or m).
    pub resolution: f64,
}

struct Planner<'a> {
    model: &'a CollisionModel,
    ws: &'a mut CollisionWorkspace,
    settings: &'a PlannerSettings,
    /// The edge check of the settings ([`EdgeCheck::of`]).
    edge: EdgeCheck,
    lazy: Option<LazySearch<'a>>,
    scratch: Vec<f64>,
    deadline: Instant,
    /// The settings' dynamic domain, its radius scaled to this robot's
    /// joints ([`DynamicDomain::radius_for`]).
    domain: Option<DynamicDomain>,
}

impl Planner<'_> {
    /// One step of `tree` from its node nearest to `target` towards it;
    /// `None` when dynamic-domain sampling rejects `target` (too far from
    /// that node's domain; never when `anyway`).
    fn extend(&mut self, tree: &mut Tree, target: &[f64], anyway: bool) -> Result<Option<Extension>, RobotError> {
        let near = tree.nn.nearest(target).expect("trees are never empty");
        let Some(domain) = self.domain else { return self.step(tree, near, target).map(Some) };
        let outside = distance(tree.nn.point(near), target) > tree.radius[near];
        if outside && !anyway && tree.rejected < domain.max_rejections {
            tree.rejected += 1;
            return Ok(None);
        }
        tree.rejected = 0;
        let extension = self.step(tree, near, target)?;
        tree.adapt(near, matches!(extension, Extension::Trapped), &domain);
        Ok(Some(extension))
    }

    /// One step of `tree` from node `near` towards `target`.
    fn step(&mut self, tree: &mut Tree, near: usize, target: &[f64]) -> Result<Extension, RobotError> {
        let from = tree.nn.point(near);
        let dist = distance(from, target);
        let reached = dist <= self.settings.step;
        let t = if reached { 1.0 } else { self.settings.step / dist };
        self.scratch.clear();
        self.scratch.extend(from.iter().zip(target).map(|(a, b)| a + (b - a) * t));
        match self.step_free(from)? {
            None => return Ok(Extension::OutOfTime),
            Some(false) => return Ok(Extension::Trapped),
            Some(true) => {}
        }
        let new = tree.add(&self.scratch, Some(near), self.lazy.is_none());
        Ok(if reached { Extension::Reached(new) } else { Extension::Advanced(new) })
    }

    /// Whether the motion from tree node `from` to the step's end in
    /// `scratch` passes (`None`: out of time). A sampled check leaves out
    /// `from`, which passed when it joined the tree
    /// ([`CollisionModel::extension_free_by`]).
    fn step_free(&mut self, from: &[f64]) -> Result<Option<bool>, RobotError> {
        let motion = (from, self.scratch.as_slice());
        let deadline = Some(self.deadline);
        match (&mut self.lazy, self.edge) {
            (Some(lazy), _) => lazy.padded.extension_free_by(lazy.ws, motion, lazy.resolution, deadline),
            (None, EdgeCheck::Resolution(r)) => self.model.extension_free_by(self.ws, motion, r, deadline),
            (None, edge) => edge.is_free_by(self.model, self.ws, motion, self.deadline),
        }
    }

    /// Certifies the edges not yet certified from node `i` up to its root,
    /// root side first: `Some(false)` when one fails (its branch is then
    /// cut from the tree), `None` when the time budget ran out.
    fn certify_branch(&mut self, tree: &mut Tree, i: usize) -> Result<Option<bool>, RobotError> {
        let mut todo: Vec<usize> = tree.lineage(i).filter(|&k| !tree.certified[k]).collect();
        todo.reverse();
        for k in todo {
            let (from, to) = (tree.nn.point(tree.parent[k] as usize), tree.nn.point(k));
            match self.edge.is_free_by(self.model, self.ws, (from, to), self.deadline)? {
                None => return Ok(None),
                Some(false) => {
                    tree.cut_branch(k);
                    return Ok(Some(false));
                }
                Some(true) => tree.certified[k] = true,
            }
        }
        Ok(Some(true))
    }

    /// Extends `tree` towards `target` until it reaches it or is blocked:
    /// from its node nearest to `target`, step after step along the
    /// straight line (each new node is where the next step starts; a
    /// nearest-neighbour query per step would cost more than it finds).
    fn connect(&mut self, tree: &mut Tree, target: &[f64]) -> Result<Extension, RobotError> {
        let mut near = tree.nn.nearest(target).expect("trees are never empty");
        loop {
            match self.step(tree, near, target)? {
                Extension::Advanced(i) => near = i,
                other => return Ok(other),
            }
        }
    }
}

/// Plans a collision-free joint-space path from `start` to any of
/// `goals`. Same seed, same inputs: same path.
///
/// # Errors
/// Configurations of the wrong length or with non-finite values;
/// settings out of range ([`PlannerSettings::validate`]).
pub fn rrt_connect(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    start: &[f64],
    goals: &[Vec<f64>],
    settings: &PlannerSettings,
) -> Result<PlanResult, RobotError> {
    search(model, ws, None, start, goals, settings)
}

/// [`rrt_connect`] with lazy certification: the trees grow on the cheap
/// discrete checks of [`LazySearch`], and when they meet, the edges of
/// the path are checked with the settings' edge check ([`EdgeCheck::of`])
/// (root side first, each edge once); an edge that fails is cut from its
/// tree with every node grown from it, and the search goes on. The path's
/// edges pass the settings' edge check, as [`rrt_connect`]'s do, while the
/// edges of branches no path takes, which on MotionBenchMaker-style
/// problems are most of what an eager search certifies, are never
/// certified (docs/notes/planning.md).
///
/// # Errors
/// Configurations of the wrong length or with non-finite values, a
/// resolution below [`crate::collision::MIN_RESOLUTION`], settings out of
/// range ([`PlannerSettings::validate`]).
pub fn rrt_connect_lazy(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    lazy: LazySearch<'_>,
    start: &[f64],
    goals: &[Vec<f64>],
    settings: &PlannerSettings,
) -> Result<PlanResult, RobotError> {
    search(model, ws, Some(lazy), start, goals, settings)
}

fn search(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    lazy: Option<LazySearch<'_>>,
    start: &[f64],
    goals: &[Vec<f64>],
    settings: &PlannerSettings,
) -> Result<PlanResult, RobotError> {
    settings.validate()?;
    let edge = EdgeCheck::of(settings);
    let began = Instant::now();
    let robot = model.robot();
    let done = |status, path, iterations, (nodes, cut)| PlanResult {
        status,
        path,
        iterations,
        nodes,
        cut,
        time: began.elapsed(),
    };
    if !robot.within_limits(start) || !edge.is_valid(model, ws, start)? {
        return Ok(done(PlanStatus::StartInvalid, Vec::new(), 0, (0, 0)));
    }
    let dim = robot.nq();
    // Nearest-neighbour scans at the collision checks' level (so
    // `TANDEM_SIMD` and `set_simd` govern both).
    let simd = model.simd().unwrap_or_else(|| SimdLevel::best_up_to(SimdLevel::from_environment()));
    let (mut a, mut b) = (Tree::new(dim, simd), Tree::new(dim, simd));
    a.add(start, None, true);
    for g in goals {
        if robot.within_limits(g) && edge.is_valid(model, ws, g)? {
            b.add(g, None, true);
        }
    }
    if b.parent.is_empty() {
        return Ok(done(PlanStatus::GoalInvalid, Vec::new(), 0, (1, 0)));
    }
    // Xoshiro256++: the search draws a sample per round and per rejection
    // (14 values a draw on a dual arm); ChaCha8 with a uniform range per
    // value took 6.0 % of the Baxter's `shelf` instructions, this 2.7 %.
    // Also keeps the stream apart from the IK's, which may get the seed.
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(settings.seed);
    let limits = robot.limits().to_vec();
    // Far budgets (beyond what an Instant holds) never run out.
    let time_limit = Duration::try_from_secs_f64(settings.time_limit).unwrap_or(Duration::MAX);
    let deadline = began.checked_add(time_limit).unwrap_or(began + Duration::from_secs(1 << 40));
    let domain = settings.dynamic_domain.map(|d| DynamicDomain { radius: d.radius_for(dim), ..d });
    let scratch = Vec::with_capacity(dim);
    let mut planner = Planner { model, ws, settings, edge, lazy, scratch, deadline, domain };
    let mut sample = vec![0.0; dim];
    // Tree `a` holds the start when `a_is_start`.
    let mut a_is_start = true;
    let (mut iteration, mut draws) = (0, 0usize);
    while iteration < settings.max_iterations {
        draws += 1;
        if draws % 32 == 0 && began.elapsed() > time_limit {
            return Ok(done(PlanStatus::TimeLimit, Vec::new(), iteration, counts(&a, &b)));
        }
        let near_root = draw_sample(&mut rng, &limits, settings.root_bias, &b, &mut sample);
        let Some(extension) = planner.extend(&mut a, &sample, near_root)? else {
            // Outside the nearest node's domain: draw again for this tree.
            continue;
        };
        iteration += 1;
        let out_of_time = |a: &Tree, b: &Tree| done(PlanStatus::TimeLimit, Vec::new(), iteration, counts(a, b));
        let new = match extension {
            Extension::Trapped => None,
            Extension::OutOfTime => return Ok(out_of_time(&a, &b)),
            Extension::Reached(i) | Extension::Advanced(i) => Some(i),
        };
        if let Some(i) = new {
            let q_new = a.nn.point(i).to_vec();
            match planner.connect(&mut b, &q_new)? {
                Extension::Reached(j) => match certified(&mut planner, &mut a, i, &mut b, j)? {
                    Some(true) => {
                        let (from_a, from_b) = (a.branch(i), b.branch(j));
                        let path = join(from_a, from_b, a_is_start);
                        let nodes = counts(&a, &b);
                        return Ok(done(PlanStatus::Solved, path, iteration, nodes));
                    }
                    // An edge failed: its branch is cut, the search goes on.
                    Some(false) => {}
                    None => return Ok(out_of_time(&a, &b)),
                },
                Extension::OutOfTime => return Ok(out_of_time(&a, &b)),
                Extension::Trapped | Extension::Advanced(_) => {}
            }
        }
        // Balanced: the smaller tree extends next (ties alternate).
        if !settings.balance || b.len() <= a.len() {
            std::mem::swap(&mut a, &mut b);
            a_is_start = !a_is_start;
        }
    }
    Ok(done(PlanStatus::IterationLimit, Vec::new(), settings.max_iterations, counts(&a, &b)))
}

/// Draws a sample into `sample` (a round may take several draws, as the
/// dynamic domain rejects uniform ones): with the bias's probability near
/// one of `other`'s roots (then `true`: the tree extends towards it
/// whatever its dynamic domain), else uniform within `limits`.
fn draw_sample(
    rng: &mut Xoshiro256PlusPlus,
    limits: &[JointLimits],
    bias: Option<RootBias>,
    other: &Tree,
    sample: &mut [f64],
) -> bool {
    if let Some(bias) = bias
        && rng.random::<f64>() < bias.probability
    {
        // Roots are the first nodes, never cut.
        let root = other.nn.point((rng.random::<f64>() * other.roots as f64) as usize % other.roots);
        for ((s, l), r) in sample.iter_mut().zip(limits).zip(root) {
            *s = (r + bias.spread * (2.0 * rng.random::<f64>() - 1.0)).clamp(l.lower, l.upper);
        }
        return true;
    }
    for (s, l) in sample.iter_mut().zip(limits) {
        // Within [lower, upper] (upper only by rounding): one multiply-add,
        // without the range checks and rejection loop of a uniform
        // distribution built per value.
        *s = l.lower + (l.upper - l.lower) * rng.random::<f64>();
    }
    false
}

/// Nodes in both trees, and of them those cut.
fn counts(a: &Tree, b: &Tree) -> (usize, usize) {
    let nodes = a.parent.len() + b.parent.len();
    (nodes, nodes - a.len() - b.len())
}

/// Whether the edges from node `i` of `a` and node `j` of `b` to their
/// roots all pass (always, unless the search is lazy); `None` when the
/// time ran out.
fn certified(
    planner: &mut Planner,
    a: &mut Tree,
    i: usize,
    b: &mut Tree,
    j: usize,
) -> Result<Option<bool>, RobotError> {
    if planner.lazy.is_none() {
        return Ok(Some(true));
    }
    Ok(match planner.certify_branch(a, i)? {
        Some(true) => planner.certify_branch(b, j)?,
        other => other,
    })
}

/// The start-to-goal path from two branches that end at the same
/// configuration (each listed from the meeting node to its root).
fn join(mut from_a: Vec<Vec<f64>>, mut from_b: Vec<Vec<f64>>, a_is_start: bool) -> Vec<Vec<f64>> {
    if !a_is_start {
        std::mem::swap(&mut from_a, &mut from_b);
    }
    // from_a: meeting → start; from_b: meeting → goal (both include the meeting point).
    from_a.reverse();
    from_a.extend(from_b.into_iter().skip(1));
    from_a
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> Vec<JointLimits> {
        let joint = |lower, upper| JointLimits { lower, upper, velocity: 1.0, effort: 1.0 };
        vec![joint(-2.9, 2.9), joint(-1.8, 1.8), joint(0.0, 0.35)]
    }

    /// Biased samples lie within the spread of one of the other tree's
    /// roots and within the limits, and come in the bias's share of draws;
    /// without a bias every sample is uniform within the limits.
    #[test]
    fn root_bias_draws_near_the_other_trees_roots() {
        let limits = limits();
        let mut other = Tree::new(3, SimdLevel::Baseline);
        let roots = [[2.5, 0.0, 0.3], [-2.0, 1.0, 0.0]];
        for r in &roots {
            other.add(r, None, true);
        }
        other.add(&[0.0, 0.0, 0.1], Some(0), false);
        let bias = RootBias { probability: 0.25, spread: 0.5 };
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let mut sample = [0.0; 3];
        let (mut near, mut by_root, draws) = (0, [0; 2], 20_000);
        for _ in 0..draws {
            let biased = draw_sample(&mut rng, &limits, Some(bias), &other, &mut sample);
            assert!(sample.iter().zip(&limits).all(|(s, l)| l.contains(*s)), "{sample:?}");
            if biased {
                near += 1;
                let root = roots.iter().position(|r| r.iter().zip(&sample).all(|(r, s)| (r - s).abs() <= 0.5));
                by_root[root.expect("a biased sample lies within the spread of a root")] += 1;
            }
        }
        let share = near as f64 / draws as f64;
        assert!((share - 0.25).abs() < 0.01, "{share}");
        assert!(by_root.iter().all(|&n| (n as f64 / near as f64 - 0.5).abs() < 0.02), "{by_root:?}");
        let mut spans = [(f64::INFINITY, f64::NEG_INFINITY); 3];
        for _ in 0..draws {
            assert!(!draw_sample(&mut rng, &limits, None, &other, &mut sample));
            for (span, s) in spans.iter_mut().zip(sample) {
                *span = (span.0.min(s), span.1.max(s));
            }
        }
        for (span, l) in spans.iter().zip(&limits) {
            assert!(span.0 >= l.lower && span.1 <= l.upper);
            assert!(span.1 - span.0 > 0.99 * (l.upper - l.lower), "uniform over the range: {span:?}");
        }
    }
}
