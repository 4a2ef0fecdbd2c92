//! One person's simulator: a task, its arbiter, the arm stepped one tick
//! at a time, the latest command, and the recording of each episode.

use super::TeleopError;
use super::scene_view::{LinkView, SceneParts, SceneView, StateView, link_poses, pose7, robot_links, tick_ellipsoid};
use crate::arbitration::{
    Arbiter, ArbiterSettings, ArbiterWorkspace, ArbitrationMode, ArbitrationPolicy, GoalObjects, GoalSettings,
    HumanCommand, ProblemGoal, limit_speed, problem_goals,
};
use crate::problem::Problem;
use crate::robot::{FrameId, KinematicsWorkspace};
use crate::sim::{Arm, Judge, LiveEpisode, Outcome, Reason, TaskJudge, sample_planar_task, sample_task};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// The tasks a person can drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TeleopTask {
    /// The Panda's reach-and-grasp of a box (§5.5.1 of the dissertation), the
    /// box placed by the seed as in `tandem experiment reach-grasp` (or the
    /// problem given to `tandem serve`).
    ReachGrasp,
    /// The planar gripper reaching one of two cylinders past a pole (§6.5 of
    /// the dissertation), placed by the seed as in
    /// `tandem experiment planar`.
    Planar,
}

impl TeleopTask {
    /// Every task.
    pub const ALL: [TeleopTask; 2] = [TeleopTask::ReachGrasp, TeleopTask::Planar];

    /// `reach-grasp` or `planar`.
    pub fn as_str(&self) -> &'static str {
        match self {
            TeleopTask::ReachGrasp => "reach-grasp",
            TeleopTask::Planar => "planar",
        }
    }

    /// The task named `name`.
    pub fn parse(name: &str) -> Option<TeleopTask> {
        TeleopTask::ALL.into_iter().find(|t| t.as_str() == name)
    }
}

/// How sessions run.
#[derive(Clone)]
pub struct SessionSettings {
    /// Control rate (Hz; default 30, the dissertation's joystick rate; at most 1000).
    pub rate_hz: f64,
    /// Largest commanded gripper speed (m/s; default 0.25): longer commands
    /// are scaled down to it.
    pub max_speed: f64,
    /// Commands older than this hold the arm (s; default 0.5): a page that
    /// stalls or disconnects never leaves the arm moving.
    pub command_timeout: f64,
    /// An episode times out after this long (s of simulated time; default 120).
    pub max_episode_time: f64,
    /// The mode sessions start in (default sum-of-squares).
    pub mode: ArbitrationMode,
    /// The reach-and-grasp problem (default: the built-in `panda_grasp_box`
    /// with the box placed by the seed).
    pub problem: Option<Arc<Problem>>,
    /// Where each driven episode is saved (Parquet); `None` keeps nothing.
    pub record_dir: Option<PathBuf>,
    /// The learned arbitration actor (offered as mode `learned` on tasks
    /// with as many goals as it was trained for).
    pub actor: Option<Arc<dyn ArbitrationPolicy>>,
}

impl Default for SessionSettings {
    fn default() -> Self {
        SessionSettings {
            rate_hz: 30.0,
            max_speed: 0.25,
            command_timeout: 0.5,
            max_episode_time: 120.0,
            mode: ArbitrationMode::SumOfSquares,
            problem: None,
            record_dir: None,
            actor: None,
        }
    }
}

/// A prepared task: its problem, goals and arbiter (built once per task
/// and seed; episodes restart on it cheaply).
struct Prepared {
    task: TeleopTask,
    seed: u64,
    problem: Problem,
    goals: Vec<ProblemGoal>,
    arbiter: Arbiter,
    modes: Vec<ArbitrationMode>,
    links: Vec<LinkView>,
    frames: Vec<FrameId>,
    /// Why the learned mode is not offered, when an actor was given.
    learned_unavailable: Option<String>,
}

/// One person's simulator.
pub struct TeleopSession {
    settings: SessionSettings,
    prepared: Prepared,
    ws: ArbiterWorkspace,
    live: LiveEpisode,
    judges: Vec<TaskJudge>,
    kin: KinematicsWorkspace,
    command: [f64; 3],
    command_at: Option<Instant>,
    used_command_at: Option<Instant>,
    new_command: bool,
    /// Whether the operator has asked for motion in this episode: the
    /// episode (its clock, its ticks, its recording) starts then, not when
    /// the page opened.
    driven: bool,
    /// The collision pair named in [`StateView::nearest`].
    nearest: Option<usize>,
    outcome: Option<Outcome>,
    /// Why the episode ended, once it has.
    reason: Option<Reason>,
    saved: bool,
    episode: usize,
    state: StateView,
}

fn prepare(settings: &SessionSettings, task: TeleopTask, seed: u64) -> Result<Prepared, TeleopError> {
    let wrap = |source| TeleopError::Prepare { task: task.as_str(), source: Box::new(source) };
    let (problem, goals) = match task {
        TeleopTask::ReachGrasp => match &settings.problem {
            Some(problem) => {
                let options =
                    GoalSettings { seed: Some(seed), objects: GoalObjects::AllGraspable, ..Default::default() };
                ((**problem).clone(), problem_goals(problem, &options).map_err(wrap)?)
            }
            None => {
                let base = Problem::builtin("panda_grasp_box").map_err(|e| wrap(e.into()))?;
                let sampled = sample_task(&base, Arm::Right, seed, 0).map_err(wrap)?;
                (sampled.goal.problem.clone(), vec![sampled.goal])
            }
        },
        TeleopTask::Planar => {
            let base = Problem::builtin("planar_pick").map_err(|e| wrap(e.into()))?;
            let sampled = sample_planar_task(&base, seed, 0).map_err(wrap)?;
            (sampled.reach[0].problem.clone(), sampled.reach)
        }
    };
    let period = 1.0 / settings.rate_hz;
    let arbiter_settings = ArbiterSettings { mode: settings.mode, period, ..ArbiterSettings::default() };
    // Built in a mode that needs no actor, the actor attached, then the
    // requested mode: `--mode learned` with `--arbiter` failed here before
    // the actor was loaded.
    let plain = ArbiterSettings { mode: ArbiterSettings::default().mode, ..arbiter_settings };
    let mut arbiter = Arbiter::for_problem(&problem, &goals, plain).map_err(wrap)?;
    let mut modes = ArbitrationMode::ALL.to_vec();
    let mut learned_unavailable = None;
    if let Some(actor) = &settings.actor {
        match arbiter.with_arbitration_policy(actor.clone()) {
            Ok(learned) => {
                arbiter = learned;
                modes.push(ArbitrationMode::Learned);
            }
            // Starting in the learned mode: say why the actor does not fit.
            Err(e) if settings.mode == ArbitrationMode::Learned => return Err(wrap(e)),
            // Else the page offers every other mode, and says why not this one.
            Err(e) => learned_unavailable = Some(e.to_string()),
        }
    }
    let arbiter = arbiter.with_settings(arbiter_settings).map_err(wrap)?;
    let (links, frames) = robot_links(&problem);
    Ok(Prepared { task, seed, problem, goals, arbiter, modes, links, frames, learned_unavailable })
}

impl TeleopSession {
    /// Prepares `task` with `seed` (plans and optimizes its references:
    /// milliseconds to a second) and starts an episode at its start.
    ///
    /// # Errors
    /// The task's problem, references or arbiter failing.
    pub fn prepare(settings: &SessionSettings, task: TeleopTask, seed: u64) -> Result<TeleopSession, TeleopError> {
        let prepared = prepare(settings, task, seed)?;
        let mut ws = prepared.arbiter.workspace();
        let live = LiveEpisode::new(&prepared.arbiter, &mut ws, &prepared.problem.start, true)?;
        let judges = prepared.goals.iter().map(TaskJudge::new).collect();
        let kin = KinematicsWorkspace::new(&prepared.problem.robot);
        let mut session = TeleopSession {
            settings: settings.clone(),
            prepared,
            ws,
            live,
            judges,
            kin,
            command: [0.0; 3],
            command_at: None,
            used_command_at: None,
            new_command: false,
            driven: false,
            nearest: None,
            outcome: None,
            reason: None,
            saved: false,
            episode: 0,
            state: StateView { status: "waiting", ..StateView::default() },
        };
        session.refresh_state(0.0)?;
        Ok(session)
    }

    /// The task.
    pub fn task(&self) -> TeleopTask {
        self.prepared.task
    }

    /// The task's seed.
    pub fn seed(&self) -> u64 {
        self.prepared.seed
    }

    /// The scene to draw.
    pub fn scene(&self) -> SceneView {
        let p = &self.prepared;
        SceneView::new(SceneParts {
            task: p.task.as_str(),
            seed: p.seed,
            problem: &p.problem,
            goals: &p.goals,
            arbiter: &p.arbiter,
            modes: &p.modes,
            mode: self.ws.mode(),
            links: p.links.clone(),
        })
    }

    /// The latest state (after the last tick).
    pub fn state(&self) -> &StateView {
        &self.state
    }

    /// How the episode ended, if it has.
    pub fn outcome(&self) -> Option<Outcome> {
        self.outcome
    }

    /// Why the episode ended, if it has.
    pub fn reason(&self) -> Option<&Reason> {
        self.reason.as_ref()
    }

    /// Sets the operator's command (m/s, world axes), received at `at`.
    /// Commands faster than the speed limit are scaled down to it; NaN is
    /// kept, so that the arbiter reports it and holds. The first command
    /// that is not zero (NaN included) starts the episode.
    pub fn set_command(&mut self, linear: [f64; 3], at: Instant) {
        // The page sends zeros while no key is held: those start nothing.
        self.driven |= linear.iter().any(|v| *v != 0.0);
        self.command = limit_speed(linear, self.settings.max_speed);
        self.command_at = Some(at);
        self.new_command = true;
        self.state.commands += 1;
    }

    /// Counts a rejected message.
    pub fn reject(&mut self) {
        self.state.rejected += 1;
    }

    /// Switches the arbitration mode from the next tick on.
    ///
    /// # Errors
    /// A name no mode has, or a mode this task cannot run (`learned`
    /// without a matching actor).
    pub fn set_mode(&mut self, name: &str) -> Result<ArbitrationMode, String> {
        let mode: ArbitrationMode = name.parse().map_err(|e| format!("{e}"))?;
        if !self.prepared.modes.contains(&mode) {
            let task = self.prepared.task.as_str();
            return Err(match &self.prepared.learned_unavailable {
                Some(why) => format!("mode '{name}' is not available on the {task} task: {why}"),
                None => format!(
                    "mode '{name}' is not available on the {task} task (it needs `tandem serve --arbiter FILE` with an actor trained for its {} goals)",
                    self.prepared.goals.len()
                ),
            });
        }
        self.ws.set_mode(mode);
        // The state says the new mode at once, also while waiting (no tick
        // runs before the first command to refresh it).
        self.state.mode = mode.as_str();
        Ok(mode)
    }

    /// Whether the episode has started: the operator sent a command that
    /// is not zero since the last start. Only such episodes are saved.
    pub fn driven(&self) -> bool {
        self.driven
    }

    /// One control tick at wall-clock time `now`: the arbiter blends the
    /// latest command (zero when older than the command timeout), the arm
    /// moves, and the episode ends on success, collision or timeout. After
    /// the end the arm holds until [`Self::restart`]; before the first
    /// command it holds too, its status `waiting`, and no tick counts.
    ///
    /// # Errors
    /// The simulator's kinematics or collision queries failing.
    pub fn tick(&mut self, now: Instant) -> Result<&StateView, TeleopError> {
        if self.outcome.is_some() {
            return Ok(&self.state);
        }
        let fresh =
            self.command_at.is_some_and(|t| now.duration_since(t).as_secs_f64() <= self.settings.command_timeout);
        if !self.driven {
            self.used_command_at = None;
            self.new_command = false;
            self.state.status = "waiting";
            self.state.stale_command = false;
            self.state.human = [0.0; 3];
            return Ok(&self.state);
        }
        let command = if fresh { self.command } else { [0.0; 3] };
        self.used_command_at = if fresh && self.new_command { self.command_at } else { None };
        self.new_command = false;
        let arbiter = &self.prepared.arbiter;
        let step = self.live.step(arbiter, &mut self.ws, HumanCommand::Linear(&command))?;
        let q = self.live.q();
        let done = self.judges.iter_mut().any(|j| j.succeeded(q));
        let time = self.live.record().steps as f64 * arbiter.settings().period;
        let outcome = if step.collided {
            Some(Outcome::Collision)
        } else if done {
            Some(Outcome::Success)
        } else if time >= self.settings.max_episode_time {
            Some(Outcome::Timeout)
        } else {
            None
        };
        if let Some(outcome) = outcome {
            self.end(outcome);
        }
        self.state.human = command;
        self.state.status = step.status.as_str();
        self.state.tick_us = step.tick_us;
        self.state.stale_command = !fresh;
        self.refresh_state(time)?;
        Ok(&self.state)
    }

    /// The episode's executed steps so far that broke a hard limit
    /// (position, velocity, collision) and those that broke an
    /// acceleration, deceleration or jerk limit (see
    /// [`EpisodeRecord`](crate::sim::EpisodeRecord)).
    pub fn violations(&self) -> (usize, usize) {
        let record = self.live.record();
        (record.hard_violations, record.limit_violations)
    }

    /// When the command the last tick used was received, if that tick was
    /// the first to use it (the start of the command → state latency).
    pub fn used_command_at(&self) -> Option<Instant> {
        self.used_command_at
    }

    /// Ends the episode in `outcome` and says why: success, the colliding
    /// pair, or, on a timeout, how far the gripper is from the goal the
    /// beliefs favour (a person's goal is theirs to know); an episode the
    /// person stopped (`Failed`) gets that goal's judge's diagnosis (how far
    /// short, or which grasp criterion fails at the object).
    fn end(&mut self, outcome: Outcome) {
        let beliefs = self.ws.beliefs();
        let likely = (0..beliefs.len()).max_by(|&a, &b| beliefs[a].total_cmp(&beliefs[b])).unwrap_or(0);
        let gripper = self.live.gripper();
        let target = self.prepared.goals.get(likely).map_or(gripper, |g| g.position);
        let reason = match (outcome, self.judges.get_mut(likely)) {
            (Outcome::Failed, Some(judge)) => judge.diagnose(self.live.q(), gripper, target),
            (other, _) => self.live.reason(other, target),
        };
        self.outcome = Some(outcome);
        self.state.outcome = Some(outcome.as_str());
        self.state.reason = Some(reason.as_str());
        self.state.reason_detail = Some(reason.to_string());
        self.reason = Some(reason);
    }

    fn refresh_state(&mut self, time: f64) -> Result<(), TeleopError> {
        let robot = &self.prepared.problem.robot;
        robot.forward_kinematics(&mut self.kin, self.live.q())?;
        let s = &mut self.state;
        link_poses(robot, &self.kin, &self.prepared.frames, &mut s.links);
        s.time = time;
        s.steps = self.live.record().steps;
        s.q.clear();
        s.q.extend_from_slice(self.live.q());
        s.gripper = self.live.gripper();
        s.gripper_pose = pose7(&robot.frame_pose(&self.kin, self.prepared.arbiter.gripper_frame()));
        s.executed = self.live.record().executed.last().copied().unwrap_or([0.0; 3]);
        s.beliefs.clear();
        s.beliefs.extend_from_slice(self.ws.beliefs());
        if s.status.is_empty() {
            s.status = "nominal";
        }
        s.mode = self.ws.mode().as_str();
        s.clearance = self.live.clearance();
        // Names change only when the pair does: no strings per tick.
        let nearest = self.live.nearest_pair();
        if nearest != self.nearest {
            self.nearest = nearest;
            s.nearest = nearest.map(|pair| {
                let (a, b) = self.prepared.arbiter.collision_model().pair_names(pair);
                [a.to_string(), b.to_string()]
            });
        }
        s.min_clearance = self.live.record().min_clearance;
        s.ellipsoid = if s.steps > 0 { tick_ellipsoid(&self.ws, self.ws.mode()) } else { [[0.0; 3]; 3] };
        s.outcome = self.outcome.map(|o| o.as_str());
        Ok(())
    }

    /// Ends the episode (as `failed` when it was still running: the person
    /// stopped it, its [`reason`](Self::reason) the judge's diagnosis) and saves it to the record directory when it has ticks,
    /// once. Returns the file written. An episode never [`driven`](Self::driven)
    /// has not started: nothing ends and nothing is saved.
    ///
    /// # Errors
    /// Writing the recording.
    pub fn finish(&mut self) -> Result<Option<PathBuf>, TeleopError> {
        self.finish_unwritten().map(Recording::write).transpose()
    }

    /// As [`Self::finish`], but the recording is returned to be written
    /// elsewhere (the server writes it on a blocking thread, so that a
    /// session's tick never waits for the disk): `None` when there is
    /// nothing to save. Allocates a copy of the episode; no I/O.
    pub fn finish_unwritten(&mut self) -> Option<Recording> {
        if !self.driven {
            return None;
        }
        if self.outcome.is_none() {
            self.end(Outcome::Failed);
        }
        let (Some(dir), true, false) = (&self.settings.record_dir, self.live.record().steps > 0, self.saved) else {
            return None;
        };
        self.saved = true;
        let p = &self.prepared;
        let mode = self.ws.mode();
        let mut record = self.live.record().clone();
        if let Some(reason) = &self.reason {
            record.outcome = reason.outcome();
            record.reason = reason.clone();
        }
        Some(Recording {
            dir: dir.clone(),
            path: recording_path(dir, p.task.as_str(), self.episode),
            label: format!("teleop/{}/{}/{}", p.task.as_str(), mode.as_str(), p.seed),
            record,
            period: p.arbiter.settings().period,
        })
    }

    /// Starts a new episode: on the same prepared task when `task` and
    /// `seed` are unchanged (instant), else after preparing the new one.
    /// Call [`Self::finish`] first to keep the old episode.
    ///
    /// # Errors
    /// Preparing the new task.
    pub fn restart(&mut self, task: TeleopTask, seed: u64) -> Result<(), TeleopError> {
        let mode = self.ws.mode();
        if task != self.prepared.task || seed != self.prepared.seed {
            self.prepared = prepare(&self.settings, task, seed)?;
            self.ws = self.prepared.arbiter.workspace();
            self.judges = self.prepared.goals.iter().map(TaskJudge::new).collect();
            self.kin = KinematicsWorkspace::new(&self.prepared.problem.robot);
        }
        // Pair indices belong to the old collision model.
        self.nearest = None;
        self.state.nearest = None;
        if self.prepared.modes.contains(&mode) {
            self.ws.set_mode(mode);
        }
        self.live = LiveEpisode::new(&self.prepared.arbiter, &mut self.ws, &self.prepared.problem.start, true)?;
        self.outcome = None;
        self.reason = None;
        self.state.reason = None;
        self.state.reason_detail = None;
        self.saved = false;
        self.driven = false;
        self.command = [0.0; 3];
        self.command_at = None;
        self.episode += 1;
        self.state.status = "waiting";
        self.refresh_state(0.0)
    }
}

/// An ended episode not yet written ([`TeleopSession::finish_unwritten`]).
pub struct Recording {
    dir: PathBuf,
    path: PathBuf,
    label: String,
    record: crate::sim::EpisodeRecord,
    /// The control period (s).
    period: f64,
}

impl Recording {
    /// The file it goes to.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// Writes it (Parquet, the simulator's episode layout), creating the
    /// folder; returns the file.
    ///
    /// # Errors
    /// Creating the folder or writing the file.
    pub fn write(self) -> Result<PathBuf, TeleopError> {
        let dir = &self.dir;
        std::fs::create_dir_all(dir).map_err(|source| crate::files::FileError::Io { path: dir.clone(), source })?;
        crate::sim::write_episodes(&self.path, &[(self.label, &self.record, self.period)])?;
        Ok(self.path)
    }
}

/// Recordings saved by this process so far: part of every recording's name.
static RECORDINGS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// A recording's file in `dir`, unique even when many sessions end in the
/// same millisecond (the millisecond and episode alone let sessions that
/// ended together overwrite each other: 60 sessions closed at once left 37
/// files): `teleop-TASK-MILLIS-PID-SEQ-eEPISODE.parquet`, the process id
/// telling apart servers that share the folder.
fn recording_path(dir: &std::path::Path, task: &str, episode: usize) -> PathBuf {
    let stamp = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_millis());
    let seq = RECORDINGS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    dir.join(format!("teleop-{task}-{stamp}-{}-{seq:06}-e{episode}.parquet", std::process::id()))
}

#[cfg(test)]
mod speed_limit {
    use crate::arbitration::limit_speed;

    /// Huge commands (whose squared norm overflows) keep their direction at
    /// the speed limit instead of turning into zero.
    #[test]
    fn commands_of_any_finite_size_are_scaled_to_the_limit() {
        for (command, expected) in [
            ([1e308, 0.0, 0.0], [0.25, 0.0, 0.0]),
            ([-1e308, 1e308, 0.0], [-0.25 / 2f64.sqrt(), 0.25 / 2f64.sqrt(), 0.0]),
            ([1e150, 0.0, 0.0], [0.25, 0.0, 0.0]),
            ([0.0, 0.0, 1.3e154], [0.0, 0.0, 0.25]),
            ([f64::INFINITY, 0.0, 1.0], [0.25, 0.0, 0.0]),
            ([0.1, 0.0, 0.0], [0.1, 0.0, 0.0]),
            ([3.0, 4.0, 0.0], [0.15, 0.2, 0.0]),
            ([5e-324, 0.0, 0.0], [5e-324, 0.0, 0.0]),
        ] {
            let got = limit_speed(command, 0.25);
            for (g, e) in got.iter().zip(expected) {
                assert!((g - e).abs() <= 1e-15, "{command:?} -> {got:?}, expected {expected:?}");
            }
        }
        assert!(limit_speed([f64::NAN, 0.0, 0.0], 0.25)[0].is_nan());
    }
}

#[cfg(test)]
mod recording_names {
    /// Names drawn at once from many threads never repeat.
    #[test]
    fn recordings_ending_together_get_distinct_names() {
        let dir = std::path::Path::new("/recordings");
        let names: Vec<_> = std::thread::scope(|s| {
            let workers: Vec<_> = (0..8)
                .map(|_| s.spawn(|| (0..500).map(|_| super::recording_path(dir, "reach-grasp", 1)).collect::<Vec<_>>()))
                .collect();
            workers.into_iter().flat_map(|w| w.join().unwrap()).collect()
        });
        let distinct: std::collections::HashSet<_> = names.iter().collect();
        assert_eq!(distinct.len(), 4000);
    }
}
