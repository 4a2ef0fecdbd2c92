//! URDF text → description, lint, model, forward kinematics and Jacobians
//! at the neutral configuration, collision model and queries.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::Arc;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::robot::{KinematicsWorkspace, MeshSearchPath, ReferenceFrame, RobotDescription, RobotModel};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(description) = RobotDescription::from_urdf_str(text, &MeshSearchPath::default()) else { return };
    let _ = description.lint();
    let Ok(model) = RobotModel::builder(Arc::new(description)).build() else { return };
    let q = model.neutral_configuration();
    let mut ws = KinematicsWorkspace::new(&model);
    if model.forward_kinematics(&mut ws, &q).is_err() {
        return;
    }
    let mut jacobian = nalgebra::Matrix6xX::zeros(model.nq());
    for frame in model.frame_ids().take(8) {
        let _ = model.frame_jacobian(&ws, frame, ReferenceFrame::WorldAligned, &mut jacobian);
    }
    let Ok(collision) = CollisionModel::builder(Arc::new(model)).build() else { return };
    let mut cws = CollisionWorkspace::new(&collision);
    let _ = collision.collision_free(&mut cws, &q);
    let _ = collision.min_distance(&mut cws, &q);
});
