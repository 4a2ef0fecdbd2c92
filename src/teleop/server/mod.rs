//! The web server: the page at `/`, its script at `/app.js`, one
//! [`TeleopSession`](super::TeleopSession) per WebSocket at `/ws`, and health and timing at
//! `/stats`. Each session ticks at the control rate on the runtime; states
//! go out at most 60 times a second through a latest-wins channel, so a
//! slow page never delays the control loop, and a flood of commands only
//! overwrites the latest one.

use super::TeleopError;
use super::protocol::MAX_FRAME_BYTES;
use axum::Router;
use axum::extract::State;
use axum::extract::ws::WebSocketUpgrade;
use axum::http::header;
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

mod socket;
mod state;
use socket::run_session;
use state::{OpenSession, Shared};
pub use state::{ServeSettings, ServerStats};

const PAGE: &str = include_str!("../../../web/index.html");
const SCRIPT: &str = include_str!("../../../web/dist/app.js");

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
