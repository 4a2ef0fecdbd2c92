//! Depth images to points: a pinhole camera with `plumb_bob` distortion
//! (the models of ROS's `sensor_msgs/CameraInfo` and OpenCV), depth as the
//! z coordinate of each pixel's point in the camera's optical frame (REP
//! 118: z forward, x right, y down; m).
//!
//! A pixel's ray is its undistorted normalised image coordinate: the
//! inverse of the plumb_bob model by fixed-point iteration (the way
//! OpenCV's `undistortPoints` inverts it), computed once per camera
//! ([`DepthProjection::new`]) so that a frame costs a multiply per
//! coordinate.

use super::{PointCloud, PointCloudError};

/// A camera's intrinsics (pixels): the image size, the focal lengths and
/// principal point of `K` (integer pixel coordinates at pixel centres, as
/// in OpenCV and ROS), and the plumb_bob distortion `k1, k2, p1, p2, k3`
/// (all zero for a pinhole camera or a rectified image).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraIntrinsics {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// plumb_bob distortion: radial k1, k2, tangential p1, p2, radial k3.
    pub distortion: [f64; 5],
}

impl CameraIntrinsics {
    /// A RealSense D435's depth stream at 640 × 480, as its driver reports
    /// it (fx = fy ≈ 385 px, no distortion: the depth image is
    /// rectified): a typical camera for tests and examples.
    pub fn realsense_d435_640x480() -> CameraIntrinsics {
        CameraIntrinsics { width: 640, height: 480, fx: 385.0, fy: 385.0, cx: 320.0, cy: 240.0, distortion: [0.0; 5] }
    }

    /// Checks the intrinsics: a size of at least one pixel, focal lengths
    /// finite and positive, principal point and distortion finite.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), PointCloudError> {
        let bad = |m: String| Err(PointCloudError::new("camera intrinsics", None, m));
        if self.width == 0 || self.height == 0 {
            return bad(format!("an image of {} × {} pixels", self.width, self.height));
        }
        if !(self.fx.is_finite() && self.fx > 0.0 && self.fy.is_finite() && self.fy > 0.0) {
            return bad(format!("focal lengths fx {} and fy {} must be finite and positive", self.fx, self.fy));
        }
        if !(self.cx.is_finite() && self.cy.is_finite() && self.distortion.iter().all(|d| d.is_finite())) {
            return bad(format!(
                "principal point ({}, {}) and distortion {:?} must be finite",
                self.cx, self.cy, self.distortion
            ));
        }
        Ok(())
    }

    /// The plumb_bob model: the distorted normalised coordinate of the
    /// undistorted `(x, y)`.
    fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = self.distortion;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        (
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// The pixel (u, v) a point of the optical frame (m, z > 0) images to,
    /// distortion included; `None` behind the camera.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        if p[2].is_nan() || p[2] <= 0.0 {
            return None;
        }
        let (x, y) = self.distort(p[0] / p[2], p[1] / p[2]);
        Some([self.fx * x + self.cx, self.fy * y + self.cy])
    }

    /// The undistorted normalised coordinate (x, y) of pixel (u, v): the
    /// ray through it is (x, y, 1). Fixed-point iteration from the
    /// distorted coordinate until it moves less than 1e-14, at most 100
    /// steps (it converges for the distortions real lenses have; tested
    /// to 1e-10 against [`Self::project`]).
    pub fn ray(&self, u: f64, v: f64) -> [f64; 2] {
        let (x0, y0) = ((u - self.cx) / self.fx, (v - self.cy) / self.fy);
        if self.distortion == [0.0; 5] {
            return [x0, y0];
        }
        let [k1, k2, p1, p2, k3] = self.distortion;
        let (mut x, mut y) = (x0, y0);
        for _ in 0..100 {
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            let (nx, ny) = ((x0 - dx) / radial, (y0 - dy) / radial);
            let moved = (nx - x).abs().max((ny - y).abs());
            (x, y) = (nx, ny);
            if moved < 1e-14 {
                break;
            }
        }
        [x, y]
    }
}

/// A camera's per-pixel rays, computed once: turns depth images of that
/// camera into points without a division or an iteration per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthProjection {
    intrinsics: CameraIntrinsics,
    /// Row-major, one (x, y) per pixel: the ray (x, y, 1).
    rays: Vec<[f64; 2]>,
}

impl DepthProjection {
    /// The rays of `intrinsics`' every pixel (allocates width × height).
    ///
    /// # Errors
    /// Intrinsics out of range ([`CameraIntrinsics::validate`]).
    pub fn new(intrinsics: CameraIntrinsics) -> Result<DepthProjection, PointCloudError> {
        intrinsics.validate()?;
        let (w, h) = (intrinsics.width as usize, intrinsics.height as usize);
        let rays = (0..w * h).map(|k| intrinsics.ray((k % w) as f64, (k / w) as f64)).collect();
        Ok(DepthProjection { intrinsics, rays })
    }

    /// The camera.
    pub fn intrinsics(&self) -> &CameraIntrinsics {
        &self.intrinsics
    }

    /// The points of a depth image of this camera, in its optical frame
    /// (m), appended to `out`: `depth(k)` is pixel `k`'s depth (row-major,
    /// m along the optical axis). A depth that is not finite and positive
    /// is a missing pixel (REP 118: NaN, or 0 in millimetre images),
    /// counted in `out.dropped`. `stride` takes every stride-th pixel of
    /// every stride-th row (1: all).
    pub fn points(&self, depth: impl Fn(usize) -> f64, stride: usize, out: &mut PointCloud) {
        let (w, h) = (self.intrinsics.width as usize, self.intrinsics.height as usize);
        let stride = stride.max(1);
        for row in (0..h).step_by(stride) {
            for col in (0..w).step_by(stride) {
                let k = row * w + col;
                let z = depth(k);
                if z.is_finite() && z > 0.0 {
                    let [x, y] = self.rays[k];
                    out.points.push([x * z, y * z, z]);
                } else {
                    out.dropped += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lens with the distortion of a Kinect-class camera (its published
    /// calibrations have k1 ≈ 0.1–0.2 and small tangential terms).
    fn distorted() -> CameraIntrinsics {
        CameraIntrinsics {
            width: 64,
            height: 48,
            fx: 58.0,
            fy: 57.5,
            cx: 31.7,
            cy: 24.2,
            distortion: [0.18, -0.32, 0.0012, -0.0008, 0.11],
        }
    }

    #[test]
    fn rays_invert_the_distortion_and_points_image_to_their_pixel() {
        let camera = distorted();
        let projection = DepthProjection::new(camera).unwrap();
        let mut worst = 0.0f64;
        for v in 0..camera.height {
            for u in 0..camera.width {
                let [x, y] = camera.ray(u as f64, v as f64);
                let [pu, pv] = camera.project([x * 1.3, y * 1.3, 1.3]).unwrap();
                worst = worst.max((pu - u as f64).abs()).max((pv - v as f64).abs());
            }
        }
        assert!(worst < 1e-10, "a pixel's ray images {worst} px away from it");
        // A plane 1.5 m away: every point at its depth, on its pixel's ray.
        let mut cloud = PointCloud::default();
        projection.points(
            |k| {
                if k == 5 {
                    f64::NAN
                } else if k == 6 {
                    0.0
                } else {
                    1.5
                }
            },
            1,
            &mut cloud,
        );
        assert_eq!((cloud.len(), cloud.dropped), (64 * 48 - 2, 2));
        assert!(cloud.points.iter().all(|p| p[2] == 1.5));
        let mut strided = PointCloud::default();
        projection.points(|_| 1.0, 4, &mut strided);
        assert_eq!(strided.len(), 16 * 12);
    }

    #[test]
    fn a_pinhole_ray_is_the_normalised_coordinate() {
        let camera = CameraIntrinsics::realsense_d435_640x480();
        assert_eq!(camera.ray(320.0, 240.0), [0.0, 0.0]);
        assert_eq!(camera.ray(705.0, 240.0), [1.0, 0.0]);
        for bad in [
            CameraIntrinsics { width: 0, ..camera },
            CameraIntrinsics { fx: 0.0, ..camera },
            CameraIntrinsics { fy: f64::NAN, ..camera },
            CameraIntrinsics { distortion: [f64::INFINITY, 0.0, 0.0, 0.0, 0.0], ..camera },
        ] {
            assert!(DepthProjection::new(bad).is_err(), "{bad:?}");
        }
    }
}
