//! Training a policy network for the experiment, and the report written
//! beside the policy file.

use crate::experiments::ExperimentError;
use crate::experiments::figures::loss_curves;
use crate::files::FileError;
use crate::learn::{
    Demonstrations, LearnSettings, PolicyNetwork, SHIPPED_POLICY_PATH, SHIPPED_POLICY_PROVENANCE, TrainReport, train_on,
};
use crate::problem::ProblemFamily;
use std::path::{Path, PathBuf};

/// The report written beside a policy file (`FILE.json`).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct PolicyReport {
    /// The dataset folder it was trained on (the provenance file for the
    /// shipped policy).
    #[serde(default)]
    pub data: PathBuf,
    /// Training trajectories.
    pub trajectories: usize,
    /// Training state-action pairs.
    pub pairs: usize,
    /// Validation trajectories.
    pub validation_trajectories: usize,
    /// Validation pairs.
    pub validation_pairs: usize,
    /// Training time (s).
    pub seconds: f64,
    /// Training loss of the last epoch.
    pub final_train_loss: f64,
    /// Validation loss of the last epoch (NaN without validation pairs).
    pub final_validation_loss: f64,
    /// Every epoch's losses (none recorded for the shipped policy).
    #[serde(default)]
    pub losses: Vec<serde_json::Value>,
}

impl PolicyReport {
    fn new(data: &Path, report: &TrainReport) -> PolicyReport {
        let last = report.losses.last();
        PolicyReport {
            data: data.to_path_buf(),
            trajectories: report.train_trajectories,
            pairs: report.train_pairs,
            validation_trajectories: report.validation_trajectories,
            validation_pairs: report.validation_pairs,
            seconds: report.seconds,
            final_train_loss: last.map_or(f64::NAN, |l| l.train),
            final_validation_loss: last.map_or(f64::NAN, |l| l.validation),
            losses: report.losses.iter().filter_map(|l| serde_json::to_value(l).ok()).collect(),
        }
    }

    /// The shipped policy's training, from its provenance
    /// (`policies/panda_grasp_family.json`).
    pub fn of_shipped() -> Option<PolicyReport> {
        let provenance: serde_json::Value = serde_json::from_str(SHIPPED_POLICY_PROVENANCE).ok()?;
        let mut report: PolicyReport = serde_json::from_value(provenance.get("training")?.clone()).ok()?;
        report.data = Path::new(SHIPPED_POLICY_PATH).with_extension("json");
        Some(report)
    }

    /// The report beside `policy` (`None` when there is none or it is unreadable).
    pub fn read_beside(policy: &Path) -> Option<PolicyReport> {
        serde_json::from_str(&std::fs::read_to_string(policy.with_extension("json")).ok()?).ok()
    }
}

/// Trains a policy network on the dataset in `data` and writes it to `out`
/// (safetensors), its [`PolicyReport`] beside it (`.json`) and its loss
/// curves (`.svg`); returns the network and the report.
///
/// # Errors
/// A file that cannot be written (checked first), an unreadable dataset,
/// training.
pub fn train_and_save(
    data: &Path,
    family: &ProblemFamily,
    options: &LearnSettings,
    out: &Path,
) -> Result<(PolicyNetwork, PolicyReport), ExperimentError> {
    for path in [out.to_path_buf(), out.with_extension("json"), out.with_extension("svg")] {
        crate::files::check_writable(&path)?;
    }
    let demos = Demonstrations::read(data)?;
    let (network, report) = train_on(&demos, family, options, None)?;
    network.save(out)?;
    let summary = PolicyReport::new(data, &report);
    let json = out.with_extension("json");
    std::fs::write(&json, serde_json::to_string_pretty(&summary)? + "\n").map_err(FileError::io(&json))?;
    let svg = out.with_extension("svg");
    let title = format!("Training the policy network ({} trajectories, {} pairs)", summary.trajectories, summary.pairs);
    std::fs::write(&svg, loss_curves(&report, &title)?).map_err(FileError::io(&svg))?;
    Ok((network, summary))
}
