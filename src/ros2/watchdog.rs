//! A watchdog on the control loop's own deadline grid: the loop writes the
//! deadline of its next tick into an atomic each tick; a thread of its own
//! checks it ten times per stall limit and reports (through the non-blocking log) a
//! loop whose next deadline passed more than [`STALL_PERIODS`] periods (and
//! at least [`STALL_FLOOR`]) ago, and again when it ticks once more.

use super::log::LogSender;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Periods past its deadline after which a loop counts as stalled.
pub const STALL_PERIODS: u32 = 10;
/// The shortest stall reported (a scheduler's hiccup on a loaded machine is not one).
pub const STALL_FLOOR: Duration = Duration::from_millis(100);

/// What the loop writes and the watchdog reads.
struct Shared {
    began: Instant,
    /// The next tick's deadline (ns since `began`).
    deadline_ns: AtomicU64,
    ticks: AtomicU64,
    running: AtomicBool,
    stalls: AtomicU64,
    longest_ns: AtomicU64,
}

/// The loop's side: its deadlines. Allocates nothing.
#[derive(Clone)]
pub struct Heartbeat(Arc<Shared>);

impl Heartbeat {
    /// The loop ticked and will tick next at `deadline`.
    pub fn beat(&self, deadline: Instant) {
        let ns = deadline.saturating_duration_since(self.0.began).as_nanos() as u64;
        self.0.deadline_ns.store(ns, Ordering::Relaxed);
        self.0.ticks.fetch_add(1, Ordering::Relaxed);
    }
}

/// Stalls seen over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stalls {
    /// Stalls reported.
    pub count: u64,
    /// The longest (s past the deadline).
    pub longest_s: f64,
}

/// The watchdog thread.
pub struct Watchdog {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl Watchdog {
    /// Watches a loop of `period` whose first deadline is `first`, writing to `log`.
    ///
    /// # Errors
    /// The thread cannot be started.
    pub fn spawn(period: Duration, first: Instant, log: LogSender) -> std::io::Result<(Watchdog, Heartbeat)> {
        let began = Instant::now().min(first);
        let shared = Arc::new(Shared {
            began,
            deadline_ns: AtomicU64::new(first.duration_since(began).as_nanos() as u64),
            ticks: AtomicU64::new(0),
            running: AtomicBool::new(true),
            stalls: AtomicU64::new(0),
            longest_ns: AtomicU64::new(0),
        });
        let limit = (period * STALL_PERIODS).max(STALL_FLOOR);
        // A tenth of the limit: a stall is seen within 10 % of its length,
        // and at 1 kHz the thread wakes 100 times a second, not 1,000.
        let check = (limit / 10).min(Duration::from_millis(20));
        let watched = Arc::clone(&shared);
        let thread = std::thread::Builder::new().name("ros2-watchdog".into()).spawn(move || {
            let s = watched;
            let mut stalled: Option<Duration> = None;
            while s.running.load(Ordering::Relaxed) {
                std::thread::sleep(check);
                let deadline = s.began + Duration::from_nanos(s.deadline_ns.load(Ordering::Relaxed));
                let late = Instant::now().saturating_duration_since(deadline);
                match stalled {
                    None if late > limit => {
                        stalled = Some(late);
                        s.stalls.fetch_add(1, Ordering::Relaxed);
                        log.send(format_args!(
                            "the control loop is stalled: {:.0} ms past its deadline, after tick {}",
                            late.as_secs_f64() * 1e3,
                            s.ticks.load(Ordering::Relaxed)
                        ));
                    }
                    Some(longest) if late <= limit => {
                        stalled = None;
                        log.send(format_args!(
                            "the control loop ticks again after a stall of {:.0} ms",
                            longest.as_secs_f64() * 1e3
                        ));
                    }
                    Some(longest) => stalled = Some(longest.max(late)),
                    None => {}
                }
                if let Some(longest) = stalled {
                    s.longest_ns.fetch_max(longest.as_nanos() as u64, Ordering::Relaxed);
                }
            }
        })?;
        Ok((Watchdog { shared: Arc::clone(&shared), thread: Some(thread) }, Heartbeat(shared)))
    }

    /// Stops the thread and says what it saw.
    pub fn finish(mut self) -> Stalls {
        self.shared.running.store(false, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            // It only sleeps and sends without waiting: it ends within a check.
            let _ = thread.join();
        }
        Stalls {
            count: self.shared.stalls.load(Ordering::Relaxed),
            longest_s: self.shared.longest_ns.load(Ordering::Relaxed) as f64 * 1e-9,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::log::NodeLog;
    use std::io::Write;
    use std::sync::Mutex;

    #[derive(Clone, Default)]
    struct Sink(Arc<Mutex<Vec<u8>>>);

    impl Write for Sink {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A loop at 100 Hz that stops beating for 300 ms is reported once,
    /// and again when it beats; one that keeps its grid is not.
    #[test]
    fn a_stalled_loop_is_reported_and_a_punctual_one_is_not() {
        let sink = Sink::default();
        let log = NodeLog::spawn(Box::new(sink.clone())).unwrap();
        let period = Duration::from_millis(10);
        let mut deadline = Instant::now() + period;
        let (watchdog, heartbeat) = Watchdog::spawn(period, deadline, log.sender()).unwrap();
        for _ in 0..20 {
            std::thread::sleep(deadline.saturating_duration_since(Instant::now()));
            deadline += period;
            heartbeat.beat(deadline);
        }
        std::thread::sleep(Duration::from_millis(300));
        for _ in 0..20 {
            deadline = Instant::now() + period;
            heartbeat.beat(deadline);
            std::thread::sleep(period);
        }
        let stalls = watchdog.finish();
        log.finish(Duration::from_secs(2));
        let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
        assert_eq!(stalls.count, 1, "{text}");
        assert!((0.1..0.5).contains(&stalls.longest_s), "{stalls:?}");
        assert!(text.contains("the control loop is stalled") && text.contains("after tick 20"), "{text}");
        assert!(text.contains("the control loop ticks again after a stall of"), "{text}");
    }
}
