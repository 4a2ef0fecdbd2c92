//! The one harness every experiment runs in: the output folder checked
//! before the work starts, a thread pool of the asked size, progress, then
//! the results as JSON, a table and figures, written to the folder.

use crate::data::{Progress, ProgressRun};
use crate::figures::FigureError;
use crate::files::FileError;
use std::path::{Path, PathBuf};

/// Most worker threads an experiment may ask for (`--threads`).
pub const MAX_THREADS: usize = 1024;

/// Errors of an experiment run (an episode that fails is a result, not an
/// error).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// A task or an arbiter could not be set up.
    #[error(transparent)]
    Arbitration(Box<crate::arbitration::ArbitrationError>),
    /// A problem or family file could not be loaded.
    #[error(transparent)]
    Problem(#[from] crate::problem::ProblemError),
    /// The robot model rejected a configuration or a frame.
    #[error(transparent)]
    Robot(#[from] crate::robot::RobotError),
    /// A training dataset could not be generated.
    #[error(transparent)]
    Generate(#[from] crate::data::GenerateError),
    /// A learned policy could not be trained, loaded or evaluated.
    #[cfg(feature = "learn")]
    #[error(transparent)]
    Learn(Box<crate::learn::LearnError>),
    /// Traded control could not be set up.
    #[cfg(feature = "learn")]
    #[error(transparent)]
    Traded(Box<super::traded::TradedError>),
    /// A figure could not be drawn.
    #[error(transparent)]
    Figure(#[from] FigureError),
    /// A result file could not be written.
    #[error(transparent)]
    File(#[from] FileError),
    /// A setting outside its range, named as the command line names it.
    #[error(transparent)]
    InvalidSetting(#[from] crate::settings::InvalidSetting),
    /// The worker threads could not be started.
    #[error("cannot start {threads} worker threads (--threads): {message}")]
    Threads {
        /// How many were asked for.
        threads: usize,
        /// What the system said.
        message: String,
    },
    /// Results that cannot be encoded as JSON.
    #[error("encoding the results: {0}")]
    Json(#[from] serde_json::Error),
    /// The physics simulator cannot run (not built in, or MuJoCo refused
    /// the scene).
    #[error("physics: {0}")]
    Physics(String),
}

impl From<crate::arbitration::ArbitrationError> for ExperimentError {
    fn from(e: crate::arbitration::ArbitrationError) -> Self {
        ExperimentError::Arbitration(Box::new(e))
    }
}

#[cfg(feature = "learn")]
impl From<crate::learn::LearnError> for ExperimentError {
    fn from(e: crate::learn::LearnError) -> Self {
        ExperimentError::Learn(Box::new(e))
    }
}

#[cfg(feature = "learn")]
impl From<super::traded::TradedError> for ExperimentError {
    fn from(e: super::traded::TradedError) -> Self {
        ExperimentError::Traded(Box::new(e))
    }
}

/// Where and how an experiment runs; nothing here changes its results.
#[derive(Debug, Clone)]
pub struct HarnessSettings {
    /// Worker threads (default: all cores; 1 … [`MAX_THREADS`]).
    pub threads: Option<usize>,
    /// How progress is shown ([`Progress::quiet`] also silences the status
    /// lines an experiment prints while it runs).
    pub progress: Progress,
    /// Folder for the results (`NAME.json`), the figures and whatever the
    /// experiment keeps (datasets, trained policies, episode recordings);
    /// created before the work starts.
    pub out: Option<PathBuf>,
}

impl Default for HarnessSettings {
    fn default() -> Self {
        HarnessSettings { threads: None, progress: Progress::auto(), out: None }
    }
}

/// What a running experiment may use of the harness.
pub struct Context<'a> {
    progress: &'a ProgressRun,
    verbose: bool,
    out: Option<&'a Path>,
}

impl Context<'_> {
    /// One more unit (task, episode) done.
    pub fn done(&self) {
        self.progress.sample_done(true);
    }

    /// A status line on stdout, unless the run is quiet.
    pub fn say(&self, line: &str) {
        if self.verbose {
            println!("{line}");
        }
    }

    /// Whether status lines and progress are shown (not with `--json`).
    pub fn verbose(&self) -> bool {
        self.verbose
    }

    /// The output folder, when there is one (it exists).
    pub fn out(&self) -> Option<&Path> {
        self.out
    }

    /// Writes `text` to `name` in the output folder (nothing without one);
    /// returns the path written.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write(&self, name: &str, text: &str) -> Result<Option<PathBuf>, FileError> {
        let Some(dir) = self.out else { return Ok(None) };
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(FileError::io(&path))?;
        Ok(Some(path))
    }
}

/// An experiment: settings in, results out, with its JSON, table and figures.
pub trait Experiment: Sync {
    /// Its name: the results file is `NAME.json`.
    const NAME: &'static str;
    /// What a run produces.
    type Results: Send;
    /// How many units the progress counts, and what they are (`tasks`).
    fn units(&self) -> (u64, &'static str);
    /// Runs it; calls [`Context::done`] once per unit.
    ///
    /// # Errors
    /// Setup failures.
    fn run(&self, cx: &Context<'_>) -> Result<Self::Results, ExperimentError>;
    /// The results as one JSON object (`--json`, and `NAME.json`).
    fn json(&self, results: &Self::Results) -> serde_json::Value;
    /// The results as the text table printed without `--json`.
    fn table(&self, results: &Self::Results) -> String;
    /// Data files of the results beside the JSON (per-task CSV tables):
    /// file name and text each.
    fn data_files(&self, _results: &Self::Results) -> Vec<(String, String)> {
        Vec::new()
    }
    /// Figures of the results: file name and SVG text each.
    ///
    /// # Errors
    /// A figure that cannot be drawn.
    fn figures(&self, _results: &Self::Results) -> Result<Vec<(String, String)>, ExperimentError> {
        Ok(Vec::new())
    }
}

/// A finished run: the results, their JSON and table, the files written.
#[derive(Debug)]
pub struct Report<R> {
    /// The results.
    pub results: R,
    /// What `--json` prints.
    pub json: serde_json::Value,
    /// What is printed without `--json`.
    pub table: String,
    /// The files written to the output folder (results, data files and figures).
    pub written: Vec<PathBuf>,
}

/// Runs `experiment` in the harness: checks the settings and creates the
/// output folder, runs it on a pool of `settings.threads` threads with
/// progress, and writes `NAME.json`, the data files and the figures into
/// the folder.
///
/// # Errors
/// A thread count out of range or that cannot be started, an output folder
/// that cannot be created, the experiment's own errors.
pub fn run<E: Experiment>(experiment: &E, settings: &HarnessSettings) -> Result<Report<E::Results>, ExperimentError> {
    if let Some(threads) = settings.threads.filter(|t| !(1..=MAX_THREADS).contains(t)) {
        let expected = format!("between 1 and {MAX_THREADS}");
        return Err(crate::settings::InvalidSetting::new("--threads", threads, expected).into());
    }
    if let Some(dir) = &settings.out {
        std::fs::create_dir_all(dir).map_err(FileError::io(dir))?;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads.unwrap_or(0))
        .build()
        .map_err(|e| ExperimentError::Threads { threads: settings.threads.unwrap_or(0), message: e.to_string() })?;
    let (total, unit) = experiment.units();
    let progress = settings.progress.start_counting(total, unit, false);
    let cx =
        Context { progress: &progress, verbose: settings.progress != Progress::Quiet, out: settings.out.as_deref() };
    let results = pool.install(|| experiment.run(&cx))?;
    progress.finish();
    let json = tidy_json(experiment.json(&results));
    let mut written = Vec::new();
    if settings.out.is_some() {
        let text = serde_json::to_string_pretty(&json)? + "\n";
        written.extend(cx.write(&format!("{}.json", E::NAME), &text)?);
        for (name, data) in experiment.data_files(&results) {
            written.extend(cx.write(&name, &data)?);
        }
        for (name, svg) in experiment.figures(&results)? {
            written.extend(cx.write(&name, &svg)?);
        }
    }
    let table = experiment.table(&results);
    Ok(Report { results, json, table, written })
}

/// Mean and (population) standard deviation of the finite values; NaN
/// when there is none.
pub fn mean_std(values: impl Iterator<Item = f64>) -> [f64; 2] {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return [f64::NAN, f64::NAN];
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64;
    [mean, var.sqrt()]
}

/// `value` with every number rounded to 12 significant digits: means and
/// sums of simulated times print as 16.914, not 16.913999999999998 (the
/// noise of binary fractions), while keeping far more digits than any
/// result has.
pub fn tidy_json(value: serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match value {
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            let rounded: f64 = format!("{x:.11e}").parse().unwrap_or(x);
            serde_json::Number::from_f64(rounded).map_or(Value::Null, Value::Number)
        }
        Value::Array(items) => Value::Array(items.into_iter().map(tidy_json).collect()),
        Value::Object(map) => Value::Object(map.into_iter().map(|(k, v)| (k, tidy_json(v))).collect()),
        other => other,
    }
}
