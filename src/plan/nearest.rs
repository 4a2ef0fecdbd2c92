//! Nearest-neighbour search over a growing set of configurations: an
//! incremental k-d tree (split axis cycling with depth). RRT inserts points
//! in random order, which keeps such a tree balanced in expectation, so
//! queries stay logarithmic-ish to 100k nodes without rebuilding. Smaller
//! sets (the trees of most problems) are scanned linearly instead, [`BLOCK`]
//! points at a time from a copy stored coordinate by coordinate: in 7
//! dimensions the tree search visits most nodes of a few hundred anyway,
//! at many times the cost per node.

use crate::collision::SimdLevel;

/// Points a block of the linear scan holds.
const BLOCK: usize = 8;

/// Sets of at most this many points are scanned linearly.
const LINEAR_SCAN: usize = 512;

/// Points of dimension `dim`, stored flat, with a k-d tree over them.
#[derive(Debug, Clone)]
pub(crate) struct NearestNeighbors {
    dim: usize,
    points: Vec<f64>,
    /// The points again, block by block, coordinate by coordinate inside a
    /// block: coordinate `k` of point `BLOCK · b + l` at `(b · dim + k) ·
    /// BLOCK + l`. Slots past the last point hold infinity.
    blocks: Vec<f64>,
    /// Children of each node (u32::MAX: none).
    left: Vec<u32>,
    right: Vec<u32>,
    /// Points removed: never the answer of a query (the k-d tree still
    /// routes through them).
    removed: Vec<bool>,
    /// Points not removed.
    alive: usize,
    /// Explicit stack of the search, kept to avoid allocating per query.
    stack: Vec<(u32, u32, f64)>,
    /// The linear scan runs compiled for AVX2 (four coordinates per
    /// instruction instead of two).
    avx2: bool,
}

const NONE: u32 = u32::MAX;

impl NearestNeighbors {
    /// An empty set of `dim`-dimensional points whose linear scan runs at
    /// `simd` (AVX2 from [`SimdLevel::Avx2`] up, when the CPU runs it).
    pub(crate) fn new(dim: usize, simd: SimdLevel) -> Self {
        NearestNeighbors {
            dim,
            points: Vec::new(),
            blocks: Vec::new(),
            left: Vec::new(),
            right: Vec::new(),
            removed: Vec::new(),
            alive: 0,
            stack: Vec::new(),
            avx2: simd >= SimdLevel::Avx2 && SimdLevel::Avx2.is_available(),
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.left.len()
    }

    /// Points not removed.
    pub(crate) fn alive(&self) -> usize {
        self.alive
    }

    /// Whether point `i` was removed.
    pub(crate) fn is_removed(&self, i: usize) -> bool {
        self.removed[i]
    }

    pub(crate) fn point(&self, i: usize) -> &[f64] {
        &self.points[i * self.dim..(i + 1) * self.dim]
    }

    /// Adds `p`; returns its index.
    pub(crate) fn insert(&mut self, p: &[f64]) -> usize {
        let index = self.len() as u32;
        self.points.extend_from_slice(p);
        let (block, lane) = (index as usize / BLOCK, index as usize % BLOCK);
        if lane == 0 {
            self.blocks.resize((block + 1) * self.dim * BLOCK, f64::INFINITY);
        }
        for (k, &v) in p.iter().enumerate() {
            self.blocks[(block * self.dim + k) * BLOCK + lane] = v;
        }
        self.left.push(NONE);
        self.right.push(NONE);
        self.removed.push(false);
        self.alive += 1;
        if index == 0 {
            return 0;
        }
        let (mut node, mut depth) = (0u32, 0usize);
        loop {
            let axis = depth % self.dim;
            let goes_left = p[axis] < self.points[node as usize * self.dim + axis];
            let child = if goes_left { &mut self.left[node as usize] } else { &mut self.right[node as usize] };
            if *child == NONE {
                *child = index;
                return index as usize;
            }
            node = *child;
            depth += 1;
        }
    }

    /// Removes point `i` from the answers of later queries (its index
    /// stays taken).
    pub(crate) fn remove(&mut self, i: usize) {
        if std::mem::replace(&mut self.removed[i], true) {
            return;
        }
        self.alive -= 1;
        let (block, lane) = (i / BLOCK, i % BLOCK);
        for k in 0..self.dim {
            // Infinitely far: the linear scan never picks it.
            self.blocks[(block * self.dim + k) * BLOCK + lane] = f64::INFINITY;
        }
    }

    /// Index of the point nearest to `q` (Euclidean) among those not
    /// removed; `None` when there is none.
    pub(crate) fn nearest(&mut self, q: &[f64]) -> Option<usize> {
        if self.alive == 0 {
            return None;
        }
        if self.len() <= LINEAR_SCAN {
            return Some(self.scan(q));
        }
        let (mut best, mut best_d2) = (0usize, f64::INFINITY);
        self.stack.clear();
        // (node, depth, squared distance from q to the node's half-space).
        self.stack.push((0, 0, 0.0));
        while let Some((node, depth, bound)) = self.stack.pop() {
            if bound >= best_d2 {
                continue;
            }
            let n = node as usize;
            let p = &self.points[n * self.dim..(n + 1) * self.dim];
            let d2: f64 = p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            if d2 < best_d2 && !self.removed[n] {
                (best, best_d2) = (n, d2);
            }
            let axis = depth as usize % self.dim;
            let diff = q[axis] - p[axis];
            let (near, far) = if diff < 0.0 { (self.left[n], self.right[n]) } else { (self.right[n], self.left[n]) };
            // Far side first on the stack, so the near side is searched first.
            if far != NONE {
                self.stack.push((far, depth + 1, bound.max(diff * diff)));
            }
            if near != NONE {
                self.stack.push((near, depth + 1, bound));
            }
        }
        Some(best)
    }

    /// Index of the point nearest to `q` by a linear scan (the first of
    /// equally near ones).
    fn scan(&self, q: &[f64]) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only from a level the CPU runs (AVX2 and FMA).
            return unsafe { self.scan_avx2(q) };
        }
        self.scan_portable(q)
    }

    /// [`scan`](Self::scan) compiled for AVX2. Without FMA: the same
    /// operations in the same order as the portable scan, so the same
    /// answers bit for bit (and the same paths) on every CPU. On the
    /// Baxter's `shelf`, nearest-neighbour queries are 7-13 % of the
    /// instructions, most of them for samples dynamic-domain sampling
    /// rejects.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn scan_avx2(&self, q: &[f64]) -> usize {
        self.scan_portable(q)
    }

    #[inline(always)]
    fn scan_portable(&self, q: &[f64]) -> usize {
        let (mut best, mut best_d2) = (0usize, f64::INFINITY);
        for (b, block) in self.blocks.chunks_exact(self.dim * BLOCK).enumerate() {
            let mut d2 = [0.0; BLOCK];
            for (coordinates, &v) in block.chunks_exact(BLOCK).zip(q) {
                for l in 0..BLOCK {
                    let d = coordinates[l] - v;
                    d2[l] += d * d;
                }
            }
            for (l, &d) in d2.iter().enumerate() {
                if d < best_d2 {
                    (best, best_d2) = (b * BLOCK + l, d);
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Removed points are never the answer, in the linear scan and in
    /// the k-d tree (which still routes through them).
    #[test]
    fn removed_points_are_skipped() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for count in [40, 2000] {
            let mut nn = NearestNeighbors::new(7, SimdLevel::best_up_to(None));
            let all: Vec<Vec<f64>> =
                (0..count).map(|_| (0..7).map(|_| rng.random_range(-3.0..3.0)).collect()).collect();
            for p in &all {
                nn.insert(p);
            }
            let removed: Vec<bool> = (0..count).map(|i| i % 3 != 0).collect();
            for i in (0..count).filter(|&i| removed[i]) {
                nn.remove(i);
                nn.remove(i);
            }
            for _ in 0..200 {
                let q: Vec<f64> = (0..7).map(|_| rng.random_range(-3.5..3.5)).collect();
                let d2 = |p: &Vec<f64>| p.iter().zip(&q).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
                let kept = (0..count).filter(|&i| !removed[i]);
                let best = kept.min_by(|&a, &b| d2(&all[a]).total_cmp(&d2(&all[b]))).unwrap();
                let found = nn.nearest(&q).unwrap();
                assert!(!removed[found], "{count}: removed point {found} returned");
                assert_eq!(d2(&all[found]), d2(&all[best]));
            }
        }
        let mut nn = NearestNeighbors::new(2, SimdLevel::best_up_to(None));
        nn.insert(&[0.0, 0.0]);
        nn.remove(0);
        assert_eq!(nn.nearest(&[1.0, 1.0]), None, "every point removed");
    }

    /// The best level's scan (AVX2 on CPUs with it) gives the portable
    /// scan's answers, ties included (coordinates on a coarse grid make
    /// many), in 7 and 14 dimensions.
    #[test]
    fn avx2_scan_answers_as_the_portable_scan() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let best = SimdLevel::best_up_to(None);
        for dim in [7, 14] {
            let mut nn = [NearestNeighbors::new(dim, SimdLevel::Baseline), NearestNeighbors::new(dim, best)];
            assert_eq!(nn[1].avx2, SimdLevel::Avx2.is_available());
            for n in 0..300 {
                let p: Vec<f64> = (0..dim).map(|_| f64::from(rng.random_range(-4i8..4)) * 0.5).collect();
                let q: Vec<f64> = (0..dim).map(|_| rng.random_range(-2.5..2.5)).collect();
                for set in &mut nn {
                    set.insert(&p);
                    if n % 7 == 0 {
                        set.remove(n / 2);
                    }
                }
                assert_eq!(nn[1].nearest(&q), nn[0].nearest(&q), "dim {dim}, {n} points");
            }
        }
    }

    #[test]
    fn matches_a_linear_scan() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let mut nn = NearestNeighbors::new(7, SimdLevel::best_up_to(None));
        let mut all: Vec<Vec<f64>> = Vec::new();
        for n in 0..3000 {
            let p: Vec<f64> = (0..7).map(|_| rng.random_range(-3.0..3.0)).collect();
            nn.insert(&p);
            all.push(p);
            if n > 100 {
                continue;
            }
            // Small sets (the linear scan, and the tree just past it).
            let q: Vec<f64> = (0..7).map(|_| rng.random_range(-3.5..3.5)).collect();
            let d2 = |p: &Vec<f64>| p.iter().zip(&q).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            let scan = (0..all.len()).min_by(|&a, &b| d2(&all[a]).total_cmp(&d2(&all[b]))).unwrap();
            assert_eq!(d2(&all[nn.nearest(&q).unwrap()]), d2(&all[scan]));
        }
        for _ in 0..500 {
            let q: Vec<f64> = (0..7).map(|_| rng.random_range(-3.5..3.5)).collect();
            let d2 = |p: &Vec<f64>| p.iter().zip(&q).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            let scan = (0..all.len()).min_by(|&a, &b| d2(&all[a]).total_cmp(&d2(&all[b]))).unwrap();
            assert_eq!(d2(&all[nn.nearest(&q).unwrap()]), d2(&all[scan]));
        }
    }
}
