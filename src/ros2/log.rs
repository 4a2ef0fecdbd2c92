//! The node's log, written so that no output can stop the control loop:
//! lines go through a bounded channel to a thread of their own that writes
//! them to stderr (a line that does not fit is dropped and counted, never
//! waited for), each kind of line at most once a second (the others
//! counted and summed up in the next line of the kind), strings from the
//! ROS 2 system cut to [`ECHO_CHARS`] before they are echoed, and a line
//! formatted into a fixed buffer: logging allocates nothing.
//!
//! Under a supervisor that does not read stderr (a pipe fills at 64 KB), a
//! peer sending unknown mode names at 1 kHz brought a loop that wrote
//! every refusal from the tick thread from 100 to 0 ticks a second, and
//! SIGTERM no longer stopped it.

use std::fmt::{self, Write as _};
use std::io::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

/// Longest echo of a string from the ROS 2 system (chars): longer ones are
/// cut, with their length in bytes.
pub const ECHO_CHARS: usize = 64;
/// Longest line (bytes); a longer one is cut at a character boundary.
pub const LINE_BYTES: usize = 256;
/// Lines waiting for the writer at most; beyond them lines are dropped.
pub const QUEUED_LINES: usize = 256;
/// Each kind of line is written at most once per this interval.
pub const RATE_LIMIT: Duration = Duration::from_secs(1);

/// A string from the ROS 2 system as the log shows it: at most
/// [`ECHO_CHARS`] characters, control characters escaped, and when cut its
/// length in bytes.
pub struct Echo<'a>(pub &'a str);

impl fmt::Display for Echo<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (shown, c) in self.0.chars().enumerate() {
            if shown == ECHO_CHARS {
                return write!(f, "… ({} bytes)", self.0.len());
            }
            if c.is_control() {
                for e in c.escape_default() {
                    f.write_char(e)?;
                }
            } else {
                f.write_char(c)?;
            }
        }
        Ok(())
    }
}

/// The kinds of line, each rate-limited on its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    /// The mode changed (topic or parameter).
    Mode,
    /// A mode name was refused.
    ModeRefused,
    /// Goals re-planned for new poses.
    Goals,
    /// Poses refused, or goals from poses unavailable.
    GoalsRefused,
    /// The node holds the arm for a reason of its own (stale or invalid input).
    Hold,
    /// A new point cloud in the scene.
    PointCloud,
    /// A camera message refused.
    PointCloudRefused,
}

impl LogKind {
    const ALL: [LogKind; 7] = [
        LogKind::Mode,
        LogKind::ModeRefused,
        LogKind::Goals,
        LogKind::GoalsRefused,
        LogKind::Hold,
        LogKind::PointCloud,
        LogKind::PointCloudRefused,
    ];

    fn index(self) -> usize {
        self as usize
    }

    fn noun(self) -> &'static str {
        match self {
            LogKind::Mode => "mode change",
            LogKind::ModeRefused => "mode refusal",
            LogKind::Goals => "goal update",
            LogKind::GoalsRefused => "pose refusal",
            LogKind::Hold => "hold",
            LogKind::PointCloud => "point cloud",
            LogKind::PointCloudRefused => "camera message refusal",
        }
    }
}

/// One line in a fixed buffer.
struct Line {
    len: usize,
    text: [u8; LINE_BYTES],
}

impl Line {
    fn new() -> Line {
        Line { len: 0, text: [0; LINE_BYTES] }
    }
}

impl fmt::Write for Line {
    /// Appends what fits, cut at a character boundary; never fails, so a
    /// long line is cut rather than lost.
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = LINE_BYTES - self.len;
        let mut take = s.len().min(room);
        while !s.is_char_boundary(take) {
            take -= 1;
        }
        self.text[self.len..self.len + take].copy_from_slice(&s.as_bytes()[..take]);
        self.len += take;
        Ok(())
    }
}

/// A sender of lines that never waits: shared by the loop and the watchdog.
#[derive(Clone)]
pub struct LogSender {
    tx: SyncSender<Line>,
    dropped: Arc<AtomicU64>,
}

impl LogSender {
    /// Queues `args` as a line (prefixed `tandem ros2: `), or counts it
    /// dropped when the queue is full. Allocates nothing.
    pub fn send(&self, args: fmt::Arguments<'_>) {
        let mut line = Line::new();
        let _ = line.write_str("tandem ros2: ");
        let _ = line.write_fmt(args);
        match self.tx.try_send(line) {
            Ok(()) => {}
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

#[derive(Clone, Copy, Default)]
struct Limit {
    last: Option<Instant>,
    suppressed: u64,
}

/// What the log did over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LogCounts {
    /// Lines dropped because the writer was behind (stderr not read).
    pub dropped: u64,
    /// Lines suppressed by the rate limit (their count written instead).
    pub suppressed: u64,
}

/// The node's log: rate-limited kinds of line to a writer thread.
pub struct NodeLog {
    sender: LogSender,
    limits: [Limit; LogKind::ALL.len()],
    suppressed: u64,
    written: Receiver<()>,
}

impl NodeLog {
    /// A log writing to `sink` from a thread of its own.
    ///
    /// # Errors
    /// The thread cannot be started.
    pub fn spawn(mut sink: Box<dyn Write + Send>) -> std::io::Result<NodeLog> {
        let (tx, rx) = mpsc::sync_channel::<Line>(QUEUED_LINES);
        let (done, written) = mpsc::channel();
        std::thread::Builder::new().name("ros2-log".into()).spawn(move || {
            while let Ok(line) = rx.recv() {
                let mut text = [0u8; LINE_BYTES + 1];
                text[..line.len].copy_from_slice(&line.text[..line.len]);
                text[line.len] = b'\n';
                // A closed stderr loses the line; nothing else to do with it.
                let _ = sink.write_all(&text[..=line.len]);
            }
            let _ = done.send(());
        })?;
        Ok(NodeLog {
            sender: LogSender { tx, dropped: Arc::new(AtomicU64::new(0)) },
            limits: [Limit::default(); LogKind::ALL.len()],
            suppressed: 0,
            written,
        })
    }

    /// A log to the process's stderr, through a duplicate of its file
    /// descriptor: a writer blocked on a full pipe then holds no lock that
    /// the rest of the process (a panic message, say) would wait for.
    ///
    /// # Errors
    /// Duplicating the descriptor, or starting the thread.
    pub fn stderr() -> std::io::Result<NodeLog> {
        use std::os::fd::AsFd;
        let fd = std::io::stderr().as_fd().try_clone_to_owned()?;
        NodeLog::spawn(Box::new(std::fs::File::from(fd)))
    }

    /// A sender for another thread (the watchdog); its lines are not rate-limited.
    pub fn sender(&self) -> LogSender {
        self.sender.clone()
    }

    /// Writes `args` as a line of `kind` at `now`, unless a line of that
    /// kind was written less than [`RATE_LIMIT`] ago (then it is counted,
    /// and the count goes with the next line of the kind). Allocates nothing.
    pub fn log(&mut self, kind: LogKind, now: Instant, args: fmt::Arguments<'_>) {
        let limit = &mut self.limits[kind.index()];
        if limit.last.is_some_and(|t| now.duration_since(t) < RATE_LIMIT) {
            limit.suppressed += 1;
            self.suppressed += 1;
            return;
        }
        let before = limit.suppressed;
        *limit = Limit { last: Some(now), suppressed: 0 };
        if before > 0 {
            self.sender.send(format_args!("{args} ({before} more {}s in the last second)", kind.noun()));
        } else {
            self.sender.send(args);
        }
    }

    /// Writes the count of lines suppressed a [`RATE_LIMIT`] ago and not
    /// yet reported (call once a tick: a burst's last count is not lost).
    pub fn flush(&mut self, now: Instant) {
        for kind in LogKind::ALL {
            let limit = &mut self.limits[kind.index()];
            if limit.suppressed > 0 && limit.last.is_some_and(|t| now.duration_since(t) >= RATE_LIMIT) {
                let n = limit.suppressed;
                *limit = Limit { last: Some(now), suppressed: 0 };
                self.sender.send(format_args!("{n} more {}(s) in the last second, not written", kind.noun()));
            }
        }
    }

    /// Lines dropped so far.
    pub fn dropped(&self) -> u64 {
        self.sender.dropped.load(Ordering::Relaxed)
    }

    /// Stops the log: reports what is still suppressed, waits up to `wait`
    /// for the writer to write what is queued (not longer: stderr may
    /// never be read), and says what was dropped and suppressed.
    pub fn finish(mut self, wait: Duration) -> LogCounts {
        self.flush(Instant::now() + RATE_LIMIT);
        let NodeLog { sender, suppressed, written, .. } = self;
        let dropped = sender.dropped.clone();
        drop(sender);
        // The watchdog's sender may still be alive: a timeout then, as for
        // a writer that cannot write.
        let _ = written.recv_timeout(wait);
        LogCounts { dropped: dropped.load(Ordering::Relaxed), suppressed }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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

    /// Long and hostile strings are cut and escaped; a flood of one kind
    /// gives one line a second and the count of the others; lines beyond
    /// the buffer are cut at a character boundary.
    #[test]
    fn lines_are_bounded_rate_limited_and_counted() {
        let long = "é".repeat(10_000);
        assert_eq!(Echo(&long).to_string(), format!("{}… (20000 bytes)", "é".repeat(ECHO_CHARS)));
        assert_eq!(Echo("a\nb\u{1b}[2J").to_string(), "a\\nb\\u{1b}[2J");
        let sink = Sink::default();
        let mut log = NodeLog::spawn(Box::new(sink.clone())).unwrap();
        let t0 = Instant::now();
        for i in 0..1000 {
            let now = t0 + Duration::from_millis(i);
            log.log(LogKind::ModeRefused, now, format_args!("mode '{}' refused", Echo(&long)));
            log.log(LogKind::Mode, now, format_args!("mode direct"));
            log.flush(now);
        }
        // 1.5 s on: the last second's count comes out by itself.
        log.flush(t0 + Duration::from_millis(2500));
        let counts = log.finish(Duration::from_secs(5));
        assert_eq!(counts, LogCounts { dropped: 0, suppressed: 2 * 999 });
        let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4, "{text}");
        assert!(lines[0].starts_with("tandem ros2: mode 'ééé") && lines[0].len() <= LINE_BYTES, "{}", lines[0]);
        assert_eq!(lines[1], "tandem ros2: mode direct");
        assert!(lines.contains(&"tandem ros2: 999 more mode refusal(s) in the last second, not written"), "{text}");
        assert!(lines.contains(&"tandem ros2: 999 more mode change(s) in the last second, not written"), "{text}");
    }

    /// A sink that never returns: the log neither blocks nor grows; the
    /// lines beyond the queue are counted dropped.
    #[test]
    fn a_writer_that_cannot_write_drops_lines_and_never_blocks() {
        struct Stuck;
        impl Write for Stuck {
            fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
                loop {
                    std::thread::park();
                }
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let log = NodeLog::spawn(Box::new(Stuck)).unwrap();
        let sender = log.sender();
        let began = Instant::now();
        for i in 0..10_000 {
            sender.send(format_args!("line {i}"));
        }
        assert!(began.elapsed() < Duration::from_secs(5));
        // The writer holds one line, the queue QUEUED_LINES.
        assert!(log.dropped() >= 10_000 - QUEUED_LINES as u64 - 1, "{}", log.dropped());
        let counts = log.finish(Duration::from_millis(50));
        assert!(counts.dropped >= 10_000 - QUEUED_LINES as u64 - 1);
    }
}
