//! What the server's sessions share: the settings of `tandem serve`, its
//! counters and timings (served at `/stats`), and the count of open
//! sessions under the cap. Every session's tick records into them without
//! a lock and without allocating: the timings are log-scale histograms
//! of fixed size (before, a mutex every tick took while `/stats` sorted
//! copies of 40,000 samples).

use crate::control::timing::TickHistogram;
use crate::teleop::session::{SessionSettings, TeleopTask};
use serde::Serialize;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// How `tandem serve` runs.
#[derive(Clone)]
pub struct ServeSettings {
    /// Where to listen (default `127.0.0.1:8080`; port 0 picks a free one).
    pub address: SocketAddr,
    /// The sessions' settings.
    pub session: SessionSettings,
    /// States sent per second at most (default 60).
    pub state_rate_hz: f64,
    /// The task a new page starts on.
    pub task: TeleopTask,
    /// Its seed.
    pub seed: u64,
    /// Sessions open at once at most (default 64); a page beyond them is
    /// refused with `503 Service Unavailable` and the reason. Each session
    /// holds a prepared task (~2 MB) and ticks on the runtime: 1,000
    /// sessions took 2 GB and made 86 % of ticks late on two cores.
    pub max_sessions: usize,
    /// A connection that has not sent a whole HTTP request head within this
    /// long is closed (default 10 s).
    pub header_timeout: Duration,
    /// A page that sends no whole WebSocket frame for this long is closed
    /// with code 1001 (default 30 s). The server pings every third of it,
    /// and browsers answer pings by themselves, so an open page is never
    /// idle; a half-sent frame is.
    pub idle_timeout: Duration,
}

impl Default for ServeSettings {
    fn default() -> Self {
        ServeSettings {
            address: SocketAddr::from(([127, 0, 0, 1], 8080)),
            session: SessionSettings::default(),
            state_rate_hz: 60.0,
            task: TeleopTask::ReachGrasp,
            seed: 0,
            max_sessions: 64,
            header_timeout: Duration::from_secs(10),
            idle_timeout: Duration::from_secs(30),
        }
    }
}

/// Counters and timings of the server since it started, served at `/stats`.
#[derive(Debug, Default)]
pub struct ServerStats {
    pub(super) sessions_open: AtomicU64,
    pub(super) sessions_total: AtomicU64,
    pub(super) ticks: AtomicU64,
    pub(super) late_ticks: AtomicU64,
    pub(super) messages: AtomicU64,
    pub(super) rejected: AtomicU64,
    pub(super) closed_oversized: AtomicU64,
    pub(super) closed_idle: AtomicU64,
    pub(super) refused_full: AtomicU64,
    pub(super) states_sent: AtomicU64,
    pub(super) episodes_saved: AtomicU64,
    /// Executed steps that broke a position or velocity limit or collided.
    pub(super) hard_violations: AtomicU64,
    /// Executed commands that broke an acceleration, deceleration or jerk limit.
    pub(super) limit_violations: AtomicU64,
    /// Every session's ticks (µs).
    pub(super) tick_us: TickHistogram,
    /// Command to state latencies (µs).
    pub(super) latency_us: TickHistogram,
}

#[derive(Serialize)]
struct Percentiles {
    count: u64,
    median: f64,
    p99: f64,
    max: f64,
}

impl Percentiles {
    /// Within [`QUANTILE_ERROR`](crate::control::timing::QUANTILE_ERROR); the largest exact.
    fn of(samples: &TickHistogram) -> Percentiles {
        let [median, p99, max] = samples.summary();
        Percentiles { count: samples.count(), median, p99, max }
    }
}

impl ServerStats {
    /// The counters and percentiles as JSON (what `/stats` returns).
    pub fn to_json(&self) -> serde_json::Value {
        let load = |c: &AtomicU64| c.load(Ordering::Relaxed);
        serde_json::json!({
            "sessions_open": load(&self.sessions_open),
            "sessions_total": load(&self.sessions_total),
            "ticks": load(&self.ticks),
            "late_ticks": load(&self.late_ticks),
            "messages": load(&self.messages),
            "rejected": load(&self.rejected),
            "closed_oversized": load(&self.closed_oversized),
            "closed_idle": load(&self.closed_idle),
            "refused_full": load(&self.refused_full),
            "states_sent": load(&self.states_sent),
            "episodes_saved": load(&self.episodes_saved),
            "hard_violations": load(&self.hard_violations),
            "limit_violations": load(&self.limit_violations),
            "tick_us": Percentiles::of(&self.tick_us),
            "latency_us": Percentiles::of(&self.latency_us),
        })
    }
}

pub(super) struct Shared {
    pub(super) settings: ServeSettings,
    pub(super) stats: Arc<ServerStats>,
}

/// A counted open session: claimed below the cap before the upgrade, given
/// back when dropped — at the end of the session, if the upgrade fails, or
/// if the session's task unwinds.
pub(super) struct OpenSession(Arc<ServerStats>);

impl OpenSession {
    pub(super) fn claim(shared: &Shared) -> Option<OpenSession> {
        let stats = &shared.stats;
        let cap = shared.settings.max_sessions as u64;
        stats.sessions_open.fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < cap).then_some(n + 1)).ok()?;
        stats.sessions_total.fetch_add(1, Ordering::Relaxed);
        Some(OpenSession(stats.clone()))
    }
}

impl Drop for OpenSession {
    fn drop(&mut self) {
        self.0.sessions_open.fetch_sub(1, Ordering::AcqRel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sessions on four threads record 60,000 ticks while `/stats` is read
    /// without pause: nothing waits for a lock, every tick is counted (the
    /// percentiles used to cover the last 10,000 to 20,000 samples), the
    /// largest exact.
    #[test]
    fn every_tick_is_counted_while_stats_are_read() {
        let stats = Arc::new(ServerStats::default());
        let reading = std::sync::atomic::AtomicBool::new(true);
        std::thread::scope(|s| {
            s.spawn(|| {
                while reading.load(Ordering::Relaxed) {
                    let json = stats.to_json();
                    assert!(json["tick_us"]["count"].as_u64().unwrap() <= 60_000);
                }
            });
            let sessions: Vec<_> = (0..4)
                .map(|k| {
                    let stats = &stats;
                    s.spawn(move || {
                        for i in 0..15_000 {
                            stats.tick_us.record(10.0 + f64::from(i % 100) + f64::from(k));
                        }
                    })
                })
                .collect();
            for session in sessions {
                session.join().unwrap();
            }
            reading.store(false, Ordering::Relaxed);
        });
        let json = stats.to_json();
        assert_eq!(json["tick_us"]["count"], 60_000);
        assert_eq!(json["tick_us"]["max"], 112.0);
        let median = json["tick_us"]["median"].as_f64().unwrap();
        assert!((median - 61.5).abs() / 61.5 < 0.03, "{median}");
        assert_eq!(json["latency_us"]["count"], 0);
    }
}
