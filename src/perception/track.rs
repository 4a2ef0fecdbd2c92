//! A particle filter over an object's 6-D pose with a depth-image
//! likelihood, in the manner of DBOT's particle tracker (Wüthrich, Pastor
//! et al., "Probabilistic Object Tracking Using a Range Camera", IROS
//! 2013; Issac et al., ICRA 2016), which the dissertation runs after
//! *mesh_pose* (§7.4.2).
//!
//! **Motion.** Between frames each particle's pose takes a Brownian step:
//! a rotation about a random axis and a translation, Gaussian with
//! [`TrackSettings::rotation_noise`] and [`TrackSettings::translation_noise`]
//! per frame (an object that may be pushed, not one known to be still).
//!
//! **Likelihood.** The object's mesh is rendered at each particle's pose
//! into a coarse copy of the camera (every
//! [`TrackSettings::pixel_stride`]-th pixel each way) around the object;
//! each pixel the model covers contributes the log-ratio of two
//! explanations of the measured depth `z` against the model's `d`:
//!
//! - *the object is there*: `z` near `d` — a Gaussian of the sensor's
//!   σ(d) mixed with a uniform tail of weight
//!   [`TrackSettings::outlier_weight`] (a robust per-pixel likelihood);
//!   `z` well in front of `d` (by more than
//!   [`TrackSettings::occlusion_margin`]) is *occlusion* by something else
//!   (an arm, another object) and explains nothing either way;
//! - *it is not*: `z` uniform over the camera's range.
//!
//! A model pixel where the camera saw *through* the model (`z` far behind
//! `d`) scores the tail alone, so particles are pushed off free space; a
//! pixel with no depth explains nothing. Pixels the model does not cover
//! add 0: each particle is compared with the same background, whatever
//! its size on the image.
//!
//! **Resampling.** Systematic, when the effective sample size falls under
//! half the particles. The estimate is the weighted mean: positions
//! averaged, rotations by the weighted quaternion mean (signs aligned to
//! the best particle's).
//!
//! After [`Tracker::new`] a frame allocates nothing; every draw comes from
//! the tracker's seeded generator.

use super::PerceptionError;
use super::camera::{DepthCamera, DepthImage};
use super::mesh::TriangleMesh;
use super::render::{PixelWindow, RenderSettings, RenderWorkspace, render_mesh};
use super::sensor::{DepthSensorSettings, standard_normal};
use crate::point_cloud::CameraIntrinsics;
use nalgebra::{IsometryMatrix3, Point3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Settings of the particle tracker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSettings {
    /// Particles (default 100).
    pub particles: usize,
    /// Translation noise per frame, per axis (m, default 0.002).
    pub translation_noise: f64,
    /// Rotation noise per frame, about each axis (rad, default 0.02).
    pub rotation_noise: f64,
    /// The likelihood's image: every this-many-th pixel each way (default 4).
    pub pixel_stride: usize,
    /// Weight of a pixel's uniform outlier tail (default 0.1).
    pub outlier_weight: f64,
    /// A measured depth this much in front of the model is occlusion (m,
    /// default 0.02).
    pub occlusion_margin: f64,
    /// Extra σ on the sensor's (m, default 0.003): the mesh is not the
    /// object to the millimetre.
    pub model_noise: f64,
    /// The sensor whose noise the likelihood expects.
    pub sensor: DepthSensorSettings,
    /// Each pixel's log-likelihood is multiplied by this (tempering the
    /// product over pixels, whose errors are not independent; default 0.5).
    pub pixel_weight: f64,
}

impl Default for TrackSettings {
    fn default() -> TrackSettings {
        TrackSettings {
            particles: 100,
            translation_noise: 0.002,
            rotation_noise: 0.02,
            pixel_stride: 4,
            outlier_weight: 0.1,
            occlusion_margin: 0.02,
            model_noise: 0.003,
            sensor: DepthSensorSettings::default(),
            pixel_weight: 0.5,
        }
    }
}

impl TrackSettings {
    /// Checks every value.
    ///
    /// # Errors
    /// The first value out of range, named.
    pub fn validate(&self) -> Result<(), PerceptionError> {
        let bad = |m: String| Err(PerceptionError::new("track settings", None, m));
        if self.particles == 0 || self.pixel_stride == 0 {
            return bad(format!(
                "particles {} and pixel_stride {} must be at least 1",
                self.particles, self.pixel_stride
            ));
        }
        for (name, v) in [
            ("translation_noise", self.translation_noise),
            ("rotation_noise", self.rotation_noise),
            ("occlusion_margin", self.occlusion_margin),
            ("model_noise", self.model_noise),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} {v} must be finite and at least 0"));
            }
        }
        if !(self.outlier_weight > 0.0 && self.outlier_weight < 1.0) {
            return bad(format!("outlier_weight {} must lie in (0, 1)", self.outlier_weight));
        }
        if !(self.pixel_weight > 0.0 && self.pixel_weight <= 1.0) {
            return bad(format!("pixel_weight {} must lie in (0, 1]", self.pixel_weight));
        }
        self.sensor.validate()
    }
}

/// One object's particle tracker.
#[derive(Debug, Clone)]
pub struct Tracker {
    settings: TrackSettings,
    mesh: TriangleMesh,
    /// The mesh's farthest vertex from its origin (m): its bounding sphere.
    radius: f64,
    /// The coarse camera of the likelihood.
    coarse: DepthCamera,
    poses: Vec<IsometryMatrix3<f64>>,
    spare: Vec<IsometryMatrix3<f64>>,
    log_weights: Vec<f64>,
    weights: Vec<f64>,
    /// The measured depth at the coarse pixels.
    measured: Vec<f32>,
    window: Vec<f32>,
    render: RenderWorkspace,
    rng: ChaCha8Rng,
    estimate: IsometryMatrix3<f64>,
}

impl Tracker {
    /// A tracker of `mesh` for images of `camera`, its particles spread
    /// around `initial` by one frame's motion noise; `seed` draws
    /// everything after.
    ///
    /// # Errors
    /// Settings out of range, a pose not finite.
    pub fn new(
        mesh: TriangleMesh,
        camera: &DepthCamera,
        initial: IsometryMatrix3<f64>,
        settings: TrackSettings,
        seed: u64,
    ) -> Result<Tracker, PerceptionError> {
        settings.validate()?;
        if !initial.to_homogeneous().iter().all(|v| v.is_finite()) {
            return Err(PerceptionError::new("tracker", None, "the initial pose is not finite"));
        }
        let s = settings.pixel_stride as f64;
        let k = camera.intrinsics;
        // Coarse pixel (i, j) is the fine pixel (s·i, s·j): same rays.
        let coarse_k = CameraIntrinsics {
            width: k.width.div_ceil(settings.pixel_stride as u32),
            height: k.height.div_ceil(settings.pixel_stride as u32),
            fx: k.fx / s,
            fy: k.fy / s,
            cx: k.cx / s,
            cy: k.cy / s,
            distortion: [0.0; 5],
        };
        let coarse = DepthCamera::new(coarse_k, camera.pose)?;
        let (w, h) = coarse.size();
        let n = settings.particles;
        let radius = mesh.vertices.iter().map(|v| Vector3::from(*v).norm()).fold(0.0, f64::max);
        let mut tracker = Tracker {
            settings,
            mesh,
            radius,
            coarse,
            poses: vec![initial; n],
            spare: vec![initial; n],
            log_weights: vec![0.0; n],
            weights: vec![1.0 / n as f64; n],
            measured: vec![f32::NAN; w * h],
            window: vec![f32::NAN; w * h],
            render: RenderWorkspace::default(),
            rng: ChaCha8Rng::seed_from_u64(seed),
            estimate: initial,
        };
        for i in 1..n {
            tracker.poses[i] = tracker.diffused(&initial);
        }
        Ok(tracker)
    }

    /// The current estimate of the object's pose in the world.
    pub fn estimate(&self) -> IsometryMatrix3<f64> {
        self.estimate
    }

    /// The particles' poses and normalised weights.
    pub fn particles(&self) -> impl Iterator<Item = (&IsometryMatrix3<f64>, f64)> {
        self.poses.iter().zip(self.weights.iter().copied())
    }

    /// One frame: diffuse, weigh by `image` (of the camera given at
    /// construction), resample if needed; returns the new estimate.
    ///
    /// # Errors
    /// An image of another size than the camera's.
    pub fn update(&mut self, image: &DepthImage) -> Result<IsometryMatrix3<f64>, PerceptionError> {
        let s = self.settings.pixel_stride;
        let (cw, ch) = self.coarse.size();
        if image.width.div_ceil(s) != cw
            || image.height.div_ceil(s) != ch
            || image.depth.len() != image.width * image.height
        {
            return Err(PerceptionError::new(
                "tracker",
                None,
                format!("a {} × {} image for a camera of {} × {} coarse pixels", image.width, image.height, cw, ch),
            ));
        }
        for v in 0..ch {
            for u in 0..cw {
                self.measured[v * cw + u] = image.depth[v * s * image.width + u * s];
            }
        }
        for i in 0..self.poses.len() {
            let pose = self.poses[i];
            let moved = self.diffused(&pose);
            self.poses[i] = moved;
            self.log_weights[i] += self.log_likelihood(i);
        }
        self.normalise();
        self.estimate = self.mean();
        let ess = 1.0 / self.weights.iter().map(|w| w * w).sum::<f64>();
        if ess < 0.5 * self.poses.len() as f64 {
            self.resample();
        }
        Ok(self.estimate)
    }

    /// `pose` moved by one frame's noise.
    fn diffused(&mut self, pose: &IsometryMatrix3<f64>) -> IsometryMatrix3<f64> {
        let (t, r) = (self.settings.translation_noise, self.settings.rotation_noise);
        let mut draw = || standard_normal(&mut self.rng);
        let dt = Vector3::new(draw() * t, draw() * t, draw() * t);
        let dr = Vector3::new(draw() * r, draw() * r, draw() * r);
        // Rotation about the object's own origin, then the translation in the world.
        IsometryMatrix3::from_parts(
            Translation3::from(pose.translation.vector + dt),
            Rotation3::new(dr) * pose.rotation,
        )
    }

    /// The log-likelihood ratio of particle `i` (see the module docs).
    fn log_likelihood(&mut self, i: usize) -> f64 {
        let (cw, ch) = self.coarse.size();
        // The window of the model's bounding sphere on the coarse image.
        let pose = self.poses[i];
        let window = self.window_of(&pose, cw, ch);
        let len = window.width() * window.height();
        if len == 0 {
            return 0.0;
        }
        let buffer = &mut self.window[..len];
        buffer.iter_mut().for_each(|d| *d = f32::NAN);
        render_mesh(&self.coarse, &self.mesh, &pose, window, &RenderSettings::default(), &mut self.render, buffer);
        let st = &self.settings;
        let range = st.sensor.max_depth - st.sensor.min_depth;
        let uniform = 1.0 / range;
        let f = self.coarse.intrinsics.fx * st.pixel_stride as f64;
        let mut sum = 0.0;
        for v in window.v0..window.v1 {
            for u in window.u0..window.u1 {
                let d = buffer[(v - window.v0) * window.width() + (u - window.u0)];
                let z = self.measured[v * cw + u];
                if d.is_nan() || z.is_nan() {
                    continue;
                }
                let (d, z) = (f64::from(d), f64::from(z));
                if z < d - st.occlusion_margin {
                    continue;
                }
                let sigma = (st.sensor.depth_rms(d, f).powi(2) + st.model_noise.powi(2)).sqrt().max(1e-4);
                let e = (z - d) / sigma;
                let gauss = (-0.5 * e * e).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt());
                let object = (1.0 - st.outlier_weight) * gauss + st.outlier_weight * uniform;
                sum += (object / uniform).ln();
            }
        }
        st.pixel_weight * sum
    }

    /// The coarse pixels the model's bounding sphere may cover at `pose`.
    fn window_of(&self, pose: &IsometryMatrix3<f64>, cw: usize, ch: usize) -> PixelWindow {
        let radius = self.radius;
        let c = self.coarse.pose.inverse() * (pose * Point3::origin());
        let k = &self.coarse.intrinsics;
        if c.z <= radius + 1e-3 {
            return PixelWindow { u0: 0, v0: 0, u1: cw, v1: ch };
        }
        let (u, v) = (k.fx * c.x / c.z + k.cx, k.fy * c.y / c.z + k.cy);
        let r = k.fx.max(k.fy) * radius / (c.z - radius) + 1.0;
        let clamp = |x: f64, hi: usize| x.max(0.0).min(hi as f64) as usize;
        PixelWindow {
            u0: clamp(u - r, cw),
            v0: clamp(v - r, ch),
            u1: clamp(u + r + 1.0, cw),
            v1: clamp(v + r + 1.0, ch),
        }
    }

    /// Weights from the log-weights, the log-weights shifted to a maximum of 0.
    fn normalise(&mut self) {
        let max = self.log_weights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut total = 0.0;
        for (w, l) in self.weights.iter_mut().zip(self.log_weights.iter_mut()) {
            *l -= max;
            *w = l.exp();
            total += *w;
        }
        for w in &mut self.weights {
            *w /= total;
        }
    }

    /// The weighted mean pose.
    fn mean(&self) -> IsometryMatrix3<f64> {
        let best = (0..self.weights.len()).max_by(|&a, &b| self.weights[a].total_cmp(&self.weights[b])).unwrap_or(0);
        let reference = UnitQuaternion::from_rotation_matrix(&self.poses[best].rotation);
        let (mut t, mut q) = (Vector3::zeros(), Quaternion::new(0.0, 0.0, 0.0, 0.0));
        for (p, w) in self.poses.iter().zip(&self.weights) {
            t += *w * p.translation.vector;
            let pq = UnitQuaternion::from_rotation_matrix(&p.rotation);
            let sign = if pq.coords.dot(&reference.coords) < 0.0 { -1.0 } else { 1.0 };
            q += pq.into_inner() * (sign * w);
        }
        let rotation = UnitQuaternion::try_new(q, 1e-12).unwrap_or(reference).to_rotation_matrix();
        IsometryMatrix3::from_parts(Translation3::from(t), rotation)
    }

    /// Systematic resampling; the weights even again.
    fn resample(&mut self) {
        let n = self.poses.len();
        let step = 1.0 / n as f64;
        let mut u = self.rng.random_range(0.0..step);
        let (mut i, mut cumulative) = (0, self.weights[0]);
        for k in 0..n {
            while u > cumulative && i + 1 < n {
                i += 1;
                cumulative += self.weights[i];
            }
            self.spare[k] = self.poses[i];
            u += step;
        }
        std::mem::swap(&mut self.poses, &mut self.spare);
        self.log_weights.iter_mut().for_each(|l| *l = 0.0);
        self.weights.iter_mut().for_each(|w| *w = step);
    }
}
