//! Bulk generation from Python: `tandem.generate` (one process, every
//! core, the same code as `tandem generate`) and the pieces
//! `tandem.distributed` schedules over Ray (missing parts, part ids).

use crate::errors::{DatasetError, PyResultExt};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use tandem::data::{
    GenerateSettings, Progress, ShardSpec, generate as rust_generate, part_count, part_ids, pending_parts,
};
use tandem::pipeline::{InitialGuess, PipelineSettings};

/// Settings of a run from the keyword arguments shared by the functions here.
#[allow(clippy::too_many_arguments)]
fn settings(
    count: u64,
    seed: u64,
    horizon: Option<usize>,
    chunk_size: u64,
    attempts: u32,
    max_evaluations: usize,
    threads: Option<usize>,
    shard: Option<(u64, u64)>,
    initial_guess: &str,
) -> PyResult<GenerateSettings> {
    let shard = match shard {
        Some((index, count)) if index < count => Some(ShardSpec { index, count }),
        Some((index, count)) => {
            return Err(DatasetError::new_err(format!("shard ({index}, {count}) needs 0 ≤ index < count")));
        }
        None => None,
    };
    Ok(GenerateSettings {
        count,
        seed,
        threads,
        shard,
        chunk_size,
        pipeline: PipelineSettings {
            horizon,
            attempts,
            max_evaluations,
            initial_guess: parse_initial_guess(initial_guess)?,
            ..PipelineSettings::default()
        },
    })
}

/// `"planned"` or `"straight"` (see `tandem generate --initial-guess`).
pub(crate) fn parse_initial_guess(name: &str) -> PyResult<InitialGuess> {
    match name {
        "planned" => Ok(InitialGuess::Planned),
        "straight" => Ok(InitialGuess::Straight),
        other => Err(pyo3::exceptions::PyValueError::new_err(format!(
            "initial_guess must be \"planned\" or \"straight\", got {other:?}"
        ))),
    }
}

/// Generates (or completes) the dataset of ``count`` samples of the
/// family in ``out``, exactly as ``tandem generate`` does (same files,
/// same bytes): Parquet part files of ``chunk_size`` ids, ``_dataset.json``,
/// ``_manifest.json`` and ``_timings/``. ``threads`` (default: every core)
/// and ``shard=(i, m)`` (share i of m of the parts) do not change the
/// bytes. ``progress``: a progress bar or periodic lines on stderr.
/// Returns ``{"manifest": {...}, "manifest_path", "parts_written",
/// "parts_kept", "samples_run", "elapsed_s"}``. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (
    family, out, *, count, seed=0, horizon=None, chunk_size=100, attempts=3, max_evaluations=200,
    threads=None, shard=None, progress=false, initial_guess="planned"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn generate<'py>(
    py: Python<'py>,
    family: PathBuf,
    out: PathBuf,
    count: u64,
    seed: u64,
    horizon: Option<usize>,
    chunk_size: u64,
    attempts: u32,
    max_evaluations: usize,
    threads: Option<usize>,
    shard: Option<(u64, u64)>,
    progress: bool,
    initial_guess: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let settings =
        settings(count, seed, horizon, chunk_size, attempts, max_evaluations, threads, shard, initial_guess)?;
    let progress = if progress { Progress::auto() } else { Progress::quiet() };
    let summary = py.detach(|| rust_generate(&family, &out, &settings, &progress)).py()?;
    let manifest = serde_json::to_string(&summary.manifest).map_err(|e| DatasetError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item("manifest", py.import("json")?.call_method1("loads", (manifest,))?)?;
    d.set_item("manifest_path", summary.manifest_path)?;
    d.set_item("parts_written", summary.parts_written)?;
    d.set_item("parts_kept", summary.parts_kept)?;
    d.set_item("samples_run", summary.samples_run)?;
    d.set_item("elapsed_s", summary.elapsed.as_secs_f64())?;
    Ok(d)
}

/// The parts of a run still missing from ``out``, as part numbers ``k``
/// (``part-{k:05}.parquet``): checks the settings, the family and the
/// folder as :func:`generate` does (a folder holding another dataset is
/// refused), writes ``_dataset.json`` when absent and moves damaged parts
/// aside, but computes nothing. Part ``k`` is ``shard=(k, part_count)``.
#[pyfunction]
#[pyo3(signature = (
    family, out, *, count, seed=0, horizon=None, chunk_size=100, attempts=3, max_evaluations=200,
    initial_guess="planned"
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn missing_parts(
    py: Python<'_>,
    family: PathBuf,
    out: PathBuf,
    count: u64,
    seed: u64,
    horizon: Option<usize>,
    chunk_size: u64,
    attempts: u32,
    max_evaluations: usize,
    initial_guess: &str,
) -> PyResult<Vec<u64>> {
    let settings = settings(count, seed, horizon, chunk_size, attempts, max_evaluations, None, None, initial_guess)?;
    py.detach(|| pending_parts(&family, &out, &settings)).py()
}

/// Number of part files of a run of ``count`` samples, ``⌈count / chunk_size⌉``.
#[pyfunction(name = "part_count")]
#[pyo3(signature = (*, count, chunk_size=100))]
pub(crate) fn py_part_count(count: u64, chunk_size: u64) -> u64 {
    part_count(&GenerateSettings { count, chunk_size, ..GenerateSettings::default() })
}

/// Ids ``(first, end)`` of part ``k`` of a run of ``count`` samples.
#[pyfunction(name = "part_ids")]
#[pyo3(signature = (k, *, count, chunk_size=100))]
pub(crate) fn py_part_ids(k: u64, count: u64, chunk_size: u64) -> (u64, u64) {
    let [first, end] = part_ids(k, &GenerateSettings { count, chunk_size, ..GenerateSettings::default() });
    (first, end)
}
