//! Perception: what a depth camera sees of the objects on a table, and
//! where each object is — the pipeline of §7.4 of *Adaptive Human-Robot
//! Policy Blending for Shared Control Teleoperation*.
//!
//! - [`mesh`]: triangle meshes, their OBJ files and surface samples.
//! - [`objects`]: the seven objects of Table 7.1 (cube, sphere, lego toy,
//!   teapot, cup, jug, bowl) with masses, symmetries and grasp frames.
//! - [`camera`]: a depth camera (intrinsics, optical frame) and its images.
//! - [`sensor`]: a real depth camera's faults (a RealSense D435's shadows,
//!   range, dropouts, noise, quantisation) applied to a perfect image.
//! - [`render`]: a mesh's depth image, rasterised on the CPU.
//! - [`segment`]: the points above the table, the robot's removed, in
//!   one cluster per object.
//! - [`cpd`]: rigid coherent point drift, the dissertation's *mesh_pose*.
//! - [`icp`]: point-to-plane ICP.
//! - [`estimate`]: a segment labelled and posed (ICP from upright
//!   hypotheses, scored against the image), *mesh_pose* by CPD.
//! - [`track`]: a particle filter over the 6-D pose, DBOT's manner.
//! - [`metrics`]: ADD, ADD-S and their AUC.
//!
//! Frames: an object's mesh is given in its own frame (origin at the
//! centre of its base, z up, so that it rests on the plane z = 0; m); a
//! camera's points in its optical frame (REP 103: z forward, x right, y
//! down; m); poses map the first frame into the world.

pub mod camera;
pub mod cpd;
pub mod estimate;
pub mod icp;
pub mod mesh;
pub mod metrics;
pub mod objects;
pub mod render;
pub mod segment;
pub mod sensor;
#[cfg(test)]
mod tests;
pub mod track;

pub use camera::{DepthCamera, DepthImage};
pub use cpd::{CpdResult, CpdSettings, CpdWorkspace, rigid_cpd};
pub use estimate::{
    Detection, EstimateSettings, EstimateWorkspace, ObjectLibrary, detect, fit_object, mask_pose, mesh_pose,
};
pub use icp::{IcpResult, IcpSettings, SurfaceModel, point_to_plane_icp};
pub use mesh::TriangleMesh;
pub use objects::{ObjectModel, Symmetry, catalog};
pub use render::{PixelWindow, RenderSettings, RenderWorkspace, render_mesh};
pub use segment::{Segment, SegmentReport, SegmentSettings, segment_objects};
pub use sensor::{DepthSensorSettings, apply_sensor_model};
pub use track::{TrackSettings, Tracker};

/// Why a perception input was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{origin}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct PerceptionError {
    /// What was being read or checked: a file, an image, a setting.
    pub origin: String,
    /// The line at fault (1-based), for text files.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl PerceptionError {
    pub(crate) fn new(origin: &str, line: Option<usize>, message: impl Into<String>) -> PerceptionError {
        PerceptionError { origin: origin.to_string(), line, message: message.into() }
    }
}
