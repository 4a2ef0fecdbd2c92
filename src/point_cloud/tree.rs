//! A k-d tree over a cloud's points for the queries collision checking
//! asks of it: is any point closer than a distance to a query point, which
//! point is nearest (within a cap), and which is nearest to a convex shape
//! given only a bound on how far the shape reaches from its centre.
//!
//! Like the collision-affording point trees of Ramsey et al. (RSS 2024,
//! the CAPT behind VAMP), the tree is built once per cloud and only read
//! afterwards, its points are stored coordinate by coordinate in leaves of
//! a few points so that the innermost loop is a straight run over arrays,
//! and a query that misses descends one path. Unlike CAPT it answers
//! exact nearest distances at any range (the optimizer's collision
//! feature and the arbiter's distance rows need them), not only "within
//! the largest radius fixed at build time". Queries allocate nothing; a
//! query point with a NaN coordinate is never "free".

use std::cell::Cell;

/// Points per leaf, at most.
const LEAF: usize = 8;
/// Deepest tree a query walks: a balanced tree with 8-point leaves
/// reaches it only past 2⁵⁸ points.
const DEPTH: usize = 64;

/// A node: the tight box around its points, and either its points
/// (`right == 0`: a leaf holding `start..end` of the reordered points) or
/// its two children (the left one follows it, the right one is `right`).
#[derive(Debug, Clone)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    start: u32,
    end: u32,
    right: u32,
}

/// A static k-d tree over points (m, in the cloud's frame); the
/// [`crate::point_cloud`] module says how it is built and queried.
#[derive(Debug, Clone, Default)]
pub struct PointTree {
    /// Coordinates of the points in tree order.
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// Each tree-order point's index in the input.
    index: Vec<u32>,
    nodes: Vec<Node>,
    /// Largest distance of a point from the origin (m).
    reach: f64,
}

/// Squared distance from `p` to the box `lo..hi` (0 inside).
#[inline(always)]
fn box_distance_squared(p: &[f64; 3], lo: &[f64; 3], hi: &[f64; 3]) -> f64 {
    let mut d2 = 0.0;
    for i in 0..3 {
        let d = (lo[i] - p[i]).max(p[i] - hi[i]).max(0.0);
        d2 += d * d;
    }
    d2
}

impl PointTree {
    /// Builds the tree over `points` (m). Points with a non-finite
    /// coordinate are left out (a [`PointCloud`](super::PointCloud) has
    /// none); [`point`](Self::point) gives each point's index in `points`.
    ///
    /// # Panics
    /// More than `u32::MAX` points.
    pub fn new(points: &[[f64; 3]]) -> PointTree {
        assert!(points.len() <= u32::MAX as usize, "a point tree holds at most 2³² − 1 points");
        let mut order: Vec<u32> =
            (0..points.len() as u32).filter(|&i| points[i as usize].iter().all(|c| c.is_finite())).collect();
        let mut tree = PointTree::default();
        if order.is_empty() {
            return tree;
        }
        tree.nodes.reserve(2 * order.len() / LEAF + 1);
        tree.split(points, &mut order, 0);
        tree.x = order.iter().map(|&i| points[i as usize][0]).collect();
        tree.y = order.iter().map(|&i| points[i as usize][1]).collect();
        tree.z = order.iter().map(|&i| points[i as usize][2]).collect();
        tree.index = order;
        tree.reach = tree.points().map(|(p, _)| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()).fold(0.0, f64::max);
        tree
    }

    /// Adds the node over `order` (which starts at `offset` of the tree
    /// order), splitting at the median of its box's longest side.
    fn split(&mut self, points: &[[f64; 3]], order: &mut [u32], offset: usize) {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &i in order.iter() {
            let p = &points[i as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let at = self.nodes.len();
        let (start, end) = (offset as u32, (offset + order.len()) as u32);
        self.nodes.push(Node { lo, hi, start, end, right: 0 });
        if order.len() <= LEAF {
            return;
        }
        let axis = (0..3).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).unwrap_or(0);
        let half = order.len() / 2;
        // Ties broken by index: the same points give the same tree.
        order.select_nth_unstable_by(half, |&a, &b| {
            points[a as usize][axis].total_cmp(&points[b as usize][axis]).then(a.cmp(&b))
        });
        let (left, right) = order.split_at_mut(half);
        self.split(points, left, offset);
        self.nodes[at].right = self.nodes.len() as u32;
        self.split(points, right, offset + half);
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// True when the tree holds no point.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Largest distance of a point from the origin of the cloud's frame
    /// (m; 0 when empty).
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// The box around every point (m), `None` when empty.
    pub fn bounds(&self) -> Option<([f64; 3], [f64; 3])> {
        self.nodes.first().map(|n| (n.lo, n.hi))
    }

    /// The `k`-th point in tree order (m) and its input index (`k <
    /// len()`).
    pub fn point(&self, k: usize) -> ([f64; 3], usize) {
        ([self.x[k], self.y[k], self.z[k]], self.index[k] as usize)
    }

    /// Every point (m) with its input index, in tree order.
    pub fn points(&self) -> impl ExactSizeIterator<Item = ([f64; 3], usize)> + '_ {
        (0..self.len()).map(|k| self.point(k))
    }

    /// Walks the tree from the root, entering a node only when `enter`
    /// (given its squared box distance to `p`) says so, nearer child
    /// first, and handing each leaf's tree-order range to `leaf`, which
    /// returns true to stop the walk. Returns whether it was stopped.
    #[inline(always)]
    fn walk(
        &self,
        p: &[f64; 3],
        mut enter: impl FnMut(f64) -> bool,
        mut leaf: impl FnMut(usize, usize) -> bool,
    ) -> bool {
        let Some(root) = self.nodes.first() else { return false };
        let mut stack = [(0u32, 0.0f64); DEPTH];
        let mut top = 0;
        if !enter(box_distance_squared(p, &root.lo, &root.hi)) {
            return false;
        }
        stack[0] = (0, 0.0);
        top += 1;
        while top > 0 {
            top -= 1;
            let (n, d2) = stack[top];
            // The bound may have tightened since the node was pushed.
            if n != 0 && !enter(d2) {
                continue;
            }
            let node = &self.nodes[n as usize];
            if node.right == 0 {
                if leaf(node.start as usize, node.end as usize) {
                    return true;
                }
                continue;
            }
            let (a, b) = (n + 1, node.right);
            let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
            let (da, db) = (box_distance_squared(p, &na.lo, &na.hi), box_distance_squared(p, &nb.lo, &nb.hi));
            let (near, far) = if da <= db { ((a, da), (b, db)) } else { ((b, db), (a, da)) };
            // Farther child below, so the nearer is taken first.
            for (child, d2) in [far, near] {
                debug_assert!(top < DEPTH, "a point tree deeper than {DEPTH}");
                if enter(d2) && top < DEPTH {
                    stack[top] = (child, d2);
                    top += 1;
                }
            }
        }
        false
    }

    /// True when some point lies closer than `distance` (m) to `p` (all
    /// of its coordinates in the cloud's frame); true for a `p` or a
    /// `distance` with a NaN.
    pub fn any_closer(&self, p: &[f64; 3], distance: f64) -> bool {
        if p.iter().any(|c| c.is_nan()) || distance.is_nan() {
            return !self.is_empty();
        }
        if distance <= 0.0 {
            return false;
        }
        let limit = distance * distance;
        self.walk(
            p,
            |d2| d2 < limit,
            |start, end| {
                let mut hit = false;
                for k in start..end {
                    let (dx, dy, dz) = (self.x[k] - p[0], self.y[k] - p[1], self.z[k] - p[2]);
                    hit |= dx * dx + dy * dy + dz * dz < limit;
                }
                hit
            },
        )
    }

    /// The point nearest `p` among those closer than `cap` (m; pass
    /// `f64::INFINITY` for the nearest of all): its squared distance (m²)
    /// and place in tree order (see [`point`](Self::point)), `None` when
    /// there is none. A `p` with a NaN
    /// coordinate gets `Some((NaN, ·))` from a non-empty tree.
    pub fn nearest(&self, p: &[f64; 3], cap: f64) -> Option<(f64, usize)> {
        if p.iter().any(|c| c.is_nan()) {
            return (!self.is_empty()).then_some((f64::NAN, 0));
        }
        // Shared by the walk's two closures.
        let best = Cell::new((cap * cap, usize::MAX));
        self.walk(
            p,
            |d2| d2 < best.get().0,
            |start, end| {
                let mut b = best.get();
                for k in start..end {
                    let (dx, dy, dz) = (self.x[k] - p[0], self.y[k] - p[1], self.z[k] - p[2]);
                    let d2 = dx * dx + dy * dy + dz * dz;
                    if d2 < b.0 {
                        b = (d2, k);
                    }
                }
                best.set(b);
                false
            },
        );
        let best = best.get();
        (best.1 != usize::MAX).then_some(best)
    }

    /// The point nearest a shape whose points all lie within `reach` (m)
    /// of `center`, among those `distance` says are closer than `cap`:
    /// `distance(point)` (m, the shape's exact distance to a point) and
    /// the point's place in tree order; `None` when no point is closer than `cap`.
    /// Points farther than `cap + reach` from `center` are never handed to
    /// `distance`. A `center` with a NaN coordinate gets `Some((NaN, ·))`.
    pub fn nearest_to(
        &self,
        center: &[f64; 3],
        reach: f64,
        cap: f64,
        mut distance: impl FnMut([f64; 3]) -> f64,
    ) -> Option<(f64, usize)> {
        if center.iter().any(|c| c.is_nan()) {
            return (!self.is_empty()).then_some((f64::NAN, 0));
        }
        let best = Cell::new((cap, usize::MAX));
        // A point at |p − center| = ρ is at least ρ − reach from the shape.
        let within = |d2: f64, best: f64| d2 < (best + reach).max(0.0).powi(2);
        self.walk(
            center,
            |d2| within(d2, best.get().0),
            |start, end| {
                for k in start..end {
                    let p = [self.x[k], self.y[k], self.z[k]];
                    let (dx, dy, dz) = (p[0] - center[0], p[1] - center[1], p[2] - center[2]);
                    if !within(dx * dx + dy * dy + dz * dz, best.get().0) {
                        continue;
                    }
                    let d = distance(p);
                    if d < best.get().0 || d.is_nan() {
                        best.set((d, k));
                    }
                }
                false
            },
        );
        let best = best.get();
        (best.1 != usize::MAX).then_some(best)
    }

    /// Calls `visit` with every point within `reach + margin` (m) of
    /// `center` (and maybe some a little farther) until it returns true;
    /// returns whether it did. For a shape within `reach` of `center`, the
    /// points it may come closer to than `margin`.
    pub fn any_near(
        &self,
        center: &[f64; 3],
        reach: f64,
        margin: f64,
        mut visit: impl FnMut([f64; 3]) -> bool,
    ) -> bool {
        if center.iter().any(|c| c.is_nan()) {
            return !self.is_empty();
        }
        let limit = (reach + margin).max(0.0).powi(2);
        self.walk(
            center,
            |d2| d2 <= limit,
            |start, end| {
                (start..end).any(|k| {
                    let p = [self.x[k], self.y[k], self.z[k]];
                    let (dx, dy, dz) = (p[0] - center[0], p[1] - center[1], p[2] - center[2]);
                    dx * dx + dy * dy + dz * dz <= limit && visit(p)
                })
            },
        )
    }
}
