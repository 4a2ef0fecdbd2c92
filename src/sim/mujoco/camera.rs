//! A depth camera in MuJoCo, by ray casting.
//!
//! Each pixel's ray is cast into the compiled world with MuJoCo's
//! `mj_multiRay` (all rays from the camera's centre, geoms pruned by their
//! bounding spheres), which meets meshes on their triangles and the
//! primitives exactly. Why rays and not MuJoCo's OpenGL renderer: CI and
//! this machine have no GPU; EGL does not initialise here and OSMesa would
//! add a system library and a GL context to every build, while rays need
//! nothing beyond `libmujoco` and give the same depth to rounding (the
//! renderer's depth buffer is quantised, the rays are not). Rays also give
//! what a renderer would need a second pass for: the geom each pixel sees
//! (the ground-truth segmentation that scoring uses, never the
//! perception) and its surface normal (grazing incidence for the sensor
//! model, [`crate::perception::sensor`]).
//!
//! The robot appears as MuJoCo sees it: its collision geoms (the Panda's
//! spheres and finger boxes), since its visual meshes are not compiled.

use crate::perception::{DepthCamera, DepthImage};
use mujoco_rs::prelude::*;
use nalgebra::Vector3;
use std::sync::Arc;

/// What the ray-cast camera saw in one frame (row-major, one entry per pixel).
#[derive(Debug, Clone, Default)]
pub struct RayCastFrame {
    /// The perfect depth along the optical axis (m, NaN where no geom
    /// within range).
    pub depth: DepthImage,
    /// The MuJoCo geom each pixel sees (`None` for none).
    pub geom: Vec<Option<usize>>,
    /// `|cos|` of the angle between the ray and the surface normal (NaN for none).
    pub cos_incidence: Vec<f32>,
}

/// A depth camera placed in a MuJoCo world: its rays computed once.
#[derive(Debug, Clone)]
pub struct RayCastCamera {
    camera: DepthCamera,
    /// Per pixel, the ray's world direction scaled so that its optical z
    /// is 1 (a distance along it is then the pixel's depth).
    rays: Vec<[f64; 3]>,
    /// The longest distance cast (m, along a ray of optical z 1).
    range: f64,
    normals: Vec<[f64; 3]>,
}

impl RayCastCamera {
    /// The camera's rays; nothing farther than `range` (m of depth) is seen.
    pub fn new(camera: DepthCamera, range: f64) -> RayCastCamera {
        let (w, h) = camera.size();
        let rays = (0..w * h)
            .map(|k| {
                let r = camera.ray((k % w) as f64, (k / w) as f64);
                (camera.pose.rotation * Vector3::from(r)).into()
            })
            .collect();
        RayCastCamera { camera, rays, range, normals: vec![[0.0; 3]; w * h] }
    }

    /// The camera.
    pub fn camera(&self) -> &DepthCamera {
        &self.camera
    }

    /// Casts every pixel's ray into `data`'s world (its kinematics as
    /// last computed: call `data.forward()` or `kinematics()` after moving
    /// it) and fills `frame`.
    pub fn render(&mut self, data: &mut MjData<Arc<MjModel>>, frame: &mut RayCastFrame) {
        let (w, h) = self.camera.size();
        let eye = self.camera.pose.translation.vector;
        let (geoms, distances) =
            data.multi_ray(&[eye.x, eye.y, eye.z], &self.rays, None, true, None, self.range, Some(&mut self.normals));
        frame.depth.width = w;
        frame.depth.height = h;
        frame.depth.depth.clear();
        frame.cos_incidence.clear();
        frame.geom.clear();
        for k in 0..w * h {
            // mj_multiRay's distance is in units of the ray's length: with
            // an optical z of 1 it is the depth.
            let d = distances[k];
            let hit = geoms[k].filter(|_| d >= 0.0 && d <= self.range);
            frame.geom.push(hit);
            if hit.is_some() {
                let r = Vector3::from(self.rays[k]);
                let n = Vector3::from(self.normals[k]);
                frame.depth.depth.push(d as f32);
                frame.cos_incidence.push((r.dot(&n).abs() / (r.norm() * n.norm()).max(1e-300)) as f32);
            } else {
                frame.depth.depth.push(f32::NAN);
                frame.cos_incidence.push(f32::NAN);
            }
        }
    }
}
