//! A depth camera: intrinsics and where its optical frame sits, and the
//! depth images it takes.

use super::PerceptionError;
use crate::point_cloud::CameraIntrinsics;
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};

/// A pinhole depth camera (no distortion: a depth camera's driver
/// rectifies its images) placed in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthCamera {
    /// Image size, focal lengths and principal point (pixels; pixel
    /// centres at integer coordinates).
    pub intrinsics: CameraIntrinsics,
    /// The optical frame's pose in the world (REP 103 optical: z along
    /// the view, x right, y down in the image).
    pub pose: IsometryMatrix3<f64>,
}

impl DepthCamera {
    /// A camera at `eye` (world, m) looking at `target`, its image's up
    /// as close to `up` as the view allows.
    ///
    /// # Errors
    /// Intrinsics out of range or with distortion, `eye` on `target`, a
    /// view along `up`, or anything not finite.
    pub fn looking_at(
        intrinsics: CameraIntrinsics,
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
    ) -> Result<DepthCamera, PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("depth camera", None, m));
        let (e, t, u) = (Vector3::from(eye), Vector3::from(target), Vector3::from(up));
        let z = t - e;
        if !(z.norm() > 1e-9 && u.norm() > 1e-9 && z.iter().chain(u.iter()).all(|v| v.is_finite())) {
            return bad(format!("eye {eye:?}, target {target:?} and up {up:?} must be finite and distinct"));
        }
        let z = z.normalize();
        let x = z.cross(&u);
        if x.norm() < 1e-6 {
            return bad(format!("the view {z:?} runs along up {up:?}"));
        }
        let x = x.normalize();
        let y = z.cross(&x);
        let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
        DepthCamera::new(intrinsics, IsometryMatrix3::from_parts(Translation3::from(e), rotation))
    }

    /// The camera from its intrinsics and optical frame's pose.
    ///
    /// # Errors
    /// Intrinsics out of range or with distortion, a pose not finite.
    pub fn new(intrinsics: CameraIntrinsics, pose: IsometryMatrix3<f64>) -> Result<DepthCamera, PerceptionError> {
        intrinsics.validate().map_err(|e| PerceptionError::new("depth camera", None, e.message))?;
        if intrinsics.distortion != [0.0; 5] {
            return Err(PerceptionError::new(
                "depth camera",
                None,
                format!("distortion {:?}: a depth camera's image is rectified (give zeros)", intrinsics.distortion),
            ));
        }
        if !pose.to_homogeneous().iter().all(|v| v.is_finite()) {
            return Err(PerceptionError::new("depth camera", None, "the pose is not finite"));
        }
        Ok(DepthCamera { intrinsics, pose })
    }

    /// Pixels across and down.
    pub fn size(&self) -> (usize, usize) {
        (self.intrinsics.width as usize, self.intrinsics.height as usize)
    }

    /// The ray through pixel `(u, v)` in the optical frame, scaled so that
    /// its z is 1: a depth `d` is the point `d ·` this.
    pub fn ray(&self, u: f64, v: f64) -> [f64; 3] {
        let k = &self.intrinsics;
        [(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0]
    }

    /// The world point of pixel `(u, v)` at depth `d` (m).
    pub fn unproject(&self, u: f64, v: f64, d: f64) -> [f64; 3] {
        let r = self.ray(u, v);
        let p = self.pose * Point3::new(r[0] * d, r[1] * d, d);
        [p.x, p.y, p.z]
    }
}

/// A depth image: row-major depth along the optical axis (m), `NaN` where
/// the camera has no return (REP 118's convention for `32FC1`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DepthImage {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// Depth per pixel (m), `NaN` for none.
    pub depth: Vec<f32>,
}

impl DepthImage {
    /// An image with no returns.
    pub fn empty(width: usize, height: usize) -> DepthImage {
        DepthImage { width, height, depth: vec![f32::NAN; width * height] }
    }

    /// The depth at column `u`, row `v` (m; `NaN` for none).
    pub fn at(&self, u: usize, v: usize) -> f32 {
        self.depth[v * self.width + u]
    }

    /// Checks the image against `camera`: the same size, every depth NaN
    /// or finite and positive.
    ///
    /// # Errors
    /// The size or the first bad pixel, named.
    pub fn validate(&self, camera: &DepthCamera, origin: &str) -> Result<(), PerceptionError> {
        let (w, h) = camera.size();
        if (self.width, self.height) != (w, h) || self.depth.len() != w * h {
            return Err(PerceptionError::new(
                origin,
                None,
                format!(
                    "a {} × {} image ({} values) from a {w} × {h} camera",
                    self.width,
                    self.height,
                    self.depth.len()
                ),
            ));
        }
        if let Some(k) = self.depth.iter().position(|d| !(d.is_nan() || (d.is_finite() && *d > 0.0))) {
            return Err(PerceptionError::new(
                origin,
                None,
                format!(
                    "pixel ({}, {}) has depth {} m (NaN for none, else finite and positive)",
                    k % w,
                    k / w,
                    self.depth[k]
                ),
            ));
        }
        Ok(())
    }

    /// The world points of every pixel with a return, with their pixel
    /// index, appended to `out`.
    pub fn points(&self, camera: &DepthCamera, out: &mut Vec<([f64; 3], usize)>) {
        for (k, d) in self.depth.iter().enumerate() {
            if d.is_finite() {
                out.push((camera.unproject((k % self.width) as f64, (k / self.width) as f64, f64::from(*d)), k));
            }
        }
    }
}
