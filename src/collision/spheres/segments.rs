//! Self pairs culled in blocks. A robot with two arms has every link of
//! one arm paired with every link of the other: the Baxter's 27 groups
//! make 187 self pairs where the Panda's 11 make 21 (its SRDF leaves
//! out the rest), and every check that finds no collision visits each
//! of them. A certification check pays most: each pair's bounding-ball
//! test there adds the pair's sweep bound over each lane's width.
//!
//! So the groups are cut into *segments*, runs of up to
//! [`SEGMENT_GROUPS`] groups along one chain (a segment never spans a
//! branching of the kinematic tree), and the self pairs between two
//! segments form a *block*. Per lane, a segment's box holds its groups'
//! bounding balls; when the two boxes of a block lie farther apart along
//! some axis than any of its pairs must keep (plus twice the tolerance),
//! every pair of the block would pass its bounding-ball test, so the
//! block is skipped whole. Verdicts do not change: only pairs that pass
//! are skipped. Pairs within a segment, between segments that follow
//! each other on a chain (their boxes touch where the links join), in
//! blocks of fewer than [`BLOCK_PAIRS`] pairs, or in blocks whose boxes
//! part in fewer than half of a sample of random configurations are
//! checked one by one.
//!
//! Instructions of planning and simplification per run (callgrind, 30
//! problems × 3 seeds, median): Baxter `table` −18 %, `shelf` −10 %;
//! TIAGo and UR5 (no block kept) +0.3–0.6 %; the Panda's 699 (its SRDF
//! leaves no block of 10 pairs) +0.2 %, same paths.
// Lane loops index several arrays by the lane on purpose (see `lanes.rs`).
#![allow(clippy::needless_range_loop)]

use super::lanes::{LANES, Lane, Real, build, max, min};
use super::workspace::SphereWorkspace;
use super::{SphereGroup, SphereModel};
use crate::robot::JointLimits;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::ops::Range;

/// Groups in a segment, at most.
const SEGMENT_GROUPS: usize = 4;

/// Self pairs a block needs to be culled as one: the Panda's block from
/// its base to its hand (9 pairs) culled cost 0.6 % more instructions
/// than it saved (`bookshelf_small`, planning and simplification).
const BLOCK_PAIRS: usize = 10;

/// Random configurations each block's boxes are tried on when the model
/// is compiled (see [`SphereModel::keep_parting_blocks`]).
const PARTING_SAMPLES: usize = 16 * LANES;

/// Self pairs checked together: `pairs` (into
/// [`SphereModel::self_pairs`]), all between `segments` (into
/// [`SphereModel::segments`]), or `None` for pairs checked one by one.
#[derive(Debug, Clone)]
pub(super) struct SelfBlock {
    pub(super) pairs: Range<usize>,
    pub(super) segments: Option<[u32; 2]>,
}

/// The self pairs in blocks and the segments they lie between.
pub(super) struct Blocks {
    pub(super) blocks: Vec<SelfBlock>,
    /// Per segment, its groups as a range into `groups`.
    pub(super) segments: Vec<Range<usize>>,
    pub(super) groups: Vec<u32>,
}

/// Cuts `groups` into segments (`parents[b]`: body `b`'s parent; bodies
/// come after their parents) and orders the self pairs (and their
/// `common_depth`, alike) into blocks: those checked one by one first, in
/// their order, then one block per pair of segments that do not follow
/// each other, with at least [`BLOCK_PAIRS`] pairs between them.
pub(super) fn blocks<T>(
    groups: &[SphereGroup<T>],
    parents: &[usize],
    self_pairs: &mut Vec<[u32; 2]>,
    common_depth: &mut Vec<usize>,
) -> Blocks {
    let (segment_of, follows) = segment_of_groups(groups, parents);
    let adjacent = |[a, b]: [u32; 2]| a == b || follows[a as usize] == Some(b) || follows[b as usize] == Some(a);
    let key = |p: &[u32; 2]| {
        let [a, b] = p.map(|g| segment_of[g as usize]);
        [a.min(b), a.max(b)]
    };
    let mut counts = std::collections::BTreeMap::<[u32; 2], usize>::new();
    for p in self_pairs.iter() {
        *counts.entry(key(p)).or_default() += 1;
    }
    let blocked = |p: &[u32; 2]| counts[&key(p)] >= BLOCK_PAIRS && !adjacent(key(p));
    // One by one (key None, first), then block by block; stable.
    let mut order: Vec<usize> = (0..self_pairs.len()).collect();
    order.sort_by_key(|&p| blocked(&self_pairs[p]).then(|| key(&self_pairs[p])));
    let (pairs, depths): (Vec<_>, Vec<_>) = order.iter().map(|&p| (self_pairs[p], common_depth[p])).unzip();
    let mut blocks: Vec<SelfBlock> = Vec::new();
    for (p, pair) in pairs.iter().enumerate() {
        let segments = blocked(pair).then(|| key(pair));
        match blocks.last_mut() {
            Some(last) if last.segments == segments => last.pairs.end = p + 1,
            _ => blocks.push(SelfBlock { pairs: p..p + 1, segments }),
        }
    }
    *self_pairs = pairs;
    *common_depth = depths;
    let (mut segments, mut members) = (Vec::with_capacity(follows.len()), Vec::with_capacity(groups.len()));
    for s in 0..follows.len() as u32 {
        let start = members.len();
        members.extend((0..groups.len() as u32).filter(|&g| segment_of[g as usize] == s));
        segments.push(start..members.len());
    }
    Blocks { blocks, segments, groups: members }
}

/// The segment of each group, and the segment each segment follows on
/// its chain (if any): groups in body order, each joining the segment of
/// the nearest group above it on its chain while that segment has room
/// and no branching of the tree lies between them.
fn segment_of_groups<T>(groups: &[SphereGroup<T>], parents: &[usize]) -> (Vec<u32>, Vec<Option<u32>>) {
    let bodies = parents.len();
    let mut has_group = vec![false; bodies];
    for group in groups {
        has_group[group.body] = true;
    }
    // Per body: how many of its children carry groups below them.
    let (mut carries, mut branches) = (has_group.clone(), vec![0usize; bodies]);
    for b in (1..bodies).rev() {
        if carries[b] {
            carries[parents[b]] = true;
            branches[parents[b]] += 1;
        }
    }
    let mut order: Vec<usize> = (0..groups.len()).collect();
    order.sort_by_key(|&g| groups[g].body);
    // Per body, the open segment whose last group is on it.
    let (mut tip, mut sizes, mut follows) = (vec![None::<u32>; bodies], Vec::<usize>::new(), Vec::new());
    let mut last_on = vec![None::<u32>; bodies];
    let mut segment = vec![0u32; groups.len()];
    for g in order {
        let body = groups[g].body;
        // The segment to join: one ending on this body, else the one ending
        // on the nearest body above with a group, if no branching of the
        // tree lies on the way up to it.
        let (mut above, mut straight) = (body, true);
        if tip[body].is_none() && body != 0 {
            above = parents[body];
            straight = branches[above] <= 1;
            while !has_group[above] && above != 0 {
                above = parents[above];
                straight &= branches[above] <= 1;
            }
        }
        let joined = tip[above].filter(|&s| straight && sizes[s as usize] < SEGMENT_GROUPS);
        let s = joined.unwrap_or_else(|| {
            sizes.push(0);
            // After the segment holding the last group above (or on this
            // body, when that one is full).
            follows.push(last_on[above]);
            (sizes.len() - 1) as u32
        });
        sizes[s as usize] += 1;
        tip[above] = None;
        tip[body] = Some(s);
        last_on[body] = Some(s);
        segment[g] = s;
    }
    (segment, follows)
}

impl<T: Real> SphereModel<T> {
    /// Per lane, the box of segment `s`'s groups' bounding balls, once per
    /// batch.
    #[inline(always)]
    fn segment_box<'w>(&self, ws: &'w mut SphereWorkspace<T>, s: usize) -> &'w [[Lane<T>; 3]; 2] {
        if !ws.boxed[s] {
            let (mut lo, mut hi) = ([[T::INFINITY; LANES]; 3], [[T::NEG_INFINITY; LANES]; 3]);
            for &g in &self.segment_groups[self.segments[s].clone()] {
                let g = g as usize;
                let (center, radius) = (*self.group_center(ws, g), self.groups[g].radius);
                for i in 0..3 {
                    for l in 0..LANES {
                        lo[i][l] = min(lo[i][l], center[i][l] - radius);
                        hi[i][l] = max(hi[i][l], center[i][l] + radius);
                    }
                }
            }
            ws.segment_boxes[s] = [lo, hi];
            ws.boxed[s] = true;
        }
        &ws.segment_boxes[s]
    }

    /// Whether the boxes of segments `a` and `b` lie, in every lane,
    /// farther apart along some axis than any pair between them must keep
    /// beyond its balls (certification: the margins over each lane's
    /// width, at the segments' sweep bounds), with twice the tolerance to
    /// spare: every such pair then passes its bounding-ball test.
    #[inline(always)]
    pub(super) fn segments_apart<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace<T>, segments: [u32; 2]) -> bool {
        self.parting_lanes::<CERTIFY>(ws, segments).iter().all(|&p| p)
    }

    /// Per lane, whether the boxes of segments `a` and `b` lie apart as
    /// [`segments_apart`](Self::segments_apart) asks.
    #[inline(always)]
    fn parting_lanes<const CERTIFY: bool>(&self, ws: &mut SphereWorkspace<T>, [a, b]: [u32; 2]) -> [bool; LANES] {
        let (a, b) = (a as usize, b as usize);
        let [lo_a, hi_a] = *self.segment_box(ws, a);
        let [lo_b, hi_b] = *self.segment_box(ws, b);
        let spare = T::of(2.0) * self.tolerance;
        let limit: Lane<T> = if CERTIFY {
            let (m, sweep) = (&ws.margins, ws.segment_sweep[a] + ws.segment_sweep[b]);
            build(|l| max(m.half + m.width[l] * sweep, m.full) + spare)
        } else {
            [spare; LANES]
        };
        build(|l| {
            let mut gap = T::NEG_INFINITY;
            for i in 0..3 {
                gap = max(gap, max(lo_a[i][l] - hi_b[i][l], lo_b[i][l] - hi_a[i][l]));
            }
            gap > limit[l]
        })
    }

    /// Per segment, the largest loose sweep bound of its groups (m per
    /// unit of motion; see `sweep.rs`), for the motion whose group sweeps
    /// are in the workspace.
    pub(super) fn start_segment_sweeps(&self, ws: &mut SphereWorkspace<T>) {
        for (s, range) in self.segments.iter().enumerate() {
            let groups = &self.segment_groups[range.clone()];
            ws.segment_sweep[s] = groups.iter().fold(T::ZERO, |a, &g| max(a, ws.group_sweep[g as usize]));
        }
    }
}

impl SphereModel {
    /// Leaves to checking pair by pair the blocks whose boxes part in
    /// fewer than half of [`PARTING_SAMPLES`] seeded random
    /// configurations within the joint limits (±π where unlimited): their
    /// box test would cost more than it saves. (The TIAGo's one block, its
    /// base and head against its hand, parts in 51 of 128: culled, it cost
    /// 3–4 % more instructions.)
    pub(super) fn keep_parting_blocks(&mut self, limits: &[JointLimits]) {
        let mut ws = SphereWorkspace::new(self, limits.len());
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut parted = vec![0usize; self.self_blocks.len()];
        for _ in 0..PARTING_SAMPLES / LANES {
            for (lane, limit) in ws.q.iter_mut().zip(limits) {
                let lower = if limit.lower.is_finite() { limit.lower } else { -PI };
                let upper = if limit.upper.is_finite() { limit.upper } else { PI };
                for v in lane.iter_mut() {
                    *v = rng.random_range(lower..=upper);
                }
            }
            ws.new_batch();
            for (block, count) in self.self_blocks.iter().zip(&mut parted) {
                if let Some(segments) = block.segments {
                    *count += self.parting_lanes::<false>(&mut ws, segments).iter().filter(|&&p| p).count();
                }
            }
        }
        for (block, count) in self.self_blocks.iter_mut().zip(parted) {
            if 2 * count < PARTING_SAMPLES {
                block.segments = None;
            }
        }
        // Neighbouring pair-by-pair blocks as one; no segments to box when
        // no block is culled.
        self.self_blocks.dedup_by(|next, last| {
            let merged = last.segments.is_none() && next.segments.is_none();
            if merged {
                last.pairs.end = next.pairs.end;
            }
            merged
        });
        if self.self_blocks.iter().all(|b| b.segments.is_none()) {
            self.segments.clear();
            self.segment_groups.clear();
        }
    }
}
