//! The per-thread scratch of the sphere checks ([`SphereWorkspace`]): the
//! lanes' poses and centres, what is placed this batch, the sweep bounds
//! of a certification and the pairs it still has to certify.

use super::SphereModel;
use super::lanes::{LANES, Lane, LanePose, Real};

/// Per-thread scratch of the sphere checks.
#[derive(Debug, Clone)]
pub(crate) struct SphereWorkspace<T = f64> {
    /// Per active joint: its value in each lane.
    pub(super) q: Vec<Lane>,
    /// Per body: its world pose in each lane (the root stays the identity);
    /// the first `posed` are valid this batch (see
    /// [`SphereModel::pose_up_to`]).
    pub(super) poses: Vec<LanePose<T>>,
    pub(super) posed: usize,
    /// Per sphere: world centre, valid when its group is `placed`.
    pub(super) centers: Vec<[Lane<T>; 3]>,
    /// Per group: world centre of its bounding ball, valid when its flag
    /// in `centered` is set.
    pub(super) group_centers: Vec<[Lane<T>; 3]>,
    pub(super) centered: Vec<bool>,
    /// Per cluster: world centre of its ball, valid when its group's flag
    /// in `clusters_placed` is set; the sphere centres are valid when its
    /// flag in `spheres_placed` is.
    pub(super) cluster_centers: Vec<[Lane<T>; 3]>,
    pub(super) clusters_placed: Vec<bool>,
    pub(super) spheres_placed: Vec<bool>,
    /// Certification of the current motion (see `sweep.rs`): per body,
    /// its joint's `|Δq · multiplier|`; per cluster, the prefix sums
    /// of its loose sweep terms (m per unit of motion), a leading 0 first,
    /// at its slot (valid when `prefix_done`), and the same for its tight
    /// terms per lane (valid when `tight_done`); per group and per
    /// cluster, the largest loose sweep; per self pair, each side's
    /// (valid when `pair_done`).
    pub(super) rates: Vec<T>,
    /// Per body, its joint's signed `Δq · multiplier` (rad or m per unit
    /// of motion); per body and lane, the world angular velocity of its
    /// frame and linear velocity of its origin along the motion (valid
    /// when `tangent_done`); per cluster, the bound of its sphere centres'
    /// acceleration (m per unit of motion², valid when `accel_done`).
    pub(super) signed_rates: Vec<T>,
    pub(super) angular: Vec<[Lane<T>; 3]>,
    pub(super) linear: Vec<[Lane<T>; 3]>,
    pub(super) tangent_done: bool,
    pub(super) accel: Vec<T>,
    pub(super) accel_done: Vec<bool>,
    pub(super) prefix: Vec<T>,
    pub(super) prefix_done: Vec<bool>,
    pub(super) pair_sweep: Vec<[T; 2]>,
    pub(super) pair_done: Vec<bool>,
    pub(super) tight: Vec<Lane<T>>,
    pub(super) tight_done: Vec<bool>,
    pub(super) group_sweep: Vec<T>,
    /// Per segment (see `segments.rs`): the largest loose sweep of its
    /// groups, and its box in each lane, valid when `boxed`.
    pub(super) segment_sweep: Vec<T>,
    pub(super) segment_boxes: Vec<[[Lane<T>; 3]; 2]>,
    pub(super) boxed: Vec<bool>,
    pub(super) cluster_sweep: Vec<T>,
    pub(super) margins: Margins<T>,
    /// Per lane, after a certification check that found it free: the
    /// half-width around its configuration over which every pair keeps
    /// `half` (at least its width when the lane was not split; NaN or
    /// negative means none).
    pub(super) room: Lane<T>,
    /// Per lane, after a certification check: the groups of the pairs
    /// that fell short of its width, which its parts must check again.
    pub(super) short: [Pending; LANES],
    /// The pairs a certification check visits: those pending in any lane.
    pub(super) checking: Pending,
    /// Intervals of the motion still to certify.
    pub(crate) intervals: std::collections::VecDeque<Interval>,
    /// The pair that last failed, checked first: successive checks (the
    /// steps of a search, a shortcut tried again) tend to fail on it.
    pub(super) last_failure: Option<Pair>,
    /// The last certification failed: probe the next motion plainly
    /// first (see `SphereModel::certify`).
    pub(super) probe_next: bool,
    /// The single-precision check's scratch (see `single.rs`).
    pub(super) single: Option<Box<SphereWorkspace<f32>>>,
}

/// A pair of the model: a group and a static shape, or a self pair.
#[derive(Debug, Clone, Copy)]
pub(super) enum Pair {
    Environment(usize, usize),
    Robot(usize),
}

/// Part `[lo, hi]` of a motion (fractions of it) still to certify, and
/// the pairs still to certify over it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Interval {
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) pending: Pending,
}

/// Pairs of a certification as group bits (bit `g` for group `g`; groups
/// past the 64th have none and are always pending): each group's pairs
/// with the static shapes, and the self pairs both of whose groups are
/// set. A pair that keeps its margin over an interval keeps it over every
/// part of it, so an interval's parts check only the pairs that fell
/// short on it (and, in a batch, those any other lane still needs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Pending {
    environment: u64,
    robot: u64,
}

impl Pending {
    pub(super) const ALL: Pending = Pending { environment: u64::MAX, robot: u64::MAX };
    pub(super) const NONE: Pending = Pending { environment: 0, robot: 0 };

    #[inline(always)]
    pub(super) fn bit(g: usize) -> u64 {
        if g < 64 { 1 << g } else { 0 }
    }

    /// Group `g`'s pairs with the static shapes.
    #[inline(always)]
    pub(super) fn environment(g: usize) -> Pending {
        Pending { environment: Pending::bit(g), robot: 0 }
    }

    /// The self pair of groups `a` and `b`.
    #[inline(always)]
    pub(super) fn robot([a, b]: [u32; 2]) -> Pending {
        Pending { environment: 0, robot: Pending::bit(a as usize) | Pending::bit(b as usize) }
    }

    /// Whether every pair of `part` is pending here.
    #[inline(always)]
    pub(super) fn covers(&self, part: Pending) -> bool {
        self.environment & part.environment == part.environment && self.robot & part.robot == part.robot
    }

    #[inline(always)]
    pub(super) fn union(self, other: Pending) -> Pending {
        Pending { environment: self.environment | other.environment, robot: self.robot | other.robot }
    }
}

/// What a certification check asks of each pair (m): to stay `full` apart
/// at the checked configurations, and `half` apart over `width` (fraction
/// of the motion) on either side of them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Margins<T = f64> {
    pub(super) half: T,
    pub(super) full: T,
    pub(super) width: Lane<T>,
}

impl<T: Real> SphereWorkspace<T> {
    /// Marks every pose, centre and segment box as not yet placed for the
    /// configurations now in the lanes.
    #[inline(always)]
    pub(super) fn new_batch(&mut self) {
        self.posed = 1;
        self.centered.fill(false);
        self.clusters_placed.fill(false);
        self.spheres_placed.fill(false);
        self.boxed.fill(false);
    }

    pub(crate) fn new(model: &SphereModel<T>, nq: usize) -> SphereWorkspace<T> {
        SphereWorkspace {
            q: vec![[0.0; LANES]; nq],
            poses: vec![LanePose::IDENTITY; model.bodies.len()],
            posed: 1,
            centers: vec![[[T::ZERO; LANES]; 3]; model.spheres.len()],
            group_centers: vec![[[T::ZERO; LANES]; 3]; model.groups.len()],
            centered: vec![false; model.groups.len()],
            cluster_centers: vec![[[T::ZERO; LANES]; 3]; model.clusters.len()],
            clusters_placed: vec![false; model.groups.len()],
            spheres_placed: vec![false; model.clusters.len()],
            rates: vec![T::ZERO; model.bodies.len()],
            signed_rates: vec![T::ZERO; model.bodies.len()],
            angular: vec![[[T::ZERO; LANES]; 3]; model.bodies.len()],
            linear: vec![[[T::ZERO; LANES]; 3]; model.bodies.len()],
            tangent_done: false,
            accel: vec![T::ZERO; model.clusters.len()],
            accel_done: vec![false; model.clusters.len()],
            prefix: vec![T::ZERO; model.sweep_terms.len() + model.clusters.len()],
            prefix_done: vec![false; model.clusters.len()],
            pair_sweep: vec![[T::ZERO; 2]; model.self_pairs.len()],
            pair_done: vec![false; model.self_pairs.len()],
            tight: vec![[T::ZERO; LANES]; model.sweep_terms.len() + model.clusters.len()],
            tight_done: vec![false; model.clusters.len()],
            group_sweep: vec![T::ZERO; model.groups.len()],
            segment_sweep: vec![T::ZERO; model.segments.len()],
            segment_boxes: vec![[[[T::ZERO; LANES]; 3]; 2]; model.segments.len()],
            boxed: vec![false; model.segments.len()],
            cluster_sweep: vec![T::ZERO; model.clusters.len()],
            margins: Margins { half: T::ZERO, full: T::ZERO, width: [T::ZERO; LANES] },
            room: [T::ZERO; LANES],
            short: [Pending::NONE; LANES],
            checking: Pending::ALL,
            intervals: std::collections::VecDeque::with_capacity(256),
            last_failure: None,
            probe_next: false,
            single: model.single.as_ref().map(|s| Box::new(SphereWorkspace::new(&s.model, nq))),
        }
    }
}
