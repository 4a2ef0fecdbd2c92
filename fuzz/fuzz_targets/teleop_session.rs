//! A teleoperation session (`tandem::teleop::TeleopSession`, what `tandem
//! serve` runs per browser tab) driven by a message sequence decoded from
//! the bytes.
//!
//! The first byte picks one of [`SLOTS`] sessions, prepared once and kept
//! (preparing a task plans and optimizes: tens of milliseconds, too slow
//! for every input): the planar task at seed 0; the planar task at seed 1
//! and the reach-and-grasp task at seed 0, each reached by a `restart`
//! from the other task after a few driven ticks (so a session that changed
//! robots is what gets fuzzed); and both tasks again with unusual settings
//! (1000 Hz with no command timeout and a 5 ms episode, which times out
//! within an input's ticks; 5 Hz with a tiny speed limit, an hour's
//! timeout and the constrained mode). Each
//! input starts a fresh episode on its slot (`restart` on the same task and
//! seed: instant) in the slot's first mode, then applies ops: page
//! messages as JSON text through `parse_client_message` (raw bytes, or
//! commands, modes and resets written from drawn values), commands with
//! drawn numbers (NaN, ±∞, ±1e308, 1.3e154, subnormals, −0.0, f64::MAX,
//! any bit pattern) received now, in the past or in the future, mode
//! switches by name (every mode, `learned` without an actor, unknown and
//! empty names), ticks at instants advancing by nothing, a period, or up
//! to minutes, runs of ticks (at most [`MAX_TICKS`] per input), `finish`,
//! `restart`, `reject` and `scene`. A reset (`finish`, then `restart`)
//! keeps the slot's task and seed, whatever it asks for.
//!
//! Beyond "no panic", after every op: every number of the `StateView` is
//! finite, except `human` (NaN where the page sent NaN, `null` on the
//! wire) and `clearance`/`min_clearance` (+∞ without obstacles, `null` on
//! the wire); the state serializes to JSON; `human` is within the speed
//! limit; beliefs are probabilities summing to 1; the arm stays within its
//! joint limits, and each tick moves it by at most one period at each
//! joint's velocity limit (its commanded joint velocity within the limits);
//! before the first command nothing moves; the outcome, reason and detail
//! are set together; a mode switch returns the mode (shown as the state's
//! mode at the next tick) or an error that says something (`learned`
//! without an actor and unknown names are errors); `finish` returns no
//! file (no recording folder).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};
use tandem::arbitration::ArbitrationMode;
use tandem::problem::Problem;
use tandem::robot::JointLimits;
use tandem::teleop::{ClientMessage, SessionSettings, StateView, TeleopSession, TeleopTask, parse_client_message};

/// Sessions in the pool (the first input byte, modulo this).
const SLOTS: usize = 5;
/// The most ticks one input runs: a tick costs about 0.1 ms instrumented,
/// and a million executions must fit in minutes.
const MAX_TICKS: usize = 8;

/// A slot: its session, where each input starts it, and its robot's limits.
struct Slot {
    session: TeleopSession,
    home: (TeleopTask, u64),
    mode: &'static str,
    max_speed: f64,
    period: f64,
    /// The joint limits of the task's robot.
    limits: Vec<JointLimits>,
}

fn slot(index: usize) -> Slot {
    let (task, seed, settings) = match index {
        0 => (TeleopTask::Planar, 0, SessionSettings::default()),
        1 => (TeleopTask::Planar, 1, SessionSettings::default()),
        2 => (TeleopTask::ReachGrasp, 0, SessionSettings::default()),
        3 => (
            TeleopTask::Planar,
            0,
            SessionSettings {
                rate_hz: 1000.0,
                max_speed: 2.0,
                command_timeout: 0.0,
                max_episode_time: 0.005,
                mode: ArbitrationMode::DirectControl,
                ..SessionSettings::default()
            },
        ),
        _ => (
            TeleopTask::ReachGrasp,
            0,
            SessionSettings {
                rate_hz: 5.0,
                max_speed: 1e-3,
                command_timeout: 3600.0,
                max_episode_time: 1e6,
                mode: ArbitrationMode::Constrained,
                ..SessionSettings::default()
            },
        ),
    };
    assert!(settings.record_dir.is_none(), "nothing is written");
    let session = match index {
        // Slots 1 and 2 start on the other task, drive it, then restart.
        1 | 2 => {
            let other = if task == TeleopTask::Planar { TeleopTask::ReachGrasp } else { TeleopTask::Planar };
            let mut session = TeleopSession::prepare(&settings, other, 0).expect("a shipped task prepares");
            let now = Instant::now();
            session.set_command([0.05, 0.05, 0.0], now);
            for k in 1..=10 {
                session.tick(now + Duration::from_millis(30 * k)).expect("the simulator's queries");
            }
            session.finish().expect("no recording to write");
            session.restart(task, seed).expect("a shipped task prepares");
            session
        }
        _ => TeleopSession::prepare(&settings, task, seed).expect("a shipped task prepares"),
    };
    let problem = if task == TeleopTask::Planar { "planar_pick" } else { "panda_grasp_box" };
    let limits = Problem::builtin(problem).expect("a shipped problem").robot.limits().to_vec();
    assert_eq!(limits.len(), session.state().q.len(), "the task's robot");
    Slot {
        session,
        home: (task, seed),
        mode: settings.mode.as_str(),
        max_speed: settings.max_speed,
        period: 1.0 / settings.rate_hz,
        limits,
    }
}

/// Slot `index`, prepared on first use.
fn slot_at(index: usize) -> &'static Mutex<Slot> {
    static SLOTS_: OnceLock<Vec<OnceLock<Mutex<Slot>>>> = OnceLock::new();
    let pool = SLOTS_.get_or_init(|| (0..SLOTS).map(|_| OnceLock::new()).collect());
    pool[index].get_or_init(|| Mutex::new(slot(index)))
}

/// Numbers a page (or a broken one) might send.
const SPECIAL: [f64; 24] = [
    0.0,
    -0.0,
    0.05,
    -0.05,
    0.1,
    -0.2,
    0.25,
    1.0,
    -3.0,
    1e308,
    -1e308,
    1.3e154,
    -1.3e154,
    f64::MAX,
    f64::MIN_POSITIVE,
    5e-324,
    -5e-324,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e-3,
    0.01,
    1e-300,
    -1e-10,
];

/// Mode names to switch to: every mode, and names none has.
const MODES: [&str; 13] = [
    "direct",
    "blend-timid",
    "blend-aggressive",
    "avoid",
    "natural-gradient",
    "natural-gradient-joint",
    "constrained",
    "sos",
    "learned",
    "",
    "SOS",
    "sum-of-squares",
    "direct ",
];

/// The input, read front to back; zeros once it runs out.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn byte(&mut self) -> u8 {
        let Some((&b, rest)) = self.0.split_first() else { return 0 };
        self.0 = rest;
        b
    }

    /// A number: one of [`SPECIAL`], or (odd tag, eight bytes left) any f64.
    fn number(&mut self) -> f64 {
        let tag = self.byte();
        if tag & 1 == 1 && self.0.len() >= 8 {
            let (raw, rest) = self.0.split_at(8);
            self.0 = rest;
            return f64::from_le_bytes(raw.try_into().expect("eight bytes"));
        }
        SPECIAL[usize::from(tag >> 1) % SPECIAL.len()]
    }

    /// Up to 255 bytes, as text (invalid UTF-8 replaced).
    fn text(&mut self) -> String {
        let n = usize::from(self.byte()).min(self.0.len());
        let (raw, rest) = self.0.split_at(n);
        self.0 = rest;
        String::from_utf8_lossy(raw).into_owned()
    }

    /// A duration: nothing, a fraction of a second, or up to minutes.
    fn duration(&mut self, period: f64) -> Duration {
        let b = self.byte();
        Duration::from_secs_f64(match b >> 6 {
            0 => 0.0,
            1 => period,
            2 => period * f64::from(b & 63) / 8.0,
            _ => f64::from(b & 63).powi(2),
        })
    }
}

/// A number as JSON text: `null` for NaN, out of range for infinities.
fn json_number(v: f64) -> String {
    if v.is_nan() {
        "null".into()
    } else if v.is_infinite() {
        if v > 0.0 { "1e400".into() } else { "-1e400".into() }
    } else {
        format!("{v:?}")
    }
}

/// One input's run on a slot.
struct Run<'a> {
    slot: &'a mut Slot,
    now: Instant,
    ticks: usize,
    /// The mode the next tick runs in.
    mode: &'static str,
}

impl Run<'_> {
    fn limits(&self) -> &[JointLimits] {
        &self.slot.limits
    }

    fn command(&mut self, linear: [f64; 3], at: Instant) {
        self.slot.session.set_command(linear, at);
    }

    fn set_mode(&mut self, name: &str) {
        match self.slot.session.set_mode(name) {
            Ok(mode) => {
                assert_eq!(mode.as_str(), name, "switched to another mode");
                assert!(name != "learned", "learned switched on without an actor");
                self.mode = mode.as_str();
            }
            Err(e) => assert!(!e.trim().is_empty(), "mode '{name}': an empty error"),
        }
    }

    /// Finishes the episode and starts the next, on the slot's task and
    /// seed (preparing another would plan and optimize).
    fn reset(&mut self) {
        self.finish();
        let (task, seed) = self.slot.home;
        self.slot.session.restart(task, seed).expect("a prepared task restarts");
        assert_eq!((self.slot.session.task(), self.slot.session.seed()), (task, seed));
        self.check_fresh();
    }

    fn finish(&mut self) {
        let driven = self.slot.session.driven();
        let file = self.slot.session.finish().expect("no recording to write");
        assert!(file.is_none(), "finish wrote {file:?} without a recording folder");
        if driven {
            assert!(self.slot.session.outcome().is_some(), "a finished episode has an outcome");
        }
        self.check(None);
    }

    /// After a restart: the start, waiting, no outcome.
    fn check_fresh(&self) {
        let s = self.slot.session.state();
        assert_eq!((s.status, s.steps, s.time), ("waiting", 0, 0.0), "a fresh episode");
        assert!(s.outcome.is_none() && self.slot.session.outcome().is_none() && !self.slot.session.driven());
        self.check(None);
    }

    fn tick(&mut self, advance: Duration) {
        if self.ticks >= MAX_TICKS {
            return;
        }
        self.ticks += 1;
        self.now += advance;
        let before: Vec<f64> = self.slot.session.state().q.clone();
        let steps = self.slot.session.state().steps;
        let (driven, ended) = (self.slot.session.driven(), self.slot.session.outcome().is_some());
        let state = self.slot.session.tick(self.now).expect("the simulator's queries");
        if driven && !ended {
            assert_eq!(state.steps, steps + 1, "a running episode ticks");
            assert_eq!(state.mode, self.mode, "the tick's mode");
        } else {
            assert_eq!(state.steps, steps, "a waiting or ended episode does not tick");
            assert_eq!(state.q, before, "a waiting or ended episode does not move");
        }
        self.check(Some(&before));
    }

    /// The state's invariants; `before` is the configuration before a tick.
    fn check(&self, before: Option<&[f64]>) {
        let session = &self.slot.session;
        let s: &StateView = session.state();
        let finite = |what: &str, v: &[f64]| assert!(v.iter().all(|x| x.is_finite()), "{what} {v:?} in {s:?}");
        finite("time", &[s.time, s.tick_us, s.latency_us]);
        finite("q", &s.q);
        for link in &s.links {
            finite("link", link);
        }
        finite("gripper", &s.gripper);
        finite("gripper pose", &s.gripper_pose);
        finite("executed", &s.executed);
        finite("beliefs", &s.beliefs);
        for axis in &s.ellipsoid {
            finite("ellipsoid", axis);
        }
        // NaN commands are kept (the arbiter holds on them); ∞ clearance means no obstacle.
        let human: f64 = s.human.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(human.is_nan() || human <= self.slot.max_speed * (1.0 + 1e-9), "human {:?} over the limit", s.human);
        for c in [s.clearance, s.min_clearance] {
            assert!(!c.is_nan() && c != f64::NEG_INFINITY, "clearance {c} in {s:?}");
        }
        assert!(s.time >= 0.0 && s.tick_us >= 0.0, "{s:?}");
        if !s.beliefs.is_empty() {
            let sum: f64 = s.beliefs.iter().sum();
            assert!(s.beliefs.iter().all(|b| (0.0..=1.0).contains(b)) && (sum - 1.0).abs() < 1e-6, "beliefs {s:?}");
        }
        let limits = self.limits();
        assert_eq!(s.q.len(), limits.len(), "q of the task's robot");
        for (x, l) in s.q.iter().zip(limits) {
            assert!(*x >= l.lower - 1e-9 && *x <= l.upper + 1e-9, "q {:?} leaves the limits", s.q);
        }
        if let Some(before) = before {
            for ((x, b), l) in s.q.iter().zip(before).zip(limits) {
                let step = (x - b).abs();
                assert!(step <= self.slot.period * l.velocity * (1.0 + 1e-9) + 1e-12, "q {before:?} -> {:?}", s.q);
            }
        }
        assert!(!s.status.is_empty() && !s.mode.is_empty(), "{s:?}");
        let ended = [s.outcome.is_some(), s.reason.is_some(), s.reason_detail.is_some(), session.outcome().is_some()];
        assert!(ended.iter().all(|e| *e == ended[0]), "outcome, reason and detail together: {s:?}");
        assert_eq!(session.outcome().map(|o| o.as_str()), s.outcome);
        // What the server sends.
        let _json = serde_json::to_string(s).expect("the state serializes");
    }

    /// A message from the page, as the server applies it.
    fn message(&mut self, text: &str) {
        match parse_client_message(text) {
            Ok(ClientMessage::Command { linear }) => self.command(linear, self.now),
            Ok(ClientMessage::Mode { mode }) => self.set_mode(&mode),
            Ok(ClientMessage::Reset { task, .. }) => match task.as_deref().map(TeleopTask::parse) {
                Some(None) => self.slot.session.reject(),
                Some(Some(_)) | None => self.reset(),
            },
            Err(e) => {
                assert!(e.starts_with("malformed message"), "{text}: {e}");
                self.slot.session.reject();
            }
        }
        self.check(None);
    }
}

fuzz_target!(|data: &[u8]| {
    let mut bytes = Bytes(data);
    let index = usize::from(bytes.byte()) % SLOTS;
    let mut guard = slot_at(index).lock().unwrap_or_else(|e| e.into_inner());
    let slot = &mut *guard;
    // A fresh episode in the slot's first mode: each input runs alike.
    let (task, seed) = slot.home;
    slot.session.set_mode(slot.mode).expect("the slot's own mode");
    slot.session.restart(task, seed).expect("a prepared task restarts");
    let period = slot.period;
    static BASE: OnceLock<Instant> = OnceLock::new();
    let base = *BASE.get_or_init(Instant::now);
    let mut run = Run { now: base + Duration::from_secs(3600), slot, ticks: 0, mode: "" };
    run.mode = run.slot.mode;
    run.check_fresh();
    while !bytes.0.is_empty() {
        match bytes.byte() % 12 {
            0 => {
                let text = bytes.text();
                run.message(&text);
            }
            1 => {
                let v = [bytes.number(), bytes.number(), bytes.number()].map(json_number);
                run.message(&format!(r#"{{"type":"command","linear":[{},{},{}]}}"#, v[0], v[1], v[2]));
            }
            2 => {
                let mode = MODES[usize::from(bytes.byte()) % MODES.len()];
                run.message(&format!(r#"{{"type":"mode","mode":"{mode}"}}"#));
            }
            3 => {
                let b = bytes.byte();
                let task = ["\"planar\"", "\"reach-grasp\"", "\"fly\"", "null"][usize::from(b & 3)];
                let seed = if b & 4 == 4 { format!(r#","seed":{}"#, b >> 3) } else { String::new() };
                run.message(&format!(r#"{{"type":"reset","task":{task}{seed}}}"#));
            }
            4 | 5 => {
                // A command received now, in the past or in the future.
                let linear = [bytes.number(), bytes.number(), bytes.number()];
                let shift = bytes.duration(period);
                let at = match bytes.byte() % 3 {
                    0 => run.now,
                    1 => run.now.checked_sub(shift).unwrap_or(run.now),
                    _ => run.now + shift,
                };
                run.command(linear, at);
                run.check(None);
            }
            6 => {
                let mode = MODES[usize::from(bytes.byte()) % MODES.len()];
                run.set_mode(mode);
            }
            7 | 8 => {
                let advance = bytes.duration(period);
                run.tick(advance);
            }
            9 => {
                for _ in 0..1 + bytes.byte() % 8 {
                    run.tick(Duration::from_secs_f64(period));
                }
            }
            10 => match bytes.byte() % 4 {
                0 => run.finish(),
                1 => run.reset(),
                2 => {
                    run.slot.session.reject();
                    run.check(None);
                }
                _ => {
                    let scene = run.slot.session.scene();
                    let _json = serde_json::to_string(&scene).expect("the scene serializes");
                }
            },
            _ => {
                let linear = [bytes.number(), bytes.number(), bytes.number()];
                run.command(linear, run.now);
                run.tick(Duration::ZERO);
            }
        }
    }
});
