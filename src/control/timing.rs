//! Timing statistics of a control loop in fixed memory: a log-scale
//! histogram of durations (µs) whose quantiles are within
//! [`QUANTILE_ERROR`] of the exact ones, recorded lock-free from any
//! thread. A loop that keeps every tick's duration for its final
//! percentiles grows by 8 bytes a tick (0.7 GB a day at 1 kHz) and
//! reallocates inside the loop; this does neither.

use std::sync::atomic::{AtomicU64, Ordering};

/// Buckets per doubling of the duration.
const PER_OCTAVE: f64 = 32.0;
/// The smallest duration told apart (µs): shorter ones count in the first bucket.
const LOWEST_US: f64 = 0.01;
/// Octaves covered above [`LOWEST_US`]: up to about 11 hours; longer
/// durations count in the last bucket.
const OCTAVES: usize = 42;
const BUCKETS: usize = OCTAVES * PER_OCTAVE as usize;

/// Largest relative error of a quantile from [`TickHistogram::quantile`]
/// between 0.01 µs and 11 hours: a quantile is reported as
/// its bucket's geometric centre, at most half a bucket (a factor
/// 2^(1/64)) from any duration in the bucket, about 1.1 %.
pub const QUANTILE_ERROR: f64 = 0.010_889_286_051_700_5;

/// Durations (µs) counted in log-scale buckets, 32 per octave, from 0.01 µs
/// to 11 hours (11 KB, allocated once). Recording is a few atomic
/// additions: any thread may record while another reads.
pub struct TickHistogram {
    counts: Box<[AtomicU64]>,
    count: AtomicU64,
    /// f64 bits: for non-negative numbers their order is the numbers' order.
    max_bits: AtomicU64,
    min_bits: AtomicU64,
}

impl Default for TickHistogram {
    fn default() -> Self {
        TickHistogram::new()
    }
}

impl std::fmt::Debug for TickHistogram {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [median, p99, max] = self.summary();
        f.debug_struct("TickHistogram")
            .field("count", &self.count())
            .field("median", &median)
            .field("p99", &p99)
            .field("max", &max)
            .finish()
    }
}

fn bucket(us: f64) -> usize {
    if us <= LOWEST_US {
        return 0;
    }
    let k = ((us / LOWEST_US).log2() * PER_OCTAVE) as usize;
    k.min(BUCKETS - 1)
}

/// The geometric centre of bucket `k` (µs).
fn centre(k: usize) -> f64 {
    LOWEST_US * ((k as f64 + 0.5) / PER_OCTAVE).exp2()
}

impl TickHistogram {
    /// An empty histogram.
    pub fn new() -> TickHistogram {
        TickHistogram {
            counts: (0..BUCKETS).map(|_| AtomicU64::new(0)).collect(),
            count: AtomicU64::new(0),
            max_bits: AtomicU64::new(0),
            min_bits: AtomicU64::new(f64::INFINITY.to_bits()),
        }
    }

    /// Counts a duration of `us` microseconds; NaN is not counted, a
    /// negative duration counts as zero. Allocates nothing.
    pub fn record(&self, us: f64) {
        if us.is_nan() {
            return;
        }
        let us = us.max(0.0);
        self.counts[bucket(us)].fetch_add(1, Ordering::Relaxed);
        self.count.fetch_add(1, Ordering::Relaxed);
        self.max_bits.fetch_max(us.to_bits(), Ordering::Relaxed);
        self.min_bits.fetch_min(us.to_bits(), Ordering::Relaxed);
    }

    /// Durations counted.
    pub fn count(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }

    /// The largest duration counted (µs, exact); NaN when none was.
    pub fn max(&self) -> f64 {
        if self.count() == 0 { f64::NAN } else { f64::from_bits(self.max_bits.load(Ordering::Relaxed)) }
    }

    /// The `p` quantile (0 to 1) of the durations counted (µs), the
    /// sample of rank round((n − 1) p) as [`crate::sim::percentiles`]
    /// ranks them, within [`QUANTILE_ERROR`] relative (clamped to the
    /// exact smallest and largest, which ranks 0 and n − 1 give exactly);
    /// NaN when none was counted.
    pub fn quantile(&self, p: f64) -> f64 {
        // A concurrent recorder may add to a bucket after `count` was read:
        // the walk goes by the buckets' own total.
        let counts: Vec<u64> = self.counts.iter().map(|c| c.load(Ordering::Relaxed)).collect();
        let n: u64 = counts.iter().sum();
        if n == 0 {
            return f64::NAN;
        }
        let rank = ((n - 1) as f64 * p.clamp(0.0, 1.0)).round() as u64;
        let (lo, hi) = (f64::from_bits(self.min_bits.load(Ordering::Relaxed)), self.max());
        // The extremes are kept exactly.
        if rank == 0 {
            return lo.min(hi);
        }
        if rank == n - 1 {
            return hi;
        }
        let mut seen = 0;
        let mut k = BUCKETS - 1;
        for (i, c) in counts.iter().enumerate() {
            seen += c;
            if seen > rank {
                k = i;
                break;
            }
        }
        centre(k).clamp(lo.min(hi), hi)
    }

    /// Median, 99th percentile and largest (µs), NaN when empty.
    pub fn summary(&self) -> [f64; 3] {
        [self.quantile(0.5), self.quantile(0.99), self.max()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the exact percentiles of skewed samples spanning six
    /// decades: every quantile within the stated error.
    #[test]
    fn quantiles_are_within_the_stated_error_of_the_exact_ones() {
        assert!((QUANTILE_ERROR - ((1.0f64 / 64.0).exp2() - 1.0)).abs() < 1e-15);
        let h = TickHistogram::new();
        assert!(h.quantile(0.5).is_nan() && h.max().is_nan());
        let mut samples = Vec::new();
        let mut x = 0.123_f64;
        for i in 0..20_000 {
            // A deterministic spread: mostly 10-100 µs, a tail to 0.1 s.
            x = (x * 9301.0 + 49297.0) % 233_280.0;
            let u = x / 233_280.0;
            let us = if i % 100 == 0 { 1e3 + u * 1e5 } else { 10.0 * (1.0 + 9.0 * u * u) };
            samples.push(us);
            h.record(us);
        }
        h.record(f64::NAN);
        assert_eq!(h.count(), 20_000);
        let mut sorted = samples.clone();
        sorted.sort_by(f64::total_cmp);
        for p in [0.0, 0.01, 0.25, 0.5, 0.9, 0.99, 0.999, 1.0] {
            let exact = sorted[((sorted.len() - 1) as f64 * p).round() as usize];
            let got = h.quantile(p);
            assert!(((got - exact) / exact).abs() <= QUANTILE_ERROR + 1e-12, "p {p}: {got} vs {exact}");
        }
        assert_eq!(h.max(), sorted[sorted.len() - 1]);
        // Out of range both ways: counted, the extremes exact.
        let h = TickHistogram::new();
        for us in [0.0, -3.0, 1e-9, 1e15] {
            h.record(us);
        }
        assert_eq!((h.count(), h.max(), h.quantile(0.0)), (4, 1e15, 0.0));
    }
}
