//! Segmentation without a network: the depth points above the table,
//! the robot's own points removed, grouped into one cluster per object.
//!
//! 1. **Table.** Points outside the table's region (a box in the world:
//!    its footprint, from just above its top up to a height) are dropped,
//!    the top itself with them ([`SegmentSettings::table_clearance`] above
//!    it, a few sensor σ).
//! 2. **Robot.** Points within a margin of the arm's own collision shapes
//!    at the measured configuration are dropped
//!    ([`CollisionModel::remove_robot_points`], the self-filter of the
//!    point-cloud scene).
//! 3. **Clusters.** The rest is bucketed into cubic cells of
//!    [`SegmentSettings::cluster_distance`]; cells that touch (26
//!    neighbours) form one cluster, so objects closer than one cell merge
//!    and objects farther apart than two never do. Clusters with too few
//!    points (speckle, a finger's edge) or too large (an arm link the
//!    filter missed, a merged pair) are dropped.
//!
//! Clusters come in a fixed order (by their first pixel), so the same
//! image gives the same segments.

use super::PerceptionError;
use crate::collision::{CollisionModel, CollisionWorkspace};
use std::collections::HashMap;

/// Settings of segmentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentSettings {
    /// The table region's lower corner: x, y of its footprint and z of
    /// its top (world, m).
    pub region_min: [f64; 3],
    /// The region's upper corner: x, y of its footprint and the highest
    /// point an object may reach (world, m).
    pub region_max: [f64; 3],
    /// Points this close above the top are the table (m, default 0.008).
    pub table_clearance: f64,
    /// Points this close to the robot's shapes are the robot (m, default 0.015).
    pub robot_margin: f64,
    /// Cell size of the clustering (m, default 0.01).
    pub cluster_distance: f64,
    /// The fewest points of a cluster (default 40).
    pub min_points: usize,
    /// The largest extent of a cluster along any axis (m, default 0.3).
    pub max_extent: f64,
}

impl SegmentSettings {
    /// Settings for a table whose top spans `min`..`max` in x and y at
    /// height `top` (m), objects up to 0.3 m tall.
    pub fn for_table(min: [f64; 2], max: [f64; 2], top: f64) -> SegmentSettings {
        SegmentSettings {
            region_min: [min[0], min[1], top],
            region_max: [max[0], max[1], top + 0.3],
            table_clearance: 0.008,
            robot_margin: 0.015,
            cluster_distance: 0.01,
            min_points: 40,
            max_extent: 0.3,
        }
    }

    /// Checks every value.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("segment settings", None, m));
        if !(0..3).all(|i| {
            self.region_min[i].is_finite() && self.region_max[i].is_finite() && self.region_min[i] < self.region_max[i]
        }) {
            return bad(format!("region {:?} .. {:?} must be finite and not empty", self.region_min, self.region_max));
        }
        for (name, v) in [("table_clearance", self.table_clearance), ("robot_margin", self.robot_margin)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} {v} must be finite and at least 0"));
            }
        }
        for (name, v) in [("cluster_distance", self.cluster_distance), ("max_extent", self.max_extent)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} {v} must be finite and positive"));
            }
        }
        Ok(())
    }
}

/// One cluster: an object's points as the camera saw them.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// World points (m).
    pub points: Vec<[f64; 3]>,
    /// Each point's pixel (row-major index into the image).
    pub pixels: Vec<usize>,
}

impl Segment {
    /// The mean of the points (m): the dissertation's *mask_pose*.
    pub fn centroid(&self) -> [f64; 3] {
        let n = self.points.len().max(1) as f64;
        let s = self.points.iter().fold([0.0; 3], |a, p| [a[0] + p[0], a[1] + p[1], a[2] + p[2]]);
        s.map(|c| c / n)
    }
}

/// What segmentation dropped, for diagnostics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SegmentReport {
    /// Points outside the region or on the table.
    pub outside: usize,
    /// Points on the robot.
    pub robot: usize,
    /// Points in clusters too small or too large.
    pub rejected: usize,
}

/// Splits `points` (world, m, each with its pixel) into object clusters;
/// `robot` is the arm at configuration `q`, whose own points are removed
/// (`None`: no robot in view).
///
/// # Errors
/// Settings out of range, a `q` the robot refuses.
pub fn segment_objects(
    points: &[([f64; 3], usize)],
    robot: Option<(&CollisionModel, &mut CollisionWorkspace, &[f64])>,
    settings: &SegmentSettings,
) -> Result<(Vec<Segment>, SegmentReport), PerceptionError> {
    settings.validate()?;
    let mut report = SegmentReport::default();
    let (lo, hi) = (settings.region_min, settings.region_max);
    let inside: Vec<([f64; 3], usize)> = points
        .iter()
        .copied()
        .filter(|(p, _)| {
            p[0] >= lo[0]
                && p[0] <= hi[0]
                && p[1] >= lo[1]
                && p[1] <= hi[1]
                && p[2] > lo[2] + settings.table_clearance
                && p[2] <= hi[2]
        })
        .collect();
    report.outside = points.len() - inside.len();
    let kept = match robot {
        None => inside,
        Some((model, ws, q)) => {
            let mut xyz: Vec<[f64; 3]> = inside.iter().map(|(p, _)| *p).collect();
            report.robot = model
                .remove_robot_points(ws, q, settings.robot_margin, &mut xyz)
                .map_err(|e| PerceptionError::new("segmentation", None, format!("the robot's configuration: {e}")))?;
            // The kept points are in their order: walk both lists (equal
            // points are kept or removed together).
            let mut out = Vec::with_capacity(xyz.len());
            let mut next = xyz.iter().peekable();
            for entry in inside {
                if next.peek().is_some_and(|p| **p == entry.0) {
                    out.push(entry);
                    next.next();
                }
            }
            out
        }
    };
    // Cells, then their 26-connected components by union-find.
    let cell = |p: &[f64; 3]| p.map(|c| (c / settings.cluster_distance).floor() as i64);
    let mut cells: HashMap<[i64; 3], usize> = HashMap::new();
    let mut of_point = Vec::with_capacity(kept.len());
    for (p, _) in &kept {
        let n = cells.len();
        of_point.push(*cells.entry(cell(p)).or_insert(n));
    }
    let mut parent: Vec<usize> = (0..cells.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (c, &i) in &cells {
        for d in 0..27 {
            let n = [c[0] + d % 3 - 1, c[1] + (d / 3) % 3 - 1, c[2] + d / 9 - 1];
            if let Some(&j) = cells.get(&n) {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                // The smaller id is the root: independent of the map's order.
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut cluster_of_root: HashMap<usize, usize> = HashMap::new();
    let mut clusters: Vec<Segment> = vec![];
    for ((p, pixel), &c) in kept.iter().zip(&of_point) {
        let r = root(&mut parent, c);
        let k = *cluster_of_root.entry(r).or_insert_with(|| {
            clusters.push(Segment { points: vec![], pixels: vec![] });
            clusters.len() - 1
        });
        clusters[k].points.push(*p);
        clusters[k].pixels.push(*pixel);
    }
    clusters.retain(|s| {
        let extent = (0..3).fold(0.0f64, |e, i| {
            let (a, b) =
                s.points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p[i]), b.max(p[i])));
            e.max(b - a)
        });
        let keep = s.points.len() >= settings.min_points && extent <= settings.max_extent;
        if !keep {
            report.rejected += s.points.len();
        }
        keep
    });
    Ok((clusters, report))
}
