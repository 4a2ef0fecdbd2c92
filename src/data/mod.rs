//! Trajectory files and bulk datasets.
//!
//! Single trajectories go to CSV (people, spreadsheets) and Parquet
//! ([`write_csv`], `write_parquet`), in one format ([`TrajectoryTable`]:
//! the start configuration first) that every command reads back. With the
//! `data` feature (on by default), bulk generation (`generate`) samples
//! problems from a [`ProblemFamily`](crate::problem::ProblemFamily), runs IK →
//! RRT-Connect → trajectory optimization → validation on every core, and
//! streams the accepted trajectories to Parquet part files: deterministic
//! (the dataset depends on the seed and ids only, not on the thread count),
//! resumable (parts are written atomically and skipped when present) and
//! described by a JSON manifest. The dataset layout and schema are in
//! [`schema`]. Shared-control episodes go to Parquet too (`write_episodes`,
//! one row per control tick).
//!
//! ```no_run
//! # #[cfg(feature = "data")] {
//! use tandem::data::{GenerateSettings, generate, Progress};
//! let settings = GenerateSettings { count: 1000, seed: 7, horizon: Some(50), ..GenerateSettings::default() };
//! let summary = generate("problems/panda_grasp_family.toml".as_ref(), "dataset".as_ref(), &settings, &Progress::quiet())?;
//! println!("{} accepted, {} rejected", summary.manifest.accepted, summary.manifest.rejected);
//! # }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#[cfg(feature = "data")]
mod episodes;
#[cfg(feature = "data")]
mod generate;
#[cfg(feature = "data")]
mod manifest;
#[cfg(feature = "data")]
mod progress;
#[cfg(feature = "data")]
mod sample;
#[cfg(feature = "data")]
pub mod schema;
#[cfg(feature = "data")]
mod shard;
mod trajectory;

#[cfg(feature = "data")]
pub use episodes::write_episodes;
#[cfg(feature = "data")]
pub use generate::{
    GenerateError, GenerateSettings, GenerateSummary, MAX_ATTEMPTS, MAX_CHUNK_SIZE, MAX_COUNT, MAX_EVALUATIONS,
    MAX_PART_SLICES, MAX_PARTS, MAX_THREADS, ShardSpec, generate, part_count, part_ids, pending_parts,
};
#[cfg(feature = "data")]
pub use manifest::{DatasetParameters, Manifest, PartEntry};
#[cfg(feature = "data")]
pub use progress::Progress;
#[cfg(feature = "data")]
pub use sample::{
    GoalMiss, Rejection, SampleOutcome, SampleTiming, TrajectoryRecord, goal_miss, run_problem, run_sample,
};
#[cfg(feature = "data")]
pub use shard::{PartSummary, read_part_summary, write_part};
#[cfg(feature = "data")]
pub use trajectory::write_parquet;
pub use trajectory::{DataError, TrajectoryTable, write_csv};
