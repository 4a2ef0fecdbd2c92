//! Depth of a mesh as a camera sees it: a z-buffer rasteriser on the CPU.
//!
//! Each triangle is moved into the camera's optical frame, projected, and
//! every pixel centre inside it gets the depth where that pixel's ray
//! meets the triangle's plane: `1/z` is affine in the image coordinates
//! for a pinhole camera, so interpolating it with screen-space barycentric
//! weights is exact (to rounding), not an approximation. The nearest
//! surface wins. Triangles with a vertex closer than
//! [`RenderSettings::near`] are left out (objects sit well in front of a
//! camera; a depth camera sees nothing that near anyway).
//!
//! The tracker renders an object many times a frame, into a window of
//! the image around it ([`PixelWindow`]); nothing is allocated after the
//! workspace has grown to the largest mesh.

use super::camera::DepthCamera;
use super::mesh::TriangleMesh;
use nalgebra::{IsometryMatrix3, Point3};

/// A rectangle of pixels: columns `u0..u1`, rows `v0..v1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelWindow {
    /// First column.
    pub u0: usize,
    /// First row.
    pub v0: usize,
    /// One past the last column.
    pub u1: usize,
    /// One past the last row.
    pub v1: usize,
}

impl PixelWindow {
    /// The whole image of `camera`.
    pub fn full(camera: &DepthCamera) -> PixelWindow {
        let (w, h) = camera.size();
        PixelWindow { u0: 0, v0: 0, u1: w, v1: h }
    }

    /// Pixels across.
    pub fn width(&self) -> usize {
        self.u1.saturating_sub(self.u0)
    }

    /// Pixels down.
    pub fn height(&self) -> usize {
        self.v1.saturating_sub(self.v0)
    }
}

/// Settings of the rasteriser.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Triangles with a vertex nearer than this are not drawn (m, default
    /// 0.05).
    pub near: f64,
}

impl Default for RenderSettings {
    fn default() -> RenderSettings {
        RenderSettings { near: 0.05 }
    }
}

/// The rasteriser's scratch: the mesh's vertices in the camera's frame and
/// projected.
#[derive(Debug, Clone, Default)]
pub struct RenderWorkspace {
    /// Per vertex: image u, v and the inverse depth 1/z.
    projected: Vec<[f64; 3]>,
}

/// Draws `mesh`, placed in the world by `object_pose`, into `depth` (the
/// window's pixels, row-major, `window.width() × window.height()`, m;
/// `NaN` or larger values are overwritten by nearer surfaces), and returns
/// how many pixels it wrote.
///
/// # Panics
/// `depth` not the window's size.
pub fn render_mesh(
    camera: &DepthCamera,
    mesh: &TriangleMesh,
    object_pose: &IsometryMatrix3<f64>,
    window: PixelWindow,
    settings: &RenderSettings,
    ws: &mut RenderWorkspace,
    depth: &mut [f32],
) -> usize {
    let (ww, wh) = (window.width(), window.height());
    assert_eq!(depth.len(), ww * wh, "the depth buffer must be the window's size");
    let k = &camera.intrinsics;
    let to_camera = camera.pose.inverse() * object_pose;
    ws.projected.clear();
    ws.projected.extend(mesh.vertices.iter().map(|v| {
        let p = to_camera * Point3::from(*v);
        let iz = 1.0 / p.z;
        [k.fx * p.x * iz + k.cx, k.fy * p.y * iz + k.cy, if p.z >= settings.near { iz } else { f64::NAN }]
    }));
    let mut written = 0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| ws.projected[i as usize]);
        if !(a[2] > 0.0 && b[2] > 0.0 && c[2] > 0.0) {
            continue;
        }
        // Twice the signed area; degenerate (edge-on) triangles draw nothing.
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area.abs() < 1e-12 {
            continue;
        }
        let lo_u = a[0].min(b[0]).min(c[0]).ceil().max(window.u0 as f64);
        let hi_u = a[0].max(b[0]).max(c[0]).floor().min(window.u1 as f64 - 1.0);
        let lo_v = a[1].min(b[1]).min(c[1]).ceil().max(window.v0 as f64);
        let hi_v = a[1].max(b[1]).max(c[1]).floor().min(window.v1 as f64 - 1.0);
        if lo_u > hi_u || lo_v > hi_v {
            continue;
        }
        let inv_area = 1.0 / area;
        for v in lo_v as usize..=hi_v as usize {
            let y = v as f64;
            for u in lo_u as usize..=hi_u as usize {
                let x = u as f64;
                // Barycentric weights of (x, y): a pixel centre on an edge
                // counts (both triangles of the edge then agree on it).
                let wa = ((b[0] - x) * (c[1] - y) - (b[1] - y) * (c[0] - x)) * inv_area;
                let wb = ((c[0] - x) * (a[1] - y) - (c[1] - y) * (a[0] - x)) * inv_area;
                let wc = 1.0 - wa - wb;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let z = (1.0 / (wa * a[2] + wb * b[2] + wc * c[2])) as f32;
                let slot = &mut depth[(v - window.v0) * ww + (u - window.u0)];
                if slot.is_nan() || *slot > z {
                    *slot = z;
                    written += 1;
                }
            }
        }
    }
    written
}
