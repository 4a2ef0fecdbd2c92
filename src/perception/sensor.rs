//! A real depth camera's faults, applied to a perfect depth image: an
//! active-stereo camera modelled on the Intel RealSense D435.
//!
//! In the order the camera makes them:
//!
//! 1. **Stereo shadows.** Depth is matched between two imagers a baseline
//!    `B` apart, the image being the left one's; a surface the right
//!    imager cannot see has no depth. Pixel `u` of a row, of disparity
//!    `d(u) = f·B/z`, lands at `u − d(u)` in the right image; it is hidden
//!    when a pixel `u' > u` lands at or left of it (`u' − d(u') ≤ u −
//!    d(u)`: a nearer surface to its right), and unseen when `u − d(u) <
//!    0` (the D400 datasheet's invalid band at the left of the image).
//! 2. **Range.** Nothing nearer than `min_depth` (the D435's Min-Z, about
//!    17.5 cm at 640 × 480 by its datasheet's table, scaled from 28 cm at
//!    1280 × 720) or farther than `max_depth`.
//! 3. **Grazing surfaces.** Stereo matching fails on surfaces seen nearly
//!    edge-on: a pixel whose surface normal is `θ` from the ray is missing
//!    with a chance rising linearly from 0 at `grazing_start` to 1 at
//!    `grazing_end` (70° and 85° by default; the datasheet gives no
//!    figure: an assumption, stated).
//! 4. **Edges.** At a depth step of more than `edge_step` to a 4-neighbour
//!    the matcher's window straddles two surfaces; the nearer side keeps
//!    its depth, the farther pixel is missing with chance `edge_dropout`
//!    (an assumption: D400 images lose a pixel or so along object
//!    outlines).
//! 5. **Noise.** Depth RMS error `σ(z) = z²·s / (f·B)` (Intel's
//!    "Best-Known-Methods for Tuning Intel RealSense D400 Depth Cameras",
//!    Grunnet-Jepsen et al., 2018, its eq. for RMS error), with the
//!    subpixel RMS `s` = 0.08 px and the D435's baseline 50 mm: 4.2 mm at
//!    1 m with `f` = 385 px; Gaussian, independent per pixel.
//! 6. **Quantisation.** The driver's 16-bit depth unit, 1 mm by default.
//!
//! Every draw comes from one seeded generator, pixel by pixel in row
//! order: the same image and seed give the same bytes.

use super::PerceptionError;
use super::camera::{DepthCamera, DepthImage};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A depth camera's faults (see the module docs); the defaults are a
/// RealSense D435's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthSensorSettings {
    /// Stereo baseline (m; D435 50 mm). 0 turns stereo shadows off.
    pub baseline: f64,
    /// Subpixel RMS of the disparity (pixels; 0.08).
    pub subpixel_rms: f64,
    /// Nearest depth returned (m; 0.175).
    pub min_depth: f64,
    /// Farthest depth returned (m; 10).
    pub max_depth: f64,
    /// Incidence from which grazing pixels start to go missing (deg; 70).
    pub grazing_start_deg: f64,
    /// Incidence at which every pixel is missing (deg; 85).
    pub grazing_end_deg: f64,
    /// A depth step to a neighbour that makes an edge (m; 0.02).
    pub edge_step: f64,
    /// Chance that the far pixel of an edge is missing (0.5).
    pub edge_dropout: f64,
    /// Depth unit the image is rounded to (m; 0.001). 0 keeps every digit.
    pub depth_unit: f64,
}

impl Default for DepthSensorSettings {
    fn default() -> DepthSensorSettings {
        DepthSensorSettings {
            baseline: 0.050,
            subpixel_rms: 0.08,
            min_depth: 0.175,
            max_depth: 10.0,
            grazing_start_deg: 70.0,
            grazing_end_deg: 85.0,
            edge_step: 0.02,
            edge_dropout: 0.5,
            depth_unit: 0.001,
        }
    }
}

impl DepthSensorSettings {
    /// A perfect camera: no shadows, noise, dropouts or rounding (the
    /// range stays).
    pub fn ideal() -> DepthSensorSettings {
        DepthSensorSettings {
            baseline: 0.0,
            subpixel_rms: 0.0,
            grazing_start_deg: 90.0,
            grazing_end_deg: 90.0,
            edge_dropout: 0.0,
            depth_unit: 0.0,
            ..DepthSensorSettings::default()
        }
    }

    /// Checks every value.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("depth sensor settings", None, m));
        for (name, v) in [
            ("baseline", self.baseline),
            ("subpixel_rms", self.subpixel_rms),
            ("min_depth", self.min_depth),
            ("edge_step", self.edge_step),
            ("depth_unit", self.depth_unit),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} {v} must be finite and at least 0"));
            }
        }
        if self.max_depth.is_nan() || self.max_depth <= self.min_depth {
            return bad(format!("max_depth {} must exceed min_depth {}", self.max_depth, self.min_depth));
        }
        if !(0.0 <= self.grazing_start_deg
            && self.grazing_start_deg <= self.grazing_end_deg
            && self.grazing_end_deg <= 90.0)
        {
            return bad(format!(
                "grazing_start_deg {} and grazing_end_deg {} must satisfy 0 ≤ start ≤ end ≤ 90",
                self.grazing_start_deg, self.grazing_end_deg
            ));
        }
        if !(0.0..=1.0).contains(&self.edge_dropout) {
            return bad(format!("edge_dropout {} must lie in [0, 1]", self.edge_dropout));
        }
        Ok(())
    }

    /// The depth RMS error at depth `z` (m) for focal length `f` (px).
    pub fn depth_rms(&self, z: f64, f: f64) -> f64 {
        if self.baseline > 0.0 { z * z * self.subpixel_rms / (f * self.baseline) } else { 0.0 }
    }
}

/// What the camera returns for the perfect image `ideal` of `camera`:
/// `cos_incidence` is, per pixel, the cosine of the angle between the
/// surface normal and the ray (NaN where `ideal` has no return); `seed`
/// draws the noise and the dropouts. The result goes to `out` (resized).
///
/// # Errors
/// Settings out of range, or images of another size than the camera's.
pub fn apply_sensor_model(
    camera: &DepthCamera,
    ideal: &DepthImage,
    cos_incidence: &[f32],
    settings: &DepthSensorSettings,
    seed: u64,
    out: &mut DepthImage,
) -> Result<(), PerceptionError> {
    settings.validate()?;
    ideal.validate(camera, "ideal depth image")?;
    let (w, h) = camera.size();
    if cos_incidence.len() != w * h {
        return Err(PerceptionError::new(
            "depth sensor",
            None,
            format!("{} incidence values for {w} × {h} pixels", cos_incidence.len()),
        ));
    }
    out.width = w;
    out.height = h;
    out.depth.clear();
    out.depth.extend_from_slice(&ideal.depth);
    let f = camera.intrinsics.fx;
    // 1. Stereo shadows and the left band, right to left along each row.
    if settings.baseline > 0.0 {
        for v in 0..h {
            let row = &mut out.depth[v * w..(v + 1) * w];
            let mut leftmost = f64::INFINITY;
            for u in (0..w).rev() {
                let z = f64::from(ideal.depth[v * w + u]);
                if !z.is_finite() {
                    continue;
                }
                let landing = u as f64 - f * settings.baseline / z;
                if landing < 0.0 || leftmost <= landing {
                    row[u] = f32::NAN;
                }
                leftmost = leftmost.min(landing);
            }
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (cos_start, cos_end) =
        (settings.grazing_start_deg.to_radians().cos(), settings.grazing_end_deg.to_radians().cos());
    // By index: a pixel's four neighbours are read beside it.
    #[allow(clippy::needless_range_loop)]
    for k in 0..w * h {
        let z = f64::from(out.depth[k]);
        if !z.is_finite() {
            continue;
        }
        // 2. Range.
        if z < settings.min_depth || z > settings.max_depth {
            out.depth[k] = f32::NAN;
            continue;
        }
        // 3. Grazing surfaces.
        let c = f64::from(cos_incidence[k]).abs();
        if c < cos_start {
            let chance = if cos_start > cos_end { ((cos_start - c) / (cos_start - cos_end)).min(1.0) } else { 1.0 };
            if rng.random_range(0.0..1.0) < chance {
                out.depth[k] = f32::NAN;
                continue;
            }
        }
        // 4. Edges: the far side of a step to a 4-neighbour.
        if settings.edge_dropout > 0.0 {
            let (u, v) = (k % w, k / w);
            let ideal_z = f64::from(ideal.depth[k]);
            let nearer = |j: usize| f64::from(ideal.depth[j]) < ideal_z - settings.edge_step;
            let edge = (u > 0 && nearer(k - 1))
                || (u + 1 < w && nearer(k + 1))
                || (v > 0 && nearer(k - w))
                || (v + 1 < h && nearer(k + w));
            if edge && rng.random_range(0.0..1.0) < settings.edge_dropout {
                out.depth[k] = f32::NAN;
                continue;
            }
        }
        // 5. Noise, 6. quantisation.
        let mut d = z + settings.depth_rms(z, f) * standard_normal(&mut rng);
        if settings.depth_unit > 0.0 {
            d = (d / settings.depth_unit).round() * settings.depth_unit;
        }
        out.depth[k] = if d > 0.0 { d as f32 } else { f32::NAN };
    }
    Ok(())
}

/// A standard normal draw (Box-Muller, one of the pair).
pub(crate) fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}
