//! One WebSocket session: commands in, the session ticked at the control
//! rate, states and messages out through the writer task, and the
//! close handshake.

use super::state::{OpenSession, ServerStats, Shared};
use crate::teleop::protocol::{ClientMessage, MAX_MESSAGE_BYTES, parse_client_message};
use crate::teleop::session::{SessionSettings, TeleopSession, TeleopTask};
use crate::teleop::{StateView, TeleopError};
use axum::extract::ws::{CloseFrame, Message, WebSocket};
use futures_util::{SinkExt, StreamExt};
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, watch};

/// Messages to the page other than states, which go through a latest-wins
/// channel.
enum Outgoing {
    Text(String),
    Ping,
    Close(u16, &'static str),
}

fn json_message<T: Serialize>(kind: &str, body: &T) -> String {
    let mut value = serde_json::to_value(body).unwrap_or(serde_json::Value::Null);
    if let serde_json::Value::Object(map) = &mut value {
        map.insert("type".into(), kind.into());
    }
    value.to_string()
}

/// Writes to the socket: control messages in order, and the latest state
/// whenever it changes.
async fn writer(
    mut sink: futures_util::stream::SplitSink<WebSocket, Message>,
    mut control: mpsc::Receiver<Outgoing>,
    mut states: watch::Receiver<Option<String>>,
    stats: Arc<ServerStats>,
) {
    loop {
        let message = tokio::select! {
            biased;
            m = control.recv() => match m {
                Some(Outgoing::Text(t)) => Message::Text(t.into()),
                Some(Outgoing::Ping) => Message::Ping(Default::default()),
                Some(Outgoing::Close(code, reason)) => {
                    let _ = sink.send(Message::Close(Some(CloseFrame { code, reason: reason.into() }))).await;
                    return;
                }
                None => return,
            },
            changed = states.changed() => {
                if changed.is_err() {
                    return;
                }
                let Some(text) = states.borrow_and_update().clone() else { continue };
                stats.states_sent.fetch_add(1, Ordering::Relaxed);
                Message::Text(text.into())
            }
        };
        if sink.send(message).await.is_err() {
            return;
        }
    }
}

/// The per-connection loop state.
struct Connection {
    shared: Arc<Shared>,
    control: mpsc::Sender<Outgoing>,
    states: watch::Sender<Option<String>>,
    errors_sent: (Instant, u32),
    last_state_sent: Option<Instant>,
    /// When the newest command not yet reflected in a sent state arrived.
    unanswered_command: Option<Instant>,
}

impl Connection {
    fn send(&self, text: String) {
        // A page that does not read fills the queue: drop, never block the loop.
        let _ = self.control.try_send(Outgoing::Text(text));
    }

    /// Tells the page what was wrong, at most 10 times a second.
    fn error(&mut self, message: &str) {
        self.shared.stats.rejected.fetch_add(1, Ordering::Relaxed);
        let now = Instant::now();
        if now.duration_since(self.errors_sent.0) > Duration::from_secs(1) {
            self.errors_sent = (now, 0);
        }
        if self.errors_sent.1 < 10 {
            self.errors_sent.1 += 1;
            self.send(json_message("error", &serde_json::json!({ "message": message })));
        }
    }

    fn scene(&mut self, session: &TeleopSession) {
        self.send(json_message("scene", &session.scene()));
        self.publish(session.state(), true);
    }

    /// Sends `state` when one is due (at most `state_rate_hz`) or `force`d;
    /// the latency of the command it answers, if any, goes with it.
    fn publish(&mut self, state: &StateView, force: bool) {
        let now = Instant::now();
        let period = 1.0 / self.shared.settings.state_rate_hz;
        let due = self.last_state_sent.is_none_or(|t| now.duration_since(t).as_secs_f64() >= period * 0.95);
        if !(force || due) {
            return;
        }
        let mut view = state.clone();
        if let Some(at) = self.unanswered_command.take() {
            view.latency_us = now.duration_since(at).as_secs_f64() * 1e6;
            self.shared.stats.latency_us.record(view.latency_us);
        }
        self.states.send_replace(Some(json_message("state", &view)));
        self.last_state_sent = Some(now);
    }
}

type Preparing = tokio::task::JoinHandle<(Option<TeleopSession>, Result<TeleopSession, TeleopError>)>;

/// Prepares `task` off the runtime's threads (it plans and optimizes).
fn start_preparing(settings: &SessionSettings, old: Option<TeleopSession>, task: TeleopTask, seed: u64) -> Preparing {
    let settings = settings.clone();
    tokio::task::spawn_blocking(move || match old {
        Some(mut session) => {
            let result = session.restart(task, seed);
            match result {
                Ok(()) => (None, Ok(session)),
                Err(e) => (Some(session), Err(e)),
            }
        }
        None => (None, TeleopSession::prepare(&settings, task, seed)),
    })
}

pub(super) async fn run_session(socket: WebSocket, shared: Arc<Shared>, open: OpenSession) {
    let stats = shared.stats.clone();
    let (sink, mut stream) = socket.split();
    let (control_tx, control_rx) = mpsc::channel(64);
    let (state_tx, state_rx) = watch::channel(None);
    let writer = tokio::spawn(writer(sink, control_rx, state_rx, stats.clone()));
    let settings = shared.settings.clone();
    let mut conn = Connection {
        shared,
        control: control_tx,
        states: state_tx,
        errors_sent: (Instant::now(), 0),
        last_state_sent: None,
        unanswered_command: None,
    };
    conn.send(json_message(
        "hello",
        &serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "tasks": TeleopTask::ALL.map(|t| t.as_str()),
            "rate_hz": settings.session.rate_hz,
            "max_speed": settings.session.max_speed,
            "max_message_bytes": MAX_MESSAGE_BYTES,
        }),
    ));
    conn.send(json_message("preparing", &serde_json::json!({ "task": settings.task.as_str(), "seed": settings.seed })));
    let mut session: Option<TeleopSession> = None;
    let mut preparing = Some(start_preparing(&settings.session, None, settings.task, settings.seed));
    let period = Duration::from_secs_f64(1.0 / settings.session.rate_hz);
    let mut clock = tokio::time::interval(period);
    clock.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut last_tick: Option<Instant> = None;
    // A mode asked for while a task is being prepared: applied when it is
    // ready (the page may switch right after a reset).
    let mut pending_mode: Option<String> = None;
    let idle = settings.idle_timeout;
    let idle_deadline = tokio::time::sleep(idle);
    tokio::pin!(idle_deadline);
    let mut pings = tokio::time::interval_at(tokio::time::Instant::now() + idle / 3, idle / 3);
    pings.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        tokio::select! {
            _ = pings.tick() => {
                let _ = conn.control.try_send(Outgoing::Ping);
            }
            () = &mut idle_deadline => {
                stats.closed_idle.fetch_add(1, Ordering::Relaxed);
                let _ = conn.control.try_send(Outgoing::Close(1001, IDLE));
                break;
            }
            _ = clock.tick(), if session.is_some() => {
                let now = Instant::now();
                if last_tick.is_some_and(|t| now.duration_since(t) > period.mul_f64(1.5)) {
                    stats.late_ticks.fetch_add(1, Ordering::Relaxed);
                }
                last_tick = Some(now);
                if let Some(s) = session.as_mut() {
                    // A tick does not panic (every mode on arms of any size is
                    // fuzzed); were one to, the page is told and the
                    // connection closed cleanly instead of dropped.
                    let ticked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| tick(&mut conn, s, now)));
                    if ticked.is_err() {
                        conn.error("internal error: the simulator panicked; this session ends (please report it)");
                        let _ = conn.control.try_send(Outgoing::Close(1011, "internal error"));
                        break;
                    }
                }
            }
            done = async { preparing.as_mut().expect("guarded by the branch condition").await }, if preparing.is_some() => {
                preparing = None;
                let ready = match done {
                    Ok((_, Ok(s))) => Some(s),
                    Ok((old, Err(e))) => {
                        conn.error(&format!("{e}"));
                        old
                    }
                    Err(e) => {
                        conn.error(&format!("preparing the task panicked: {e}"));
                        None
                    }
                };
                if let Some(mut s) = ready {
                    if let Some(Err(e)) = pending_mode.take().map(|mode| s.set_mode(&mode)) {
                        s.reject();
                        conn.error(&e);
                    }
                    conn.scene(&s);
                    session = Some(s);
                }
            }
            incoming = stream.next() => {
                let Some(incoming) = incoming else { break };
                idle_deadline.as_mut().reset(tokio::time::Instant::now() + idle);
                stats.messages.fetch_add(1, Ordering::Relaxed);
                if incoming.as_ref().is_ok_and(|m| payload_bytes(m) > MAX_MESSAGE_BYTES) {
                    stats.closed_oversized.fetch_add(1, Ordering::Relaxed);
                    let _ = conn.control.try_send(Outgoing::Close(1009, OVERSIZED));
                    close_handshake(&mut stream).await;
                    break;
                }
                match incoming {
                    Ok(Message::Text(text)) => {
                        let action = handle_text(&mut conn, session.as_mut(), preparing.is_some(), &text);
                        if let Some(Action::QueueMode(mode)) = action {
                            pending_mode = Some(mode);
                        } else if let Some(Action::Reset(task, seed)) = action {
                            if preparing.is_some() {
                                conn.error("a task is being prepared; reset again when it is ready");
                            } else {
                                let mut old = session.take();
                                if let Some(s) = old.as_mut().filter(|s| s.outcome().is_none()) {
                                    finish_episode(&conn, s, &stats);
                                }
                                let task = task.unwrap_or(old.as_ref().map_or(settings.task, TeleopSession::task));
                                let seed = seed.unwrap_or(old.as_ref().map_or(settings.seed, TeleopSession::seed));
                                let body = serde_json::json!({ "task": task.as_str(), "seed": seed });
                                pending_mode = None;
                                conn.send(json_message("preparing", &body));
                                preparing = Some(start_preparing(&settings.session, old, task, seed));
                            }
                        }
                    }
                    Ok(Message::Binary(_)) => {
                        conn.error("binary frames are not read: send JSON text messages");
                        if let Some(s) = session.as_mut() { s.reject(); }
                    }
                    Ok(Message::Close(_)) => break,
                    Ok(Message::Ping(_) | Message::Pong(_)) => {}
                    Err(e) => {
                        // The only read errors that leave a reason to give:
                        // a frame over the WebSocket layer's limit (1009).
                        if format!("{e:?}").contains("Capacity") || format!("{e}").contains("too long") {
                            stats.closed_oversized.fetch_add(1, Ordering::Relaxed);
                            let _ = conn.control.try_send(Outgoing::Close(1009, OVERSIZED));
                        }
                        break;
                    }
                }
            }
        }
    }
    if let Some(s) = session.as_mut().filter(|s| s.outcome().is_none()) {
        // Saved even after a panicking tick, if the recording allows.
        let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| finish_episode(&conn, s, &stats)));
    }
    drop(conn);
    let _ = writer.await;
    drop(open);
}

const OVERSIZED: &str = "message larger than 4096 bytes";
const IDLE: &str = "no message from the page within the idle timeout";

fn payload_bytes(message: &Message) -> usize {
    match message {
        Message::Text(text) => text.len(),
        Message::Binary(bytes) => bytes.len(),
        _ => 0,
    }
}

/// Reads (and drops) what the page still sends until it answers our close
/// frame, for at most two seconds. Closing the socket while unread bytes
/// sit in its buffer makes the kernel reset it, and the page would see an
/// abnormal close (1006) instead of our code.
async fn close_handshake(stream: &mut futures_util::stream::SplitStream<WebSocket>) {
    let drain = async {
        while let Some(Ok(message)) = stream.next().await {
            if matches!(message, Message::Close(_)) {
                break;
            }
        }
    };
    let _ = tokio::time::timeout(Duration::from_secs(2), drain).await;
}

/// Ends the session's episode, saves it, and tells the page how, why and
/// where. A page that never drove has no episode to end: nothing is saved
/// or said. Called once per episode: when it ends by itself (at that tick),
/// else when the page resets or leaves while it runs. The recording is
/// written on a blocking thread, the page told when it is: a tick never
/// waits for the disk (a slow or full one stalled every session on the
/// runtime's thread).
fn finish_episode(conn: &Connection, session: &mut TeleopSession, stats: &Arc<ServerStats>) {
    if !session.driven() {
        return;
    }
    let recording = session.finish_unwritten();
    let outcome = session.outcome().map_or("failed", |o| o.as_str());
    let state = session.state();
    let mut episode = serde_json::json!({
        "outcome": outcome,
        "reason": state.reason,
        "reason_detail": state.reason_detail,
        "steps": state.steps,
        "time": state.time,
        "min_clearance": state.min_clearance,
        "file": null,
    });
    let Some(recording) = recording else {
        conn.send(json_message("episode", &episode));
        return;
    };
    let (control, stats) = (conn.control.clone(), Arc::clone(stats));
    // The writer task ends only when this sender is dropped too: a page
    // that leaves still gets its recording written.
    tokio::task::spawn_blocking(move || {
        let text = match recording.write() {
            Ok(file) => {
                stats.episodes_saved.fetch_add(1, Ordering::Relaxed);
                episode["file"] = file.display().to_string().into();
                json_message("episode", &episode)
            }
            Err(e) => json_message("error", &serde_json::json!({ "message": format!("{e}") })),
        };
        let _ = control.try_send(Outgoing::Text(text));
    });
}

/// One control tick and, when due, a state for the page; an episode that
/// just ended is saved.
fn tick(conn: &mut Connection, session: &mut TeleopSession, now: Instant) {
    let stats = conn.shared.stats.clone();
    let was_running = session.outcome().is_none();
    let (hard, limits) = session.violations();
    match session.tick(now) {
        Ok(state) => {
            if was_running {
                stats.ticks.fetch_add(1, Ordering::Relaxed);
                stats.tick_us.record(state.tick_us);
            }
        }
        Err(e) => conn.error(&format!("the simulator failed: {e}")),
    }
    let (hard_now, limits_now) = session.violations();
    stats.hard_violations.fetch_add(hard_now.saturating_sub(hard) as u64, Ordering::Relaxed);
    stats.limit_violations.fetch_add(limits_now.saturating_sub(limits) as u64, Ordering::Relaxed);
    let ended = was_running && session.outcome().is_some();
    // The state carries the newest command: its latency is the one measured.
    if let (true, Some(at)) = (was_running, session.used_command_at()) {
        conn.unanswered_command = Some(at);
    }
    conn.publish(session.state(), ended);
    if ended {
        finish_episode(conn, session, &stats);
    }
}

/// What a message asks of the connection beyond its session.
enum Action {
    /// End the episode and start one on (task, seed).
    Reset(Option<TeleopTask>, Option<u64>),
    /// Switch to this mode (a valid name) once the task being prepared is ready.
    QueueMode(String),
}

/// Applies a text message; returns what the connection must do. A message
/// that cannot be applied is counted and explained to the page.
fn handle_text(
    conn: &mut Connection,
    mut session: Option<&mut TeleopSession>,
    preparing: bool,
    text: &str,
) -> Option<Action> {
    match apply(session.as_deref_mut(), preparing, text) {
        Ok(action) => action,
        Err(e) => {
            if let Some(s) = session {
                s.reject();
            }
            conn.error(&e);
            None
        }
    }
}

fn apply(session: Option<&mut TeleopSession>, preparing: bool, text: &str) -> Result<Option<Action>, String> {
    match parse_client_message(text)? {
        ClientMessage::Command { linear } => {
            // While a task is being prepared there is no arm to move: the
            // page shows "preparing" and its commands are dropped.
            if let Some(s) = session {
                s.set_command(linear, Instant::now());
            }
            Ok(None)
        }
        ClientMessage::Mode { mode } => match session {
            Some(s) => s.set_mode(&mode).map(|_| None),
            None if preparing => {
                // Refuse an unknown name now; whether the task offers the
                // mode is known once it is ready.
                mode.parse::<crate::arbitration::ArbitrationMode>().map_err(|e| e.to_string())?;
                Ok(Some(Action::QueueMode(mode)))
            }
            None => Err("no task is ready: send a reset to prepare one".into()),
        },
        ClientMessage::Reset { task, seed } => match task.as_deref().map(TeleopTask::parse) {
            Some(None) => {
                let known = TeleopTask::ALL.map(|t| t.as_str()).join(", ");
                Err(format!("unknown task '{}' (known: {known})", task.unwrap_or_default()))
            }
            Some(Some(t)) => Ok(Some(Action::Reset(Some(t), seed))),
            None => Ok(Some(Action::Reset(None, seed))),
        },
    }
}
