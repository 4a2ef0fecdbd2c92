//! Thinning a cloud before it becomes an obstacle: a workspace crop, a
//! range window around the sensor, and a minimum-distance filter.
//!
//! **Why the filter keeps the checks sound.** The minimum-distance filter
//! goes through the points in file order and keeps a point unless a point
//! already kept lies within `spacing` of it (a grid of edge `spacing`
//! finds those among the 27 cells around it): every removed point lies
//! within `spacing` of a kept one, and no two kept points are closer than
//! `spacing`. A robot sphere that clears every kept
//! point by `point_radius + spacing` therefore clears every removed point
//! by `point_radius`: whoever uses the thinned cloud as obstacles must
//! inflate its points by [`FilterReport::radius_margin`] (= `spacing`).

use super::{PointCloud, PointCloudError};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A cell key's hash: one multiply-xor per coordinate (the hash of rustc's
/// own tables). The std SipHash made the 27 lookups per point the filter's
/// whole cost; this one is deterministic too.
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(u64::from(*b));
        }
    }

    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

type Cells = HashMap<[i64; 3], u32, BuildHasherDefault<CellHasher>>;

/// How to thin a cloud (all in m, in the cloud's frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterSettings {
    /// Keep only points inside this axis-aligned box (min, max corners);
    /// `None`: no crop.
    pub crop: Option<([f64; 3], [f64; 3])>,
    /// The sensor's position, for [`Self::range`].
    pub sensor: [f64; 3],
    /// Keep only points whose distance from `sensor` is within this window
    /// (a depth camera's reliable range, e.g. 0.3–3 m for a RealSense
    /// D435); `None`: no window.
    pub range: Option<(f64, f64)>,
    /// The minimum-distance filter's spacing: every removed point lies
    /// within it of a kept point; 0: no thinning.
    pub spacing: f64,
}

impl Default for FilterSettings {
    fn default() -> Self {
        FilterSettings { crop: None, sensor: [0.0; 3], range: None, spacing: 0.0 }
    }
}

/// What a filter removed, step by step, and what it asks of the user.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FilterReport {
    /// Points given.
    pub input: usize,
    /// Removed by the crop box.
    pub cropped: usize,
    /// Removed by the range window.
    pub out_of_range: usize,
    /// Removed by the minimum-distance filter.
    pub thinned: usize,
    /// Points kept.
    pub kept: usize,
    /// How much to add to the point radius so that the kept points stand
    /// for the removed ones (m): the spacing (see the module docs).
    pub radius_margin: f64,
}

impl FilterSettings {
    /// Checks the settings: a crop box with min ≤ max, a range window
    /// 0 ≤ near ≤ far, a spacing finite and ≥ 0, everything finite.
    ///
    /// # Errors
    /// The first setting out of range, by name.
    pub fn validate(&self) -> Result<(), PointCloudError> {
        let bad = |m: String| Err(PointCloudError::new("point cloud filter", None, m));
        if let Some((lo, hi)) = self.crop
            && !(0..3).all(|k| lo[k].is_finite() && hi[k].is_finite() && lo[k] <= hi[k])
        {
            return bad(format!("crop: {lo:?} to {hi:?} is not a box (finite, min ≤ max)"));
        }
        if !self.sensor.iter().all(|x| x.is_finite()) {
            return bad(format!("sensor: {:?} is not a position", self.sensor));
        }
        if let Some((near, far)) = self.range
            && !(near.is_finite() && far.is_finite() && 0.0 <= near && near <= far)
        {
            return bad(format!("range: {near} to {far} is not a window (0 ≤ near ≤ far)"));
        }
        if !(self.spacing.is_finite() && self.spacing >= 0.0) {
            return bad(format!("spacing: {} must be finite and ≥ 0", self.spacing));
        }
        Ok(())
    }
}

impl PointCloud {
    /// The cloud cropped, range-limited and thinned by `settings`, in that
    /// order, with what each step removed. Deterministic: the kept points
    /// are in file order, each farther than `spacing` from those before it.
    ///
    /// # Errors
    /// Settings out of range ([`FilterSettings::validate`]).
    pub fn filtered(&self, settings: &FilterSettings) -> Result<(PointCloud, FilterReport), PointCloudError> {
        let mut thinning = Thinning::new(settings)?;
        for p in &self.points {
            thinning.offer(*p);
        }
        thinning.kept.dropped = self.dropped;
        Ok(thinning.finish())
    }
}

/// The filter's state while points stream through it: what it kept and,
/// by grid cell of edge `spacing`, the first kept point of each cell and
/// each kept point's next in its cell (`u32::MAX` ends a chain). A point's
/// neighbours within `spacing` lie in the 27 cells around its own.
pub(super) struct Thinning {
    settings: FilterSettings,
    report: FilterReport,
    first: Cells,
    next: Vec<u32>,
    kept: PointCloud,
}

impl Thinning {
    pub(super) fn new(settings: &FilterSettings) -> Result<Thinning, PointCloudError> {
        settings.validate()?;
        Ok(Thinning {
            settings: *settings,
            report: FilterReport { radius_margin: settings.spacing, ..FilterReport::default() },
            first: Cells::default(),
            next: Vec::new(),
            kept: PointCloud::default(),
        })
    }

    /// Crops, range-limits and thins one finite point.
    fn offer(&mut self, p: [f64; 3]) {
        let s = &self.settings;
        self.report.input += 1;
        if s.crop.is_some_and(|(lo, hi)| !(0..3).all(|k| lo[k] <= p[k] && p[k] <= hi[k])) {
            self.report.cropped += 1;
            return;
        }
        let in_range = |(near, far): (f64, f64)| {
            let d = (0..3).map(|k| (p[k] - s.sensor[k]).powi(2)).sum::<f64>().sqrt();
            near <= d && d <= far
        };
        if s.range.is_some_and(|r| !in_range(r)) {
            self.report.out_of_range += 1;
            return;
        }
        let spacing = s.spacing;
        if spacing > 0.0 {
            let cell = p.map(|x| (x / spacing).floor() as i64);
            // The point's own cell first (13 is the offset 0, 0, 0): in a
            // dense cloud the kept point that removes it is mostly there.
            let near = (0..27).map(|n| (n + 13) % 27).any(|n| {
                let at = [cell[0] + n % 3 - 1, cell[1] + (n / 3) % 3 - 1, cell[2] + n / 9 - 1];
                let mut k = self.first.get(&at).copied().unwrap_or(u32::MAX);
                while k != u32::MAX {
                    let q = &self.kept.points[k as usize];
                    if (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>() <= spacing * spacing {
                        return true;
                    }
                    k = self.next[k as usize];
                }
                false
            });
            if near {
                self.report.thinned += 1;
                return;
            }
            let index = self.kept.points.len() as u32;
            self.next.push(self.first.insert(cell, index).unwrap_or(u32::MAX));
        }
        self.kept.points.push(p);
    }

    pub(super) fn finish(mut self) -> (PointCloud, FilterReport) {
        self.report.kept = self.kept.len();
        (self.kept, self.report)
    }
}

impl super::PointSink for Thinning {
    fn push(&mut self, p: [f64; 3]) {
        if p.iter().all(|x| x.is_finite()) {
            self.offer(p);
        } else {
            self.kept.dropped += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded cloud: a dense patch (a table seen by a camera) and a few
    /// points far away.
    fn cloud() -> PointCloud {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points: Vec<[f64; 3]> = (0..4000).map(|_| [next() * 0.4, next() * 0.4, 0.7 + next() * 0.01]).collect();
        points.extend([[5.0, 0.0, 0.0], [0.0, 0.0, 0.1]]);
        PointCloud::from_points(points)
    }

    #[test]
    fn streaming_a_file_through_the_filter_keeps_what_filtering_it_whole_keeps() {
        let cloud = cloud();
        let mut text = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nend_header\n",
            cloud.len() + 1
        );
        for p in &cloud.points {
            text += &format!("{:?} {:?} {:?}\n", p[0], p[1], p[2]);
        }
        text += "nan 0 0\n";
        let path = std::env::temp_dir().join(format!("tandem-filter-{}.ply", std::process::id()));
        std::fs::write(&path, text).unwrap();
        let crop = Some(([0.0, 0.0, 0.0], [0.3, 0.4, 1.0]));
        let settings = FilterSettings { spacing: 0.02, crop, ..FilterSettings::default() };
        let whole = PointCloud::read(&path).unwrap().filtered(&settings).unwrap();
        let streamed = PointCloud::read_filtered(&path, &settings).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(whole, streamed);
        assert!(streamed.0.dropped == 1 && streamed.1.cropped > 0 && streamed.1.thinned > 0, "{:?}", streamed.1);
    }

    #[test]
    fn every_removed_point_lies_within_the_spacing_of_a_kept_one() {
        let cloud = cloud();
        for spacing in [0.005, 0.02, 0.1] {
            let (kept, report) = cloud.filtered(&FilterSettings { spacing, ..FilterSettings::default() }).unwrap();
            assert_eq!(report.kept + report.thinned, cloud.len());
            assert!(report.thinned > 0 && report.radius_margin == spacing);
            let worst = cloud
                .points
                .iter()
                .map(|p| {
                    kept.points
                        .iter()
                        .map(|q| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt())
                        .fold(f64::INFINITY, f64::min)
                })
                .fold(0.0, f64::max);
            assert!(worst <= spacing, "spacing {spacing}: a removed point {worst} m from every kept one");
            // A minimum-distance filter: no two kept points within the spacing.
            for (i, p) in kept.points.iter().enumerate() {
                for q in &kept.points[..i] {
                    let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
                    assert!(d > spacing, "spacing {spacing}: kept points {d} m apart");
                }
            }
            // Deterministic, and the same again.
            assert_eq!(kept, cloud.filtered(&FilterSettings { spacing, ..FilterSettings::default() }).unwrap().0);
        }
    }

    #[test]
    fn crop_and_range_remove_what_they_say() {
        let cloud = cloud();
        let settings = FilterSettings {
            crop: Some(([-1.0, -1.0, 0.05], [1.0, 1.0, 2.0])),
            sensor: [0.0, 0.0, 0.0],
            range: Some((0.3, 3.0)),
            spacing: 0.0,
        };
        let (kept, report) = cloud.filtered(&settings).unwrap();
        // The far point is cropped; the one 0.1 m from the sensor is too near.
        assert_eq!((report.cropped, report.out_of_range, report.thinned, report.kept), (1, 1, 0, 4000));
        assert_eq!(kept.len(), 4000);
        for (bad, says) in [
            (FilterSettings { spacing: -1.0, ..settings }, "spacing: -1"),
            (FilterSettings { spacing: f64::NAN, ..settings }, "spacing: NaN"),
            (FilterSettings { range: Some((2.0, 1.0)), ..settings }, "range: 2 to 1"),
            (FilterSettings { crop: Some(([1.0; 3], [0.0; 3])), ..settings }, "crop:"),
            (FilterSettings { sensor: [f64::INFINITY, 0.0, 0.0], ..settings }, "sensor:"),
        ] {
            let e = cloud.filtered(&bad).unwrap_err().to_string();
            assert!(e.contains(says), "{e}");
        }
    }
}
