//! What the node's loop does each tick besides reading and writing DDS:
//! a `~/mode` name applied (one a tick), the tick's duration counted in
//! fixed memory, the node's own holds on invalid input logged when they
//! start or change, the rate-limited log flushed, the watchdog's heartbeat.
//! None of it blocks or allocates after warm-up: the node's loop without
//! the middleware, testable on its own (tests/ros2_node.rs runs it a
//! million times under a counting allocator).

use super::control::{ControlLoop, ControlOutput};
use super::log::{Echo, LogCounts, LogKind, NodeLog};
use super::watchdog::{Heartbeat, Stalls, Watchdog};
use crate::arbitration::{ArbitrationMode, TickStatus};
use crate::control::timing::TickHistogram;
use std::time::{Duration, Instant};

/// How long [`Ticker::finish`] waits for the log's last lines to be
/// written: stderr may never be read, and the node must still exit.
const LOG_DRAIN: Duration = Duration::from_millis(200);

/// The loop's bookkeeping (see the module's documentation).
pub struct Ticker {
    log: NodeLog,
    tick_us: TickHistogram,
    watchdog: Watchdog,
    heartbeat: Heartbeat,
    /// The invalid-input hold logged last (its reason and joint).
    hold: Option<(&'static str, Option<usize>)>,
}

/// What the bookkeeping saw over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TickerReport {
    /// The ticks' own time (µs): median, 99th percentile (both within
    /// [`QUANTILE_ERROR`](crate::control::timing::QUANTILE_ERROR)), largest.
    pub tick_us: [f64; 3],
    /// Log lines dropped and suppressed.
    pub log: LogCounts,
    /// Stalls the watchdog reported.
    pub stalls: Stalls,
}

impl Ticker {
    /// Bookkeeping for a loop of `period` whose first deadline is `first`, logging to `log`.
    ///
    /// # Errors
    /// The watchdog's thread cannot be started.
    pub fn new(log: NodeLog, period: Duration, first: Instant) -> std::io::Result<Ticker> {
        let (watchdog, heartbeat) = Watchdog::spawn(period, first, log.sender())?;
        Ok(Ticker { log, tick_us: TickHistogram::new(), watchdog, heartbeat, hold: None })
    }

    /// Writes a line of `kind` (rate-limited, see [`NodeLog::log`]).
    pub fn log(&mut self, kind: LogKind, now: Instant, args: std::fmt::Arguments<'_>) {
        self.log.log(kind, now, args);
    }

    /// A mode name from the mode topic, received at `now` (the loop reads
    /// one a tick): applied when the loop runs that mode, else refused,
    /// the name echoed bounded. Returns the mode switched to.
    pub fn mode_name(&mut self, control: &mut ControlLoop, name: &str, now: Instant) -> Option<ArbitrationMode> {
        match control.parse_mode(name).and_then(|mode| control.switch_mode(mode).map(|()| mode)) {
            Ok(mode) => {
                self.log.log(LogKind::Mode, now, format_args!("mode {mode}"));
                Some(mode)
            }
            Err(e) => {
                self.log.log(LogKind::ModeRefused, now, format_args!("mode '{}' refused: {e}", Echo(name)));
                None
            }
        }
    }

    /// After a tick at `now` whose output is `out` (the arm's joints
    /// `joints`), the next deadline on the loop's grid `next`.
    pub fn ticked(&mut self, out: &ControlOutput, joints: &[String], next: Instant, now: Instant) {
        self.tick_us.record(out.diagnostics[0]);
        let invalid = matches!(out.status, Some(TickStatus::InvalidCommand | TickStatus::InvalidState))
            && out.hold_reason.is_some();
        let hold = if invalid { out.hold_reason.map(|r| (r, out.hold_joint)) } else { None };
        if hold != self.hold {
            if let Some((reason, joint)) = hold {
                match joint.and_then(|j| joints.get(j)) {
                    Some(name) => self.log.log(LogKind::Hold, now, format_args!("holding: {reason} ({name})")),
                    None => self.log.log(LogKind::Hold, now, format_args!("holding: {reason}")),
                }
            }
            self.hold = hold;
        }
        self.log.flush(now);
        self.heartbeat.beat(next);
    }

    /// Ticks counted so far.
    pub fn ticks(&self) -> u64 {
        self.tick_us.count()
    }

    /// Stops the watchdog and the log (waiting a little for its last lines).
    pub fn finish(self) -> TickerReport {
        let stalls = self.watchdog.finish();
        let log = self.log.finish(LOG_DRAIN);
        TickerReport { tick_us: self.tick_us.summary(), log, stalls }
    }
}
