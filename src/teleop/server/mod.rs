//! The web server: the page at `/`, its script at `/app.js`, one
//! [`TeleopSession`] per WebSocket at `/ws`, and health and timing at
//! `/stats`. Each session ticks at the control rate on the runtime; states
//! go out at most 60 times a second through a latest-wins channel, so a
//! slow page never delays the control loop, and a flood of commands only
//! overwrites the latest one.

use super::TeleopError;
use super::protocol::MAX_FRAME_BYTES;
use super::session::{SessionSettings, TeleopTask};
use axum::Router;
use axum::extract::State;
use axum::extract::ws::WebSocketUpgrade;
use axum::http::header;
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use serde::Serialize;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

mod socket;
use socket::run_session;

const PAGE: &str = include_str!("../../../web/index.html");
const SCRIPT: &str = include_str!("../../../web/dist/app.js");

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

/// Counters and recent timings of the server, served at `/stats`.
#[derive(Debug, Default)]
pub struct ServerStats {
    sessions_open: AtomicU64,
    sessions_total: AtomicU64,
    ticks: AtomicU64,
    late_ticks: AtomicU64,
    messages: AtomicU64,
    rejected: AtomicU64,
    closed_oversized: AtomicU64,
    closed_idle: AtomicU64,
    refused_full: AtomicU64,
    states_sent: AtomicU64,
    episodes_saved: AtomicU64,
    samples: Mutex<Samples>,
}

#[derive(Debug, Default)]
struct Samples {
    tick_us: Vec<f64>,
    latency_us: Vec<f64>,
}

/// Recent samples kept for the percentiles.
const KEPT_SAMPLES: usize = 20_000;

fn keep(samples: &mut Vec<f64>, value: f64) {
    if samples.len() >= KEPT_SAMPLES {
        samples.drain(..KEPT_SAMPLES / 2);
    }
    samples.push(value);
}

#[derive(Serialize)]
struct Percentiles {
    count: usize,
    median: f64,
    p99: f64,
    max: f64,
}

impl Percentiles {
    fn of(samples: &[f64]) -> Percentiles {
        let (median, p99, max) = crate::sim::percentiles(samples);
        Percentiles { count: samples.len(), median, p99, max }
    }
}

impl ServerStats {
    /// The counters and percentiles as JSON (what `/stats` returns).
    pub fn to_json(&self) -> serde_json::Value {
        let load = |c: &AtomicU64| c.load(Ordering::Relaxed);
        let samples = self.samples.lock().unwrap_or_else(|e| e.into_inner());
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
            "tick_us": Percentiles::of(&samples.tick_us),
            "latency_us": Percentiles::of(&samples.latency_us),
        })
    }
}

struct Shared {
    settings: ServeSettings,
    stats: Arc<ServerStats>,
}

/// A bound server, ready to [`Server::run`].
pub struct Server {
    listener: tokio::net::TcpListener,
    app: Router,
    stats: Arc<ServerStats>,
    header_timeout: Duration,
}

impl Server {
    /// Binds `settings.address`.
    ///
    /// # Errors
    /// The address cannot be bound (in use, not local, …).
    pub async fn bind(settings: ServeSettings) -> Result<Server, TeleopError> {
        let listener = tokio::net::TcpListener::bind(settings.address).await?;
        let stats = Arc::new(ServerStats::default());
        let header_timeout = settings.header_timeout;
        let shared = Arc::new(Shared { settings, stats: stats.clone() });
        let app = Router::new()
            .route("/", get(|| async { Html(PAGE) }))
            .route("/app.js", get(|| async { ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], SCRIPT) }))
            .route("/stats", get(stats_page))
            .route("/ws", get(upgrade))
            .with_state(shared);
        Ok(Server { listener, app, stats, header_timeout })
    }

    /// The address it listens on.
    ///
    /// # Errors
    /// The socket's address cannot be read.
    pub fn local_addr(&self) -> Result<SocketAddr, TeleopError> {
        Ok(self.listener.local_addr()?)
    }

    /// Its counters.
    pub fn stats(&self) -> Arc<ServerStats> {
        self.stats.clone()
    }

    /// Serves until the process ends.
    ///
    /// # Errors
    /// The listener failing.
    pub async fn run(self) -> Result<(), TeleopError> {
        // axum::serve sets no timer, so hyper never times out a request
        // head: connections are served here with one and a header timeout.
        let mut http = hyper::server::conn::http1::Builder::new();
        http.timer(hyper_util::rt::TokioTimer::new()).header_read_timeout(self.header_timeout);
        loop {
            let (stream, _) = match self.listener.accept().await {
                Ok(accepted) => accepted,
                // Out of file descriptors and the like: wait, do not spin.
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            };
            let service = hyper_util::service::TowerToHyperService::new(self.app.clone());
            let connection = http.serve_connection(hyper_util::rt::TokioIo::new(stream), service).with_upgrades();
            tokio::spawn(async move {
                let _ = connection.await;
            });
        }
    }
}

/// Serves on a runtime of its own until the process ends; `ready` is told
/// the bound address first.
///
/// # Errors
/// Binding or serving failing.
pub fn serve(settings: ServeSettings, ready: impl FnOnce(SocketAddr)) -> Result<(), TeleopError> {
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    runtime.block_on(async {
        let server = Server::bind(settings).await?;
        ready(server.local_addr()?);
        server.run().await
    })
}

async fn stats_page(State(shared): State<Arc<Shared>>) -> Response {
    ([(header::CONTENT_TYPE, "application/json")], shared.stats.to_json().to_string()).into_response()
}

async fn upgrade(ws: WebSocketUpgrade, State(shared): State<Arc<Shared>>) -> Response {
    let Some(open) = OpenSession::claim(&shared) else {
        shared.stats.refused_full.fetch_add(1, Ordering::Relaxed);
        let message = format!(
            "the server has its most sessions open ({}, `tandem serve --max-sessions`); try again later",
            shared.settings.max_sessions
        );
        return (axum::http::StatusCode::SERVICE_UNAVAILABLE, message).into_response();
    };
    ws.max_message_size(MAX_FRAME_BYTES)
        .max_frame_size(MAX_FRAME_BYTES)
        .on_upgrade(move |socket| run_session(socket, shared, open))
}

/// A counted open session: claimed below the cap before the upgrade, given
/// back when dropped — at the end of the session, if the upgrade fails, or
/// if the session's task unwinds.
struct OpenSession(Arc<ServerStats>);

impl OpenSession {
    fn claim(shared: &Shared) -> Option<OpenSession> {
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
