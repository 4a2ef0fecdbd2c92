//! Bulk datasets of optimized trajectories (feature `data`, on by default).
//!
//! Bulk generation ([`generate()`]) samples problems from a
//! [`ProblemFamily`](crate::problem::ProblemFamily), runs IK →
//! RRT-Connect → trajectory optimization → validation on every core, and
//! streams the accepted trajectories to Parquet part files: deterministic
//! (the dataset depends on the seed and ids only, not on the thread count),
//! resumable (parts are written atomically and skipped when present) and
//! described by a JSON manifest. The dataset layout and schema are in
//! [`schema`].
//!
//! ```no_run
//! use tandem::data::{GenerateSettings, generate, Progress};
//! use tandem::pipeline::PipelineSettings;
//! let pipeline = PipelineSettings { horizon: Some(50), ..PipelineSettings::default() };
//! let settings = GenerateSettings { count: 1000, seed: 7, pipeline, ..GenerateSettings::default() };
//! let summary = generate("problems/panda_grasp_family.toml".as_ref(), "dataset".as_ref(), &settings, &Progress::quiet())?;
//! println!("{} accepted, {} rejected", summary.manifest.accepted, summary.manifest.rejected);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod generate;
mod manifest;
mod progress;
mod sample;
pub mod schema;
mod shard;

pub use generate::{
    GenerateError, GenerateSettings, GenerateSummary, MAX_CHUNK_SIZE, MAX_COUNT, MAX_PART_SLICES, MAX_PARTS,
    MAX_THREADS, ShardSpec, dataset_parameters, generate, part_count, part_ids, pending_parts, robot_sha256,
};
pub use manifest::{DatasetParameters, Manifest, PartEntry};
pub use progress::Progress;
#[cfg(feature = "experiments")]
pub(crate) use progress::ProgressRun;
pub use sample::{Rejection, SampleOutcome, SampleTiming, TrajectoryRecord, run_problem, run_sample};
pub use shard::{PartSummary, read_part_summary, write_part};
