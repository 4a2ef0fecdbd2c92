//! The dataset's run parameters (`_dataset.json`) and manifest
//! (`_manifest.json`): what was asked, what came out, and every part file
//! with its hash. Both are deterministic: no times, no host names.

use super::shard::PartSummary;
use crate::pipeline::InitialGuess;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Everything that decides a dataset's content. A folder holds one set:
/// resuming with other parameters is refused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetParameters {
    /// See [`SCHEMA_VERSION`](super::schema::SCHEMA_VERSION).
    pub schema_version: u32,
    /// The tandem version that wrote the dataset.
    pub tandem_version: String,
    /// The family's `name`.
    pub family: String,
    /// SHA-256 (hex) of the family file, and of its base problem file.
    pub family_sha256: String,
    /// SHA-256 of the family's base problem file.
    pub base_problem_sha256: String,
    /// SHA-256 over every file that shapes the robot: its URDF (the
    /// embedded text for the shipped robots), the collision URDF and the
    /// SRDF when given, and each collision mesh, in that order (see
    /// [`robot_sha256`](super::robot_sha256)). Empty in datasets
    /// written before it was recorded, which then cannot be resumed.
    #[serde(default)]
    pub robot_sha256: String,
    /// Run seed S: sample i draws from a stream seeded by (S, i).
    pub seed: u64,
    /// Ids 0 … count − 1.
    pub count: u64,
    /// Slices per trajectory (T).
    pub horizon: usize,
    /// Ids per part file.
    pub chunk_size: u64,
    /// IK + planning + optimization attempts per sample.
    pub attempts: u32,
    /// Evaluation budget of each optimizer solve.
    pub max_evaluations: usize,
    /// Joint step of the final collision check between slices (rad).
    pub validation_resolution: f64,
    /// Acceptance: q_T within this distance (m) and angle (rad) of the goal.
    pub goal_tolerance: f64,
    /// Acceptance: angle (rad) of q_T from the goal orientation.
    pub goal_angle_tolerance: f64,
    /// What the optimizer starts from (`planned` in datasets made before
    /// it was recorded).
    #[serde(default)]
    pub initial_guess: InitialGuess,
}

/// A part file as listed in the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartEntry {
    /// File name within the dataset folder.
    pub file: String,
    /// Ids `first .. end`.
    pub ids: [u64; 2],
    /// Accepted trajectories (rows) in the part.
    pub rows: u64,
    /// Rejected samples.
    pub rejected: u64,
    /// SHA-256 of the part file.
    pub sha256: String,
    /// Size of the part file (bytes).
    pub bytes: u64,
}

/// What a run (or a shard of it) produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The run parameters (`_dataset.json`).
    pub parameters: DatasetParameters,
    /// `[i, M]` for `--shard i/M`; absent for the whole range.
    pub shard: Option<[u64; 2]>,
    /// Ids `first .. end` covered by this manifest.
    pub ids: [u64; 2],
    /// Active joint names: the order of every joint-space column.
    pub joints: Vec<String>,
    /// The gripper frame of `ee_pose` (empty when none).
    pub ee_frame: String,
    /// Samples in the dataset (accepted and rejected).
    pub samples: u64,
    /// Accepted samples (rows).
    pub accepted: u64,
    /// Rejected samples.
    pub rejected: u64,
    /// Rejections counted by reason (see [`Rejection`](super::Rejection)).
    pub rejected_by_reason: BTreeMap<String, u64>,
    /// Every part file, in id order.
    pub parts: Vec<PartEntry>,
}

impl Manifest {
    /// The manifest of `parts` (in id order) for the run `parameters`.
    pub fn new(
        parameters: DatasetParameters,
        shard: Option<[u64; 2]>,
        joints: Vec<String>,
        ee_frame: String,
        parts: &[(String, PartSummary)],
    ) -> Manifest {
        let mut rejected_by_reason = BTreeMap::new();
        for r in parts.iter().flat_map(|(_, p)| &p.rejected) {
            *rejected_by_reason.entry(r.reason.clone()).or_insert(0) += 1;
        }
        let accepted = parts.iter().map(|(_, p)| p.rows).sum();
        let rejected = rejected_by_reason.values().sum();
        let ids = match (parts.first(), parts.last()) {
            (Some((_, a)), Some((_, b))) => [a.ids[0], b.ids[1]],
            _ => [0, 0],
        };
        let parts = parts
            .iter()
            .map(|(file, p)| PartEntry {
                file: file.clone(),
                ids: p.ids,
                rows: p.rows,
                rejected: p.rejected.len() as u64,
                sha256: p.sha256.clone(),
                bytes: p.bytes,
            })
            .collect();
        Manifest {
            parameters,
            shard,
            ids,
            joints,
            ee_frame,
            samples: accepted + rejected,
            accepted,
            rejected,
            rejected_by_reason,
            parts,
        }
    }

    /// The share of samples accepted (0 … 1).
    pub fn acceptance(&self) -> f64 {
        if self.samples == 0 { 0.0 } else { self.accepted as f64 / self.samples as f64 }
    }
}
