//! `tandem generate`: bulk training trajectories from a problem family.

use crate::data::{
    GenerateSettings, GenerateSummary, MAX_CHUNK_SIZE, MAX_COUNT, MAX_THREADS, Progress, ShardSpec, generate,
};
use crate::pipeline::{InitialGuess, MAX_ATTEMPTS, MAX_EVALUATIONS, PipelineSettings};
use crate::problem::{MAX_HORIZON, MIN_HORIZON};
use std::path::PathBuf;

/// Arguments of `tandem generate`.
#[derive(Debug, clap::Args)]
pub struct GenerateArgs {
    /// The problem family file (format: problems/README.md), e.g.
    /// problems/panda_grasp_family.toml.
    #[arg(long, value_name = "FAMILY.toml")]
    pub family: PathBuf,
    /// Number of samples: ids 0 … N−1 (1 to 10^11; at most 10^6 part files).
    #[arg(long, value_name = "N", value_parser = |s: &str| super::number_in(s, 1..=MAX_COUNT))]
    pub count: u64,
    /// Dataset folder: part-NNNNN.parquet files, _dataset.json, _manifest.json
    /// and _timings/. Re-running the same command completes it.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Run seed S: sample i draws from a stream seeded by (S, i) only.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Slices per trajectory T, 2 to 100000 (default: the base problem's
    /// optimizer.horizon).
    #[arg(long, short = 'T', value_name = "T",
          value_parser = |s: &str| super::number_in(s, MIN_HORIZON..=MAX_HORIZON))]
    pub horizon: Option<usize>,
    /// Worker threads, 1 to 1024 (default: every core). Does not change the output.
    #[arg(long, value_name = "K", value_parser = |s: &str| super::number_in(s, 1..=MAX_THREADS))]
    pub threads: Option<usize>,
    /// Generate only share I of M (0 ≤ I < M) of the part files, e.g. on M
    /// machines; the shards together are the dataset of one run. Writes
    /// _manifest-shard-I-of-M.json; the unsharded command over the union
    /// then only writes _manifest.json.
    #[arg(long, value_name = "I/M")]
    pub shard: Option<ShardSpec>,
    /// Ids per part file (part of the dataset's identity), 1 to 100000,
    /// and at most 10^7 slices (IDS × (T + 1)) per part.
    #[arg(long, default_value_t = 100, value_name = "IDS",
          value_parser = |s: &str| super::number_in(s, 1..=MAX_CHUNK_SIZE))]
    pub chunk_size: u64,
    /// IK + planning + optimization attempts per sample before it counts
    /// as rejected; each uses another planner seed, and the even-numbered
    /// ones (2nd, 4th, …) the flipped grasp; 1 to 100.
    #[arg(long, default_value_t = 3, value_parser = |s: &str| super::number_in(s, 1..=MAX_ATTEMPTS))]
    pub attempts: u32,
    /// Evaluation budget of each optimizer solve of an attempt, 1 to 10^6.
    #[arg(long, default_value_t = 200, value_name = "N",
          value_parser = |s: &str| super::number_in(s, 1..=MAX_EVALUATIONS))]
    pub max_evaluations: usize,
    /// What the optimizer starts from: `planned` (RRT-Connect's path to
    /// whichever goal configuration it reached), or `straight` (the
    /// straight line to the goal configuration nearest the start, the
    /// planned path when that fails): motions that depend on the task
    /// only, not on the planner's seed.
    #[arg(long, value_enum, default_value_t = InitialGuess::Planned, value_name = "GUESS")]
    pub initial_guess: InitialGuess,
    /// Print the manifest as one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// No progress bar or progress lines.
    #[arg(long)]
    pub quiet: bool,
}

pub(super) fn run(args: &GenerateArgs) -> Result<(), Box<dyn std::error::Error>> {
    let settings = GenerateSettings {
        count: args.count,
        seed: args.seed,
        threads: args.threads,
        shard: args.shard,
        chunk_size: args.chunk_size,
        pipeline: PipelineSettings {
            horizon: args.horizon,
            attempts: args.attempts,
            max_evaluations: args.max_evaluations,
            initial_guess: args.initial_guess,
            ..PipelineSettings::default()
        },
    };
    let progress = if args.quiet || args.json { Progress::quiet() } else { Progress::auto() };
    let summary = generate(&args.family, &args.out, &settings, &progress)?;
    if args.json {
        println!("{}", serde_json::to_string(&summary.manifest)?);
    } else {
        print_summary(&summary);
    }
    Ok(())
}

fn print_summary(s: &GenerateSummary) {
    let m = &s.manifest;
    println!(
        "{}: ids {}..{}, {} accepted of {} ({:.2} %), {} rejected",
        m.parameters.family,
        m.ids[0],
        m.ids[1],
        m.accepted,
        m.samples,
        100.0 * m.acceptance(),
        m.rejected
    );
    for (reason, n) in &m.rejected_by_reason {
        println!("  rejected, {reason}: {n}");
    }
    if s.samples_run > 0 {
        let median = s.sample_ms.get(s.sample_ms.len() / 2).copied().unwrap_or(0.0);
        println!(
            "this run: {} samples in {:.1} s, {:.1} samples/s ({} part files written, {} kept); median sample {median:.1} ms",
            s.samples_run,
            s.elapsed.as_secs_f64(),
            s.rate(),
            s.parts_written,
            s.parts_kept
        );
    } else {
        println!("nothing to do: all {} part files were already complete", s.parts_kept);
    }
    if let Some(mib) = peak_memory_mib() {
        println!("peak memory (resident): {mib:.1} MiB");
    }
    println!("manifest: {}", s.manifest_path.display());
}

/// The process's peak resident set size (MiB), where the OS reports it.
fn peak_memory_mib() -> Option<f64> {
    // SAFETY: getrusage writes into the zeroed struct we own.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } == 0;
    // Linux reports kilobytes, macOS bytes.
    let kib = if cfg!(target_os = "macos") { usage.ru_maxrss as f64 / 1024.0 } else { usage.ru_maxrss as f64 };
    (ok && kib > 0.0).then_some(kib / 1024.0)
}
