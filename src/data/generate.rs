//! `generate`: a family's samples 0 … N−1, in parallel, into part files.
//!
//! Ids are cut into chunks of `chunk_size`; chunk k becomes
//! `part-{k:05}.parquet`. Chunks already on disk (complete by construction:
//! they are renamed into place) are kept, the rest are generated, with
//! rayon spreading both chunks and the ids inside them over the threads.
//! `--shard i/M` takes chunks `⌊k·i/M⌋ … ⌊k·(i+1)/M⌋` of the k chunks, so
//! shards run anywhere add up to the dataset of one run.

use super::manifest::{DatasetParameters, Manifest};
use super::progress::{Progress, ProgressRun};
use super::sample::{SampleOutcome, SampleTiming, run_sample};
use super::shard::{
    PartMeta, PartSummary, read_part_summary, sha256_hex, temporary_path, write_atomically, write_part,
};
use crate::files::FileError;
use crate::pipeline::PipelineSettings;
use crate::problem::{ProblemError, ProblemFamily};
use crate::settings::InvalidSetting;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::{Duration, Instant};
use thiserror::Error;

/// `i/M`: the i-th of M equal shares of the chunks (0 ≤ i < M).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardSpec {
    /// The share, from 0.
    pub index: u64,
    /// How many shares.
    pub count: u64,
}

impl FromStr for ShardSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<ShardSpec, String> {
        let bad = || format!("expected a shard as I/M with 0 ≤ I < M, e.g. 0/4; got {s:?}");
        let (i, m) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (i.trim().parse().map_err(|_| bad())?, m.trim().parse().map_err(|_| bad())?);
        if index < count { Ok(ShardSpec { index, count }) } else { Err(bad()) }
    }
}

/// What to generate; everything except `threads`, `shard` and the output
/// folder decides the dataset's bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateSettings {
    /// Samples 0 … count − 1.
    pub count: u64,
    /// Run seed.
    pub seed: u64,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Generate only this share of the part files (default: all).
    pub shard: Option<ShardSpec>,
    /// Ids per part file.
    pub chunk_size: u64,
    /// How each sample is solved and accepted (horizon, attempts,
    /// evaluation budget, validation resolution, goal tolerances).
    pub pipeline: PipelineSettings,
}

impl Default for GenerateSettings {
    fn default() -> Self {
        GenerateSettings {
            count: 1000,
            seed: 0,
            threads: None,
            shard: None,
            chunk_size: 100,
            pipeline: PipelineSettings::default(),
        }
    }
}

/// Why a run stopped.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GenerateError {
    #[error(transparent)]
    /// The family (or its base problem) cannot be loaded.
    Family(#[from] ProblemError),
    #[error(transparent)]
    /// A file cannot be written.
    Data(#[from] FileError),
    #[error(transparent)]
    /// A setting outside its bounds, named as the command line names it
    /// (`--count`).
    InvalidSetting(#[from] InvalidSetting),
    /// The output folder holds a dataset made with other parameters.
    #[error(
        "{path} was generated with {key} = {existing}, this run asks {requested}: use another --out folder, or the same parameters to resume"
    )]
    Mismatch {
        /// The folder's `_dataset.json`.
        path: PathBuf,
        /// The differing parameter.
        key: String,
        /// The value the folder's dataset was made with.
        existing: String,
        /// The value this run asks for.
        requested: String,
    },
    /// A file of an earlier run in the folder cannot be read.
    #[error("cannot read {path}: {message}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    #[error("cannot start {0} worker threads: {1}")]
    /// The worker threads cannot be started (count, reason).
    Threads(usize, String),
}

/// The outcome of a run.
#[derive(Debug, Clone)]
pub struct GenerateSummary {
    /// The manifest written.
    pub manifest: Manifest,
    /// Where it was written.
    pub manifest_path: PathBuf,
    /// Part files written by this run, and found complete from earlier runs.
    pub parts_written: usize,
    /// Part files found complete from earlier runs.
    pub parts_kept: usize,
    /// Samples this run computed, and its wall-clock time.
    pub samples_run: u64,
    /// Wall-clock time of this run.
    pub elapsed: Duration,
    /// Per-sample times of this run (ms), sorted.
    pub sample_ms: Vec<f64>,
}

impl GenerateSummary {
    /// Samples per second of this run (accepted or not).
    pub fn rate(&self) -> f64 {
        self.samples_run as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Generates (or completes) the dataset in `out`; see the module docs.
///
/// # Errors
/// Bad settings, an unreadable family, a folder holding another dataset,
/// or I/O errors; samples that fail are rejections, not errors.
pub fn generate(
    family_path: &Path,
    out: &Path,
    settings: &GenerateSettings,
    progress: &Progress,
) -> Result<GenerateSummary, GenerateError> {
    let began = Instant::now();
    let OpenedDataset { family, parameters, mut found, pending } = open_dataset(family_path, out, settings)?;
    let joints = family.base.robot.joint_names().to_vec();
    let ee_frame = family.base.robot_spec.gripper.clone().unwrap_or_default();
    let samples_run: u64 = pending.iter().map(|&k| chunk_ids(k, settings)).map(|[a, b]| b - a).sum();
    let run = progress.start(samples_run);
    let horizon = parameters.horizon;
    let context =
        RunContext { family: &family, settings, out, joints: &joints, ee_frame: &ee_frame, horizon, progress: &run };
    let written = run_chunks(&context, &pending)?;
    run.finish();
    let parts_written = written.len();
    let mut sample_ms: Vec<f64> = written.iter().flat_map(|(_, _, t)| t.iter().map(|t| t.total_ms)).collect();
    sample_ms.sort_by(f64::total_cmp);
    found.extend(written.into_iter().map(|(k, s, _)| (k, s)));
    found.sort_by_key(|(k, _)| *k);
    let parts: Vec<(String, PartSummary)> = found.into_iter().map(|(k, s)| (part_name(k), s)).collect();
    let shard = settings.shard.map(|s| [s.index, s.count]);
    let manifest = Manifest::new(parameters, shard, joints, ee_frame, &parts);
    let manifest_path = out.join(match settings.shard {
        Some(s) => format!("_manifest-shard-{}-of-{}.json", s.index, s.count),
        None => "_manifest.json".into(),
    });
    write_atomically(&manifest_path, pretty(&manifest).as_bytes())?;
    Ok(GenerateSummary {
        manifest,
        manifest_path,
        parts_written,
        parts_kept: parts.len() - parts_written,
        samples_run,
        elapsed: began.elapsed(),
        sample_ms,
    })
}

/// A dataset folder checked for a run: the family, the run parameters
/// (written to, or checked against, `_dataset.json`), the part files of
/// the run's shard found complete and the chunks still missing.
struct OpenedDataset {
    family: ProblemFamily,
    parameters: DatasetParameters,
    found: Vec<(u64, PartSummary)>,
    pending: Vec<u64>,
}

fn open_dataset(family_path: &Path, out: &Path, settings: &GenerateSettings) -> Result<OpenedDataset, GenerateError> {
    validate(settings)?;
    let family = ProblemFamily::from_file(family_path)?;
    let parameters = parameters(family_path, &family, settings)?;
    validate_part_size(settings.chunk_size, parameters.horizon)?;
    std::fs::create_dir_all(out.join("_timings")).map_err(|e| FileError::Io { path: out.into(), source: e })?;
    check_parameters(out, &parameters)?;
    let (mut found, mut pending) = (Vec::new(), Vec::new());
    for k in shard_chunks(settings) {
        match existing_part(out, k, settings)? {
            Some(summary) => found.push((k, summary)),
            None => pending.push(k),
        }
    }
    Ok(OpenedDataset { family, parameters, found, pending })
}

/// The part files of this run (of its shard, when sharded) still missing
/// from `out`, as part numbers `k` (file `part-{k:05}.parquet`, ids
/// [`part_ids`]). Checks everything [`generate`] checks before it
/// computes — settings, family, a folder holding another dataset (refused)
/// — writes `_dataset.json` when absent and moves damaged parts aside, but
/// generates nothing. Another scheduler can then compute each missing part
/// as shard `k/K` with `K = `[`part_count`] (exactly part `k`), anywhere,
/// and a final unsharded [`generate`] over the complete folder writes the
/// manifest: the dataset of one run (this is what the Python package's
/// `tandem.distributed` does over Ray).
///
/// # Errors
/// As [`generate`].
pub fn pending_parts(family_path: &Path, out: &Path, settings: &GenerateSettings) -> Result<Vec<u64>, GenerateError> {
    Ok(open_dataset(family_path, out, settings)?.pending)
}

/// Number of part files of a run, `⌈count / chunk_size⌉` (0 for a chunk size of 0).
pub fn part_count(settings: &GenerateSettings) -> u64 {
    if settings.chunk_size == 0 { 0 } else { chunk_count(settings) }
}

/// Ids `first .. end` of part `k` of a run.
pub fn part_ids(k: u64, settings: &GenerateSettings) -> [u64; 2] {
    chunk_ids(k, settings)
}

/// Most samples of one run (`--count`).
pub const MAX_COUNT: u64 = 100_000_000_000;
/// Most ids per part file (`--chunk-size`).
pub const MAX_CHUNK_SIZE: u64 = 100_000;
/// Most part files of one dataset (`--count` / `--chunk-size`, rounded up).
pub const MAX_PARTS: u64 = 1_000_000;
/// Most slices (`--chunk-size` × T) of one part file, which is assembled
/// in memory: 10⁷ slices of a 7-joint arm are about 2 GB of columns.
pub const MAX_PART_SLICES: u64 = 10_000_000;
/// Most worker threads (`--threads`).
pub const MAX_THREADS: usize = 1024;

/// Checks every size against its bound (above), naming the setting by its
/// command-line option.
fn validate(s: &GenerateSettings) -> Result<(), GenerateError> {
    let range = |option: &str, value: u64, max: u64| {
        if (1..=max).contains(&value) {
            Ok(())
        } else {
            Err(InvalidSetting::new(option, value, format!("between 1 and {max}")))
        }
    };
    range("--count", s.count, MAX_COUNT)?;
    range("--chunk-size", s.chunk_size, MAX_CHUNK_SIZE)?;
    if chunk_count(s) > MAX_PARTS {
        let expected =
            format!("large enough for at most {MAX_PARTS} part files (--count {} makes {})", s.count, chunk_count(s));
        return Err(InvalidSetting::new("--chunk-size", s.chunk_size, expected).into());
    }
    s.pipeline.validate()?;
    if let Some(threads) = s.threads {
        range("--threads", threads as u64, MAX_THREADS as u64)?;
    }
    Ok(())
}

/// Checks the slices of one part file against [`MAX_PART_SLICES`] once
/// the horizon is known.
fn validate_part_size(chunk_size: u64, horizon: usize) -> Result<(), GenerateError> {
    let slices = u128::from(chunk_size) * (horizon as u128 + 1);
    if slices > u128::from(MAX_PART_SLICES) {
        let expected = format!(
            "small enough for at most {MAX_PART_SLICES} slices per part file ({} slices each make {slices})",
            horizon + 1
        );
        return Err(InvalidSetting::new("--chunk-size", chunk_size, expected).into());
    }
    Ok(())
}

fn parameters(path: &Path, family: &ProblemFamily, s: &GenerateSettings) -> Result<DatasetParameters, GenerateError> {
    let hash = |p: &Path| {
        // A builtin base problem is hashed as its embedded text.
        let builtin = p.to_str().and_then(|s| s.strip_prefix("<builtin:")).and_then(|s| s.strip_suffix('>'));
        if let Some((_, text)) =
            builtin.and_then(|name| crate::problem::BUILTIN_PROBLEMS.iter().find(|(n, _)| *n == name))
        {
            return Ok(sha256_hex(text.as_bytes()));
        }
        std::fs::read(p)
            .map(|b| sha256_hex(&b))
            .map_err(|e| GenerateError::Read { path: p.into(), message: e.to_string() })
    };
    Ok(DatasetParameters {
        schema_version: super::schema::SCHEMA_VERSION,
        tandem_version: env!("CARGO_PKG_VERSION").into(),
        family: family.name.clone(),
        family_sha256: hash(path)?,
        base_problem_sha256: hash(Path::new(&family.base.origin))?,
        robot_sha256: robot_sha256(&family.base)?,
        seed: s.seed,
        count: s.count,
        horizon: s.pipeline.horizon.unwrap_or(family.base.optimizer.horizon),
        chunk_size: s.chunk_size,
        attempts: s.pipeline.attempts,
        max_evaluations: s.pipeline.max_evaluations,
        validation_resolution: s.pipeline.validation_resolution,
        goal_tolerance: s.pipeline.goal_tolerance,
        goal_angle_tolerance: s.pipeline.goal_angle_tolerance,
        initial_guess: s.pipeline.initial_guess,
    })
}

/// SHA-256 (hex) over every file that shapes `problem`'s robot: the URDF
/// (for an embedded robot, its embedded text), the collision URDF and the
/// SRDF when given, then each collision mesh of both URDFs, each file
/// entering as its name's length-prefixed bytes and its own hash. A dataset
/// resumed after any of them changed would mix two robots.
///
/// # Errors
/// A file that cannot be read.
pub fn robot_sha256(problem: &crate::problem::Problem) -> Result<String, GenerateError> {
    use sha2::Digest;
    let mut all = sha2::Sha256::new();
    let mut add = |label: &str, bytes: &[u8]| {
        all.update((label.len() as u64).to_le_bytes());
        all.update(label.as_bytes());
        all.update(sha2::Sha256::digest(bytes));
    };
    let read = |path: &Path| {
        std::fs::read(path).map_err(|e| GenerateError::Read { path: path.into(), message: e.to_string() })
    };
    let descriptions: Vec<&crate::robot::RobotDescription> =
        std::iter::once(&**problem.robot.description()).chain(problem.collision_geometry.as_deref()).collect();
    let urdfs = std::iter::once(&problem.robot_spec.urdf).chain(&problem.robot_spec.collision_urdf);
    for (description, path) in descriptions.iter().zip(urdfs) {
        match description.embedded_urdf() {
            Some(text) => add(description.source(), text.as_bytes()),
            None => add("urdf", &read(path)?),
        }
    }
    if let Some(srdf) = &problem.robot_spec.srdf {
        add("srdf", &read(srdf)?);
    }
    for mesh in descriptions.iter().flat_map(|d| d.mesh_files()) {
        add("mesh", &read(mesh)?);
    }
    Ok(all.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

fn pretty(value: &impl serde::Serialize) -> String {
    serde_json::to_string_pretty(value).unwrap_or_default() + "\n"
}

/// The run parameters of the dataset in `dir` (its `_dataset.json`); a key
/// written after the dataset was made takes its documented default.
///
/// # Errors
/// [`GenerateError::Read`] naming the file: missing, or not the parameters.
pub fn dataset_parameters(dir: &Path) -> Result<DatasetParameters, GenerateError> {
    let path = dir.join("_dataset.json");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| GenerateError::Read { path: path.clone(), message: e.to_string() })?;
    serde_json::from_str(&text).map_err(|e| GenerateError::Read { path, message: e.to_string() })
}

/// Writes `_dataset.json`, or checks that the one there matches.
fn check_parameters(out: &Path, parameters: &DatasetParameters) -> Result<(), GenerateError> {
    let path = out.join("_dataset.json");
    if !path.exists() {
        write_atomically(&path, pretty(parameters).as_bytes())?;
        return Ok(());
    }
    let read_error = |message: String| GenerateError::Read { path: path.clone(), message };
    let existing = serde_json::to_value(dataset_parameters(out)?).map_err(|e| read_error(e.to_string()))?;
    let requested = serde_json::to_value(parameters).map_err(|e| read_error(e.to_string()))?;
    let (Some(existing), Some(requested)) = (existing.as_object(), requested.as_object()) else {
        return Err(read_error("not a JSON object".into()));
    };
    for (key, want) in requested {
        let have = existing.get(key).cloned().unwrap_or(serde_json::Value::Null);
        if &have != want {
            let (existing, requested) = (have.to_string(), want.to_string());
            return Err(GenerateError::Mismatch { path, key: key.clone(), existing, requested });
        }
    }
    Ok(())
}

fn chunk_count(s: &GenerateSettings) -> u64 {
    s.count.div_ceil(s.chunk_size)
}

/// The chunks of this run's shard.
fn shard_chunks(s: &GenerateSettings) -> Vec<u64> {
    let k = chunk_count(s);
    let spec = s.shard.unwrap_or(ShardSpec { index: 0, count: 1 });
    let at = |i: u64| (u128::from(k) * u128::from(i) / u128::from(spec.count)) as u64;
    (at(spec.index)..at(spec.index + 1)).collect()
}

/// Ids `[first, end)` of chunk `k` (validated settings: no overflow).
fn chunk_ids(k: u64, s: &GenerateSettings) -> [u64; 2] {
    [k * s.chunk_size, ((k + 1) * s.chunk_size).min(s.count)]
}

fn part_name(k: u64) -> String {
    format!("part-{k:05}.parquet")
}

/// A complete part file of chunk `k` from an earlier run, if any. Partial
/// writes never carry the final name; anything unreadable there is moved
/// aside (never deleted) and regenerated.
fn existing_part(out: &Path, k: u64, s: &GenerateSettings) -> Result<Option<PartSummary>, GenerateError> {
    let path = out.join(part_name(k));
    let _ = std::fs::remove_file(temporary_path(&path));
    if !path.exists() {
        return Ok(None);
    }
    match read_part_summary(&path) {
        Ok(summary) if summary.ids == chunk_ids(k, s) => Ok(Some(summary)),
        outcome => {
            let why = outcome.err().map_or_else(|| "another id range".to_string(), |e| e.to_string());
            let aside = out.join(format!("_damaged-{}", part_name(k)));
            eprintln!(
                "warning: {} is not a part of this dataset ({why}); moved to {}",
                path.display(),
                aside.display()
            );
            std::fs::rename(&path, &aside).map_err(|e| FileError::Io { path: path.clone(), source: e })?;
            Ok(None)
        }
    }
}

struct RunContext<'a> {
    family: &'a ProblemFamily,
    settings: &'a GenerateSettings,
    out: &'a Path,
    joints: &'a [String],
    ee_frame: &'a str,
    /// T, as resolved in the run parameters.
    horizon: usize,
    progress: &'a ProgressRun,
}

type ChunkResult = (u64, PartSummary, Vec<SampleTiming>);

fn run_chunks(c: &RunContext<'_>, pending: &[u64]) -> Result<Vec<ChunkResult>, GenerateError> {
    let threads = c.settings.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| GenerateError::Threads(threads, e.to_string()))?;
    pool.install(|| pending.par_iter().map(|&k| run_chunk(c, k)).collect())
}

fn run_chunk(c: &RunContext<'_>, k: u64) -> Result<ChunkResult, GenerateError> {
    let ids = chunk_ids(k, c.settings);
    let results: Vec<(SampleOutcome, SampleTiming)> = (ids[0]..ids[1])
        .into_par_iter()
        .map(|id| {
            let result = run_sample(c.family, c.settings, id);
            c.progress.sample_done(matches!(result.0, SampleOutcome::Accepted(_)));
            result
        })
        .collect();
    let (outcomes, timings): (Vec<_>, Vec<_>) = results.into_iter().unzip();
    let meta = PartMeta { joints: c.joints, ee_frame: c.ee_frame, horizon: c.horizon, ids };
    let summary = write_part(&c.out.join(part_name(k)), &meta, &outcomes)?;
    write_timings(c.out, k, &outcomes, &timings)?;
    Ok((k, summary, timings))
}

fn write_timings(out: &Path, k: u64, outcomes: &[SampleOutcome], timings: &[SampleTiming]) -> Result<(), FileError> {
    let mut csv = String::from("id,outcome,plan_ms,optimize_ms,total_ms\n");
    for (o, t) in outcomes.iter().zip(timings) {
        let outcome = match o {
            SampleOutcome::Accepted(_) => "accepted",
            SampleOutcome::Rejected(r) => &r.reason,
        };
        csv.push_str(&format!("{},{outcome},{:.3},{:.3},{:.3}\n", o.id(), t.plan_ms, t.optimize_ms, t.total_ms));
    }
    write_atomically(&out.join("_timings").join(format!("part-{k:05}.csv")), csv.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_k_of_part_count_is_part_k() {
        for (count, chunk_size) in [(12, 3), (10, 3), (1, 100), (250, 100)] {
            let settings = GenerateSettings { count, chunk_size, ..GenerateSettings::default() };
            let parts = part_count(&settings);
            assert_eq!(parts, count.div_ceil(chunk_size));
            for k in 0..parts {
                let shard = Some(ShardSpec { index: k, count: parts });
                assert_eq!(shard_chunks(&GenerateSettings { shard, ..settings.clone() }), vec![k]);
            }
            assert_eq!(part_ids(parts - 1, &settings)[1], count);
        }
        assert_eq!(part_count(&GenerateSettings { chunk_size: 0, ..GenerateSettings::default() }), 0);
    }
}
