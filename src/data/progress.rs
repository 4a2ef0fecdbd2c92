//! Progress of a long run: a bar with rate and ETA on a terminal, plain
//! periodic lines otherwise (logs, CI), or nothing.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How to report progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// A progress bar on stderr.
    Bar,
    /// A line on stderr every `every`.
    Lines {
        /// Seconds between two lines.
        every: Duration,
    },
    /// No output.
    Quiet,
}

impl Progress {
    /// A bar when stderr is a terminal, a line every 10 s otherwise.
    pub fn auto() -> Progress {
        if std::io::stderr().is_terminal() { Progress::Bar } else { Progress::Lines { every: Duration::from_secs(10) } }
    }

    /// No progress output.
    pub fn quiet() -> Progress {
        Progress::Quiet
    }

    /// Starts reporting `total` samples, each accepted or rejected.
    pub(crate) fn start(self, total: u64) -> ProgressRun {
        self.start_counting(total, "samples", true)
    }

    /// Starts reporting `total` items called `unit` ("tasks"), counting
    /// accepted ones when `acceptance`.
    pub(crate) fn start_counting(self, total: u64, unit: &'static str, acceptance: bool) -> ProgressRun {
        let bar = (self == Progress::Bar).then(|| {
            let bar = ProgressBar::new(total);
            let template = format!(
                "{{elapsed_precise}} [{{wide_bar}}] {{pos}}/{{len}} {unit} · {{per_sec}} · ETA {{eta}} · {{msg}}"
            );
            let style = ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> ");
            bar.set_style(style);
            bar
        });
        let every = match self {
            Progress::Lines { every } => Some(every),
            _ => None,
        };
        ProgressRun {
            bar,
            every,
            total,
            unit,
            acceptance,
            began: Instant::now(),
            last_line: Mutex::new(Instant::now()),
            done: AtomicU64::new(0),
            accepted: AtomicU64::new(0),
        }
    }
}

/// An ongoing report; shared by the worker threads.
#[derive(Debug)]
pub(crate) struct ProgressRun {
    bar: Option<ProgressBar>,
    every: Option<Duration>,
    total: u64,
    unit: &'static str,
    acceptance: bool,
    began: Instant,
    last_line: Mutex<Instant>,
    done: AtomicU64,
    accepted: AtomicU64,
}

impl ProgressRun {
    /// One more sample done.
    pub(crate) fn sample_done(&self, accepted: bool) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        let accepted = self.accepted.fetch_add(u64::from(accepted), Ordering::Relaxed) + u64::from(accepted);
        if let Some(bar) = &self.bar {
            if self.acceptance {
                bar.set_message(format!("{accepted} accepted, {} rejected", done - accepted));
            }
            bar.inc(1);
        }
        if let Some(every) = self.every {
            let Ok(mut last) = self.last_line.lock() else { return };
            if last.elapsed() >= every || done == self.total {
                *last = Instant::now();
                eprintln!("{}", self.line(done, accepted));
            }
        }
    }

    fn line(&self, done: u64, accepted: u64) -> String {
        let seconds = self.began.elapsed().as_secs_f64();
        let rate = done as f64 / seconds.max(1e-9);
        let eta = (self.total - done.min(self.total)) as f64 / rate.max(1e-9);
        let (total, unit) = (self.total, self.unit);
        let accepted = if self.acceptance { format!(" ({accepted} accepted)") } else { String::new() };
        format!("{done}/{total} {unit}{accepted} in {seconds:.0} s · {rate:.1}/s · ETA {eta:.0} s")
    }

    pub(crate) fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish();
            // The bar's last draw ends in a carriage return: without a
            // newline, the next line printed would overwrite it.
            eprintln!();
        }
    }
}
