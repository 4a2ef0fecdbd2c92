//! Motions on the sphere fast path: sampled checks [`LANES`] samples at a
//! time, and certification by bounded motion.
//!
//! Certification: over the straight motion `q(t) = q0 + t (q1 − q0)`,
//! `t ∈ [0, 1]`, the centre of a sphere moves at most `S = Σ_k |Δq_k| ·
//! lever_k` per unit of `t` (levers bound each joint's reach for every q;
//! see [`lever_chain`](crate::collision::geometry::lever_chain)), and two
//! spheres approach each other at most at the sum of their speeds
//! counting only the joints that move one but not the other (a joint
//! moving both turns them together). So if at `t = m` a pair is `d` apart,
//! it stays `d − w S` apart for `|t − m| ≤ w`. An interval `[m − w, m + w]`
//! is certified when every pair clears `half + w S` at `m`; it fails when
//! a pair at `m` is closer than `full`; otherwise it is split in two.
//! A pair short of `half + w S` is given a second chance by a second-order
//! bound, `d − |τ| rate − τ² accel / 2` with the distance's actual rate of
//! change at `m` (see `narrow` in `check.rs`): a motion grazing an obstacle
//! barely approaches it, and is certified in far fewer, wider intervals
//! (MotionBenchMaker's Panda problems: a fifth fewer instructions in
//! planning and simplification).
//!
//! A pair that keeps its margin over an interval keeps it over every part
//! of it, so the parts of a split interval check again only the pairs
//! that fell short on it ([`Pending`], as group bits): most pairs of a
//! robot with many groups lie far from what stopped the interval.
//! Callgrind, planning and simplification, against checking every pair:
//! Baxter `shelf` −2.0 %, `table` −4.4 %; single arms +0.2–1.0 % (the
//! bits' upkeep), same paths.

use super::SphereModel;
use super::check::Verdict;
use super::lanes::{LANES, Lane, build};
use super::workspace::{Interval, Margins, Pending, SphereWorkspace};

/// Sample indices `0..=steps` of a motion, coarse to fine: the end, the
/// start, then the odd multiples of halving strides (every index once),
/// so that a blocked motion is found early.
#[derive(Debug, Clone)]
pub(crate) struct SampleOrder {
    steps: usize,
    ends: u8,
    stride: usize,
    next: usize,
    /// Index 0 is left out (a start known to pass).
    skip_start: bool,
}

impl SampleOrder {
    pub(crate) fn new(steps: usize) -> SampleOrder {
        let stride = steps.next_power_of_two();
        SampleOrder { steps, ends: 0, stride, next: stride / 2, skip_start: false }
    }

    /// The same order without index 0.
    pub(crate) fn after_start(steps: usize) -> SampleOrder {
        SampleOrder { skip_start: true, ..SampleOrder::new(steps) }
    }
}

impl Iterator for SampleOrder {
    type Item = usize;

    fn next(&mut self) -> Option<usize> {
        if self.ends == 0 {
            self.ends = 1;
            return Some(self.steps);
        }
        if self.ends == 1 {
            self.ends = 2;
            if !self.skip_start {
                return Some(0);
            }
        }
        while self.stride > 1 {
            if self.next < self.steps {
                let k = self.next;
                self.next += self.stride;
                return Some(k);
            }
            self.stride /= 2;
            self.next = self.stride / 2;
        }
        None
    }
}

/// What [`SphereModel::certify`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Certification {
    /// Every configuration keeps the `half` margin.
    Certified,
    /// A configuration on the motion is closer than `full`.
    Fails,
    /// A pair within the tolerance of `full`, or a robot with sliding
    /// joints (whose sweep bounds do not hold): the exact model decides.
    Undecided,
}

/// Splits the widest of fewer than [`LANES`] pending intervals in halves
/// until the next batch is full: its lanes cost the same used or not, and
/// narrower intervals certify in fewer rounds.
fn fill_lanes(intervals: &mut std::collections::VecDeque<Interval>) {
    while !intervals.is_empty() && intervals.len() < LANES {
        let (widest, &interval) = intervals
            .iter()
            .enumerate()
            .max_by(|a, b| (a.1.hi - a.1.lo).total_cmp(&(b.1.hi - b.1.lo)))
            .expect("not empty");
        // Thin ones are left to the bounded splitting of `certify`.
        if interval.hi - interval.lo < 1e-9 {
            return;
        }
        let m = 0.5 * (interval.lo + interval.hi);
        intervals[widest].hi = m;
        intervals.push_back(Interval { lo: m, ..interval });
    }
}

/// How far (m) spheres may move over the intervals a certification starts
/// with. Wider first intervals split more often, which costs less since
/// the parts check only pending pairs: against 0.2, instructions of
/// planning + simplification (callgrind, 30 problems × 3 seeds) Baxter
/// `shelf` −2.5 %, `table` −6.2 %, UR5 `shelf` −3.2 %, `cage` −1.8 %,
/// TIAGo `shelf` −1.3 %, `cage` −0.4 %, the Panda's 699 +0.4 %; 0.4 took
/// the Baxter further (`shelf` −3.1 %) and the Panda +2.1 %.
const FIRST_REACH: f64 = 0.3;

impl SphereModel {
    /// Checks samples `ks` of the motion from `q0` to `q1` in `steps` steps
    /// (sample k at `t = k / steps`).
    pub(crate) fn check_samples(
        &self,
        ws: &mut SphereWorkspace,
        q0: &[f64],
        q1: &[f64],
        ks: &[usize; LANES],
        steps: usize,
    ) -> Verdict {
        let t: Lane = build(|l| ks[l] as f64 / steps as f64);
        self.set_along(ws, q0, q1, &t);
        self.check_plain(ws)
    }

    /// Certifies the motion from `q0` to `q1` for margins `half` and `full`
    /// (m; see the [module documentation](self)). After a motion that
    /// failed, the next is first probed with a plain check: a search's
    /// failures come in runs (blocked extensions, shortcuts through the
    /// same obstacle), and the probe finds most of them for less (on
    /// MotionBenchMaker's Panda problems, mean planning time 0.52 ->
    /// 0.42 ms). Verdicts do not change: a collision fails certification.
    pub(crate) fn certify(
        &self,
        ws: &mut SphereWorkspace,
        (q0, q1): (&[f64], &[f64]),
        (half, full): (f64, f64),
    ) -> Certification {
        if ws.probe_next && self.probe_collides(ws, q0, q1) {
            return Certification::Fails;
        }
        self.start_certification(ws, q0, q1, half, full);
        while let Some(first) = ws.intervals.pop_front() {
            let mut taken = [first; LANES];
            let mut n = 1;
            while n < LANES {
                let Some(next) = ws.intervals.pop_front() else { break };
                taken[n] = next;
                n += 1;
            }
            // Unused lanes repeat the first interval.
            let mid: Lane = build(|l| 0.5 * (taken[l].lo + taken[l].hi));
            ws.margins.width = build(|l| (mid[l] - taken[l].lo).max(taken[l].hi - mid[l]));
            ws.checking = taken[..n].iter().fold(Pending::NONE, |all, i| all.union(i.pending));
            self.set_along(ws, q0, q1, &mid);
            let Verdict::Free { unsure, split } = self.check::<true>(ws) else {
                ws.probe_next = true;
                return Certification::Fails;
            };
            if unsure[..n].iter().any(|&u| u) {
                return Certification::Undecided;
            }
            for l in (0..n).filter(|&l| split[l]) {
                let (Interval { lo, hi, .. }, m) = (taken[l], mid[l]);
                let pending = ws.short[l];
                // Bounded splitting: an interval this thin is for the exact model.
                if hi - lo < 1e-12 {
                    return Certification::Undecided;
                }
                // What is certified around the midpoint anyway (NaN: nothing)
                // stays out of the halves left.
                let room = ws.room[l];
                let room = if room > 0.0 { room.min(ws.margins.width[l]) } else { 0.0 };
                if m - room > lo {
                    ws.intervals.push_back(Interval { lo, hi: m - room, pending });
                }
                if m + room < hi {
                    ws.intervals.push_back(Interval { lo: m + room, hi, pending });
                }
            }
            fill_lanes(&mut ws.intervals);
        }
        ws.probe_next = false;
        Certification::Certified
    }

    /// Whether a plain check finds a collision at [`LANES`] configurations
    /// evenly spread over the motion (the midpoints of the first batch of
    /// a short motion's certification). A collision there means the motion
    /// cannot be certified, and the plain check costs a fraction of a
    /// certification batch, which also bounds each pair's sweep.
    fn probe_collides(&self, ws: &mut SphereWorkspace, q0: &[f64], q1: &[f64]) -> bool {
        let t: Lane = build(|l| (l as f64 + 0.5) / LANES as f64);
        self.set_along(ws, q0, q1, &t);
        self.check_plain(ws) == Verdict::Collides
    }

    /// Sweep bounds for the motion from `q0` to `q1`, the margins (m), and
    /// the work queue holding the whole motion.
    fn start_certification(&self, ws: &mut SphereWorkspace, q0: &[f64], q1: &[f64], half: f64, full: f64) {
        self.start_sweeps(ws, q0, q1);
        ws.margins = Margins { half, full, width: [0.0; LANES] };
        ws.intervals.clear();
        // Wide intervals would only be split: start with ones over which
        // no sphere moves more than about `FIRST_REACH`, a multiple of
        // the lanes, each batch spread over the whole motion.
        let fastest = ws.group_sweep.iter().fold(0.0, |a: f64, &b| a.max(b));
        let per_lane = ((fastest / FIRST_REACH).ceil() as usize).div_ceil(LANES).clamp(1, 128);
        let count = (per_lane * LANES) as f64;
        for j in SampleOrder::new(per_lane).filter(|&j| j < per_lane) {
            for i in 0..LANES {
                let k = (i * per_lane + j) as f64;
                ws.intervals.push_back(Interval { lo: k / count, hi: (k + 1.0) / count, pending: Pending::ALL });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::SampleOrder;

    #[test]
    fn sample_order_visits_every_index_once_ends_first() {
        for steps in 1..70 {
            let order: Vec<usize> = SampleOrder::new(steps).collect();
            assert_eq!(order[..2], [steps, 0]);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..=steps).collect::<Vec<_>>(), "{steps}");
            // Without the start: the same order, index 0 left out.
            let after: Vec<usize> = SampleOrder::after_start(steps).collect();
            assert_eq!(after, order.iter().copied().filter(|&k| k != 0).collect::<Vec<_>>(), "{steps}");
        }
    }
}
