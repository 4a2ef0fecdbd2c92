//! From a segment to a labelled pose: which of the known objects it is,
//! and where.
//!
//! Each object of the [`ObjectLibrary`] is fitted to the segment's points
//! from a few upright hypotheses (the object resting on the table, its
//! base at the table's height, turned about the vertical through the
//! segment's centroid: [`EstimateSettings::yaw_hypotheses`] over the
//! object's symmetry period) by point-to-plane ICP. A fit is scored
//! twice:
//!
//! - **fit**: the share of the segment's points within
//!   [`EstimateSettings::inlier_distance`] of the posed model's surface;
//! - **explained**: the model rendered at its pose into the image
//!   window of the segment, pixel by pixel against the measured depth
//!   (DBOT's reasoning): a model surface *in front of* a measured one is
//!   fine (the model is occluded), one *behind* it where the camera saw
//!   farther is a contradiction (the camera looked through where the
//!   model would be). `explained` is the share of the model's pixels that
//!   are seen or occluded, not contradicted.
//!
//! The label is the object of the best `fit × explained`; below
//! [`EstimateSettings::min_score`] the segment is *not detected* — no pose
//! is made up. The dissertation's *mesh_pose* (rigid CPD from the mask's
//! centroid, §7.4.1) is [`mesh_pose`]; [`mask_pose`] is its baseline.

use super::PerceptionError;
use super::camera::{DepthCamera, DepthImage};
use super::cpd::{CpdSettings, CpdWorkspace, rigid_cpd};
use super::icp::{IcpSettings, SurfaceModel, point_to_plane_icp};
use super::objects::{ObjectModel, Symmetry};
use super::render::{PixelWindow, RenderSettings, RenderWorkspace, render_mesh};
use super::segment::Segment;
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3};

/// The known objects, each with its registration models sampled once.
#[derive(Debug, Clone)]
pub struct ObjectLibrary {
    entries: Vec<LibraryEntry>,
}

#[derive(Debug, Clone)]
struct LibraryEntry {
    object: ObjectModel,
    /// Dense surface samples with normals, for ICP and scoring.
    surface: SurfaceModel,
    /// A few hundred samples, for CPD.
    sparse: Vec<[f64; 3]>,
}

impl ObjectLibrary {
    /// The library of `objects`: 3,000 surface samples each for ICP and
    /// scoring, 200 for CPD (seeded: the same library every time).
    ///
    /// # Errors
    /// An object whose mesh has no area.
    pub fn new(objects: Vec<ObjectModel>) -> Result<ObjectLibrary, PerceptionError> {
        let mut entries = Vec::with_capacity(objects.len());
        for (i, object) in objects.into_iter().enumerate() {
            let samples = object.mesh.sample_surface_with_normals(3000, 0x000B_1EC7 + i as u64);
            let (points, normals) = samples.into_iter().unzip();
            let surface =
                SurfaceModel::new(points, normals).map_err(|e| PerceptionError::new(object.name, None, e.message))?;
            let sparse = object.mesh.sample_surface(200, 0xC0DE + i as u64);
            entries.push(LibraryEntry { object, surface, sparse });
        }
        Ok(ObjectLibrary { entries })
    }

    /// The objects, in the library's order.
    pub fn objects(&self) -> impl ExactSizeIterator<Item = &ObjectModel> {
        self.entries.iter().map(|e| &e.object)
    }

    /// Object `k`.
    pub fn object(&self, k: usize) -> &ObjectModel {
        &self.entries[k].object
    }

    /// Object `k`'s dense surface model.
    pub fn surface(&self, k: usize) -> &SurfaceModel {
        &self.entries[k].surface
    }

    /// How many objects.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Settings of detection and pose estimation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateSettings {
    /// Height of the table's top (world z, m): the hypotheses' base.
    pub table_height: f64,
    /// Yaw hypotheses over an object's symmetry period (default 12; one
    /// for an object of revolution).
    pub yaw_hypotheses: usize,
    /// A point within this of the model's surface fits (m, default 0.005).
    pub inlier_distance: f64,
    /// A model pixel contradicts the image when the camera saw farther by
    /// more than this (m, default 0.015).
    pub free_space_tolerance: f64,
    /// The least `fit × explained` of a detection (default 0.55).
    pub min_score: f64,
    /// ICP of each hypothesis.
    pub icp: IcpSettings,
    /// CPD of [`mesh_pose`].
    pub cpd: CpdSettings,
    /// The most segment points registered (evenly thinned; default 400).
    pub max_points: usize,
}

impl EstimateSettings {
    /// The defaults for a table whose top is at `table_height` (m).
    pub fn for_table(table_height: f64) -> EstimateSettings {
        EstimateSettings {
            table_height,
            yaw_hypotheses: 12,
            inlier_distance: 0.005,
            free_space_tolerance: 0.015,
            min_score: 0.55,
            icp: IcpSettings { max_iterations: 30, max_correspondence_distance: 0.02, ..IcpSettings::default() },
            cpd: CpdSettings { max_iterations: 60, tolerance: 1e-6, ..CpdSettings::default() },
            max_points: 400,
        }
    }
}

/// A segment labelled and posed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// The object (index into the library).
    pub object: usize,
    /// Its pose in the world.
    pub pose: IsometryMatrix3<f64>,
    /// `fit × explained` (see the module docs).
    pub score: f64,
    /// Share of the segment's points on the model's surface.
    pub fit: f64,
    /// Share of the model's pixels not contradicted by the image.
    pub explained: f64,
}

/// Scratch of estimation.
#[derive(Debug, Clone, Default)]
pub struct EstimateWorkspace {
    render: RenderWorkspace,
    window: Vec<f32>,
    cpd: CpdWorkspace,
}

/// The segment's centroid, the dissertation's *mask_pose*: a position
/// without a rotation (identity).
pub fn mask_pose(segment: &Segment) -> IsometryMatrix3<f64> {
    let c = segment.centroid();
    IsometryMatrix3::translation(c[0], c[1], c[2])
}

/// Labels `segment` and estimates its pose (see the module docs), or
/// `None`: not detected.
///
/// # Errors
/// An empty segment.
pub fn detect(
    segment: &Segment,
    camera: &DepthCamera,
    image: &DepthImage,
    library: &ObjectLibrary,
    settings: &EstimateSettings,
    ws: &mut EstimateWorkspace,
) -> Result<Option<Detection>, PerceptionError> {
    let points = thinned(segment, settings.max_points)?;
    let mut best: Option<Detection> = None;
    for k in 0..library.len() {
        let d = fit_points(segment, &points, camera, image, library, k, settings, ws)?;
        if best.is_none_or(|b| d.score > b.score) {
            best = Some(d);
        }
    }
    Ok(best.filter(|b| b.score >= settings.min_score))
}

/// Object `k` fitted to the segment: the best ICP fit over the upright
/// hypotheses, scored (see the module docs), whatever its score.
///
/// # Errors
/// An empty segment.
pub fn fit_object(
    segment: &Segment,
    camera: &DepthCamera,
    image: &DepthImage,
    library: &ObjectLibrary,
    k: usize,
    settings: &EstimateSettings,
    ws: &mut EstimateWorkspace,
) -> Result<Detection, PerceptionError> {
    let points = thinned(segment, settings.max_points)?;
    fit_points(segment, &points, camera, image, library, k, settings, ws)
}

#[allow(clippy::too_many_arguments)]
fn fit_points(
    segment: &Segment,
    points: &[[f64; 3]],
    camera: &DepthCamera,
    image: &DepthImage,
    library: &ObjectLibrary,
    k: usize,
    settings: &EstimateSettings,
    ws: &mut EstimateWorkspace,
) -> Result<Detection, PerceptionError> {
    let mut best: Option<Detection> = None;
    for start in hypotheses(segment, camera, library.object(k), settings) {
        let r = point_to_plane_icp(library.surface(k), points, &start, &settings.icp)?;
        let d = score(segment, points, camera, image, library, k, &r.pose, settings, ws);
        if best.is_none_or(|b| d.score > b.score) {
            best = Some(d);
        }
    }
    Ok(best.expect("at least one hypothesis"))
}

/// The dissertation's *mesh_pose* of object `k`: rigid CPD of the
/// object's samples onto the segment from each upright hypothesis, the
/// best scored.
///
/// # Errors
/// An empty segment, CPD refusing the points.
pub fn mesh_pose(
    segment: &Segment,
    camera: &DepthCamera,
    image: &DepthImage,
    library: &ObjectLibrary,
    k: usize,
    settings: &EstimateSettings,
    ws: &mut EstimateWorkspace,
) -> Result<Detection, PerceptionError> {
    let points = thinned(segment, settings.max_points.min(300))?;
    let mut best: Option<Detection> = None;
    for start in hypotheses(segment, camera, library.object(k), settings) {
        let initial = (*start.rotation.matrix(), start.translation.vector, 1.0);
        let r = rigid_cpd(&points, &library.entries[k].sparse, initial, &settings.cpd, &mut ws.cpd)?;
        let pose = IsometryMatrix3::from_parts(
            Translation3::from(r.translation),
            Rotation3::from_matrix_unchecked(r.rotation),
        );
        let d = score(segment, &points, camera, image, library, k, &pose, settings, ws);
        if best.is_none_or(|b| d.score > b.score) {
            best = Some(d);
        }
    }
    Ok(best.expect("at least one hypothesis"))
}

/// At most `max` of the segment's points, evenly spaced in its order.
fn thinned(segment: &Segment, max: usize) -> Result<Vec<[f64; 3]>, PerceptionError> {
    if segment.points.is_empty() {
        return Err(PerceptionError::new("detection", None, "an empty segment"));
    }
    let stride = segment.points.len().div_ceil(max.max(1));
    Ok(segment.points.iter().step_by(stride).copied().collect())
}

/// The upright starts: base on the table under the segment's centroid and
/// behind it (seen from the camera, the visible surface of a solid lies
/// about 0.6 of its half-width in front of its axis, 2/π for a cylinder;
/// that of an open bowl, whose far inner wall is seen too, nearer the
/// axis), yaws over the symmetry period.
fn hypotheses(
    segment: &Segment,
    camera: &DepthCamera,
    object: &ObjectModel,
    settings: &EstimateSettings,
) -> Vec<IsometryMatrix3<f64>> {
    let c = segment.centroid();
    let (lo, hi) = object.mesh.bounds();
    let half_width = 0.5 * (hi[0] - lo[0]).min(hi[1] - lo[1]);
    let eye = camera.pose.translation.vector;
    let away = nalgebra::Vector2::new(c[0] - eye.x, c[1] - eye.y);
    let away = if away.norm() > 1e-9 { away.normalize() } else { nalgebra::Vector2::zeros() };
    let (count, period) = match object.symmetry {
        Symmetry::RevolutionZ | Symmetry::Sphere => (1, 0.0),
        Symmetry::Cube => (settings.yaw_hypotheses.div_ceil(4).max(1), std::f64::consts::FRAC_PI_2),
        Symmetry::None => (settings.yaw_hypotheses.max(1), std::f64::consts::TAU),
    };
    let mut starts = Vec::with_capacity(2 * count);
    for behind in [0.0, 0.6 * half_width] {
        for i in 0..count {
            starts.push(IsometryMatrix3::from_parts(
                Translation3::new(c[0] + behind * away.x, c[1] + behind * away.y, settings.table_height),
                Rotation3::from_euler_angles(0.0, 0.0, period * i as f64 / count as f64),
            ));
        }
    }
    starts
}

/// `fit` and `explained` of object `k` at `pose` (see the module docs).
#[allow(clippy::too_many_arguments)]
fn score(
    segment: &Segment,
    points: &[[f64; 3]],
    camera: &DepthCamera,
    image: &DepthImage,
    library: &ObjectLibrary,
    k: usize,
    pose: &IsometryMatrix3<f64>,
    settings: &EstimateSettings,
    ws: &mut EstimateWorkspace,
) -> Detection {
    let inv = pose.inverse();
    let surface = library.surface(k);
    let inliers = points
        .iter()
        .filter(|p| {
            let q = inv * Point3::from(**p);
            // Near a sample (within twice the distance: samples lie a few
            // mm apart) and near its tangent plane.
            surface.nearest(&[q.x, q.y, q.z], settings.inlier_distance * 2.0).is_some_and(|(i, _)| {
                let (n, y) = (surface.normals()[i], surface.points()[i]);
                ((q.x - y[0]) * n[0] + (q.y - y[1]) * n[1] + (q.z - y[2]) * n[2]).abs() <= settings.inlier_distance
            })
        })
        .count();
    let fit = inliers as f64 / points.len() as f64;
    // The model's pixels in a window around the segment, grown by half its size.
    let (w, h) = camera.size();
    let (mut u0, mut v0, mut u1, mut v1) = (w, h, 0, 0);
    for &px in &segment.pixels {
        let (u, v) = (px % w, px / w);
        (u0, v0, u1, v1) = (u0.min(u), v0.min(v), u1.max(u + 1), v1.max(v + 1));
    }
    let (gu, gv) = ((u1 - u0) / 2 + 2, (v1 - v0) / 2 + 2);
    let window = PixelWindow {
        u0: u0.saturating_sub(gu),
        v0: v0.saturating_sub(gv),
        u1: (u1 + gu).min(w),
        v1: (v1 + gv).min(h),
    };
    ws.window.clear();
    ws.window.resize(window.width() * window.height(), f32::NAN);
    render_mesh(
        camera,
        &library.object(k).mesh,
        pose,
        window,
        &RenderSettings::default(),
        &mut ws.render,
        &mut ws.window,
    );
    let (mut drawn, mut contradicted) = (0usize, 0usize);
    let tol = settings.free_space_tolerance as f32;
    for v in window.v0..window.v1 {
        for u in window.u0..window.u1 {
            let model = ws.window[(v - window.v0) * window.width() + (u - window.u0)];
            if model.is_nan() {
                continue;
            }
            drawn += 1;
            let seen = image.depth[v * w + u];
            if seen.is_finite() && seen > model + tol {
                contradicted += 1;
            }
        }
    }
    let explained = if drawn > 0 { 1.0 - contradicted as f64 / drawn as f64 } else { 0.0 };
    Detection { object: k, pose: *pose, score: fit * explained, fit, explained }
}
