//! A shared-control episode in the kinematic simulator: a velocity-
//! controlled arm stepped at the arbiter's period (`q ← q + q̇·dt`), a
//! simulated operator, and after every step a collision check (the
//! arbiter's collision model, exact geometry) and the task's judge. It ends
//! in success as soon as the judge agrees (§5.5.3 of the dissertation: "a
//! success when the object lies between the gripper's fingers"), in a
//! collision when the arm touches anything first, as failed when the operator
//! stops where the task is not done (it believes it has arrived), or in a
//! timeout.

use super::judge::Judge;
use super::operator::{Observation, Operator, OperatorAction};
use super::reason::Reason;
use crate::arbitration::{Arbiter, ArbiterWorkspace, HumanCommand, MotionAudit, TickInput, TickStatus};
use crate::collision::CollisionWorkspace;
use crate::control::RobotPolicyWorkspace;
use crate::robot::{KinematicsWorkspace, ReferenceFrame, RobotError};
use nalgebra::Matrix6xX;
use std::time::Instant;

/// When an episode ends, and what it keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeSettings {
    /// Timeout (s of simulated time; default 30).
    pub max_time: f64,
    /// Record configurations, commands, beliefs and statuses of every step
    /// (default true).
    pub record: bool,
}

impl Default for EpisodeSettings {
    fn default() -> Self {
        EpisodeSettings { max_time: 30.0, record: true }
    }
}

/// How an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Outcome {
    /// The task's judge agreed (checked after every step).
    Success,
    /// The operator stopped, believing it had arrived, where the judge did
    /// not agree (e.g. the box not between the fingers, the gripper not
    /// pointing down).
    Failed,
    /// The arm touched something.
    Collision,
    /// Time ran out.
    Timeout,
}

impl Outcome {
    /// `success`, `failed`, `collision` or `timeout`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Outcome::Success => "success",
            Outcome::Failed => "failed",
            Outcome::Collision => "collision",
            Outcome::Timeout => "timeout",
        }
    }
}

/// What happened in an episode.
#[derive(Debug, Clone)]
pub struct EpisodeRecord {
    /// How it ended.
    pub outcome: Outcome,
    /// Why it ended (its [`Outcome`] is `reason.outcome()`).
    pub reason: Reason,
    /// Control ticks run.
    pub steps: usize,
    /// Simulated duration (s).
    pub duration: f64,
    /// Wall-clock time of each tick (µs).
    pub tick_us: Vec<f64>,
    /// Executed steps that left the joint limits, exceeded a velocity
    /// limit, or (when the arbiter avoids collisions) ended in collision.
    pub hard_violations: usize,
    /// Executed commands that broke an acceleration, deceleration or jerk
    /// limit of the robot ([`RobotModel::motion_limits`](crate::robot::RobotModel::motion_limits)),
    /// by finite differences at the period from rest, and the largest
    /// ratios to those limits ([`MotionAudit`]).
    pub limit_violations: usize,
    /// The largest `|q̈| / limit` over the episode.
    pub peak_acceleration_ratio: f64,
    /// The largest `|q⃛| / limit` over the episode.
    pub peak_jerk_ratio: f64,
    /// Smallest signed distance over the visited configurations (m).
    pub min_clearance: f64,
    /// Ticks whose status was a hold or a fallback.
    pub fallbacks: usize,
    /// Gripper path length (m).
    pub travel: f64,
    /// Configurations, the start first (when recorded).
    pub q: Vec<Vec<f64>>,
    /// Gripper positions (m, world), the start first (always recorded).
    pub gripper: Vec<[f64; 3]>,
    /// Per tick (when recorded): the operator's command and the executed
    /// gripper velocity `J q̇` (m/s), the beliefs, the status.
    pub human: Vec<[f64; 3]>,
    /// Executed gripper velocities (m/s).
    pub executed: Vec<[f64; 3]>,
    /// Executed joint velocities (rad/s or m/s).
    pub qdot: Vec<Vec<f64>>,
    /// The most likely goal's robot action (rad/s or m/s).
    pub robot: Vec<Vec<f64>>,
    /// Beliefs over the goals.
    pub beliefs: Vec<Vec<f64>>,
    /// Tick statuses.
    pub statuses: Vec<TickStatus>,
    /// The final configuration.
    pub final_q: Vec<f64>,
    /// The grasped object's pose at each configuration of `q` (position in
    /// m, then the unit quaternion w, x, y, z; world frame) when a physics
    /// simulator moves it; empty in the kinematic simulator.
    pub object: Vec<[f64; 7]>,
}

impl EpisodeRecord {
    /// Mean cosine distance `1 − cos` between the operator's command and
    /// the executed gripper velocity, over the ticks where both move
    /// (the dissertation's Table 4.1); NaN without such ticks.
    pub fn mean_cosine_distance(&self) -> f64 {
        let values: Vec<f64> = self
            .human
            .iter()
            .zip(&self.executed)
            .filter_map(|(h, e)| {
                let (nh, ne) = (super::operator::norm3(*h), super::operator::norm3(*e));
                (nh > 1e-6 && ne > 1e-6).then(|| (1.0 - (h[0] * e[0] + h[1] * e[1] + h[2] * e[2]) / (nh * ne)).max(0.0))
            })
            .collect();
        if values.is_empty() { f64::NAN } else { values.iter().sum::<f64>() / values.len() as f64 }
    }
}

/// One episode's setup: the arbiter, the start, where the operator aims,
/// and which goal is the true one (its policy feeds operators that follow
/// the robot's policy).
#[derive(Clone, Copy)]
pub struct Episode<'a> {
    /// The arbiter blending the operator's commands.
    pub arbiter: &'a Arbiter,
    /// The start configuration.
    pub start: &'a [f64],
    /// The true goal's grasp point (m, world).
    pub target: [f64; 3],
    /// The true goal among the arbiter's goals.
    pub true_goal: usize,
    /// Timeout and recording.
    pub settings: EpisodeSettings,
}

impl Episode<'_> {
    /// Runs the episode with `operator`; `judge` says whether the task is
    /// done, at the start and after every step, and why not when the
    /// operator stops ([`TaskJudge`](super::TaskJudge), or any closure
    /// `FnMut(&[f64]) -> bool`).
    ///
    /// # Errors
    /// A bad start configuration.
    pub fn run(
        &self,
        ws: &mut ArbiterWorkspace,
        operator: &mut dyn Operator,
        judge: &mut dyn Judge,
    ) -> Result<EpisodeRecord, RobotError> {
        let arbiter = self.arbiter;
        let dt = arbiter.settings().period;
        let mut live = LiveEpisode::new(arbiter, ws, self.start, self.settings.record)?;
        let mut feed = OperatorFeed::new(arbiter, self.true_goal, operator.needs_policy());
        let steps_max = (self.settings.max_time / dt).ceil() as usize;
        live.record.tick_us.reserve(steps_max);
        let mut outcome = Outcome::Timeout;
        for step in 0..steps_max {
            if judge.succeeded(live.q()) {
                outcome = Outcome::Success;
                break;
            }
            let v = match feed.act(operator, &live, self.target, step as f64 * dt) {
                OperatorAction::Done => {
                    outcome = Outcome::Failed;
                    break;
                }
                OperatorAction::Move(v) => v,
            };
            if live.step(arbiter, ws, HumanCommand::Linear(&v))?.collided {
                outcome = Outcome::Collision;
                break;
            }
        }
        if outcome == Outcome::Timeout && judge.succeeded(live.q()) {
            outcome = Outcome::Success;
        }
        let reason = match outcome {
            Outcome::Failed => judge.diagnose(live.q(), live.gripper(), self.target),
            _ => live.reason(outcome, self.target),
        };
        Ok(live.finish(reason, dt))
    }
}

/// What a simulated operator sees each tick: the live state, its goal,
/// and (for operators that follow the robot) the true goal's policy action.
pub(crate) struct OperatorFeed {
    policy: Option<std::sync::Arc<dyn crate::control::RobotPolicy>>,
    state: Option<RobotPolicyWorkspace>,
    action: Vec<f64>,
}

impl OperatorFeed {
    /// The feed of an episode whose true goal is `true_goal` among
    /// `arbiter`'s goals; the policy runs only when `needs_policy`.
    pub(crate) fn new(arbiter: &Arbiter, true_goal: usize, needs_policy: bool) -> OperatorFeed {
        let policy = arbiter.goals().get(true_goal).map(|g| g.policy.clone());
        let state = policy.as_ref().map(|p| p.new_workspace());
        let action = vec![0.0; if needs_policy { arbiter.robot().nq() } else { 0 }];
        OperatorFeed { policy, state, action }
    }

    /// `operator`'s action at `live`'s state, aiming at `goal` (m, world),
    /// at `time` (s).
    pub(crate) fn act(
        &mut self,
        operator: &mut dyn Operator,
        live: &LiveEpisode,
        goal: [f64; 3],
        time: f64,
    ) -> OperatorAction {
        if let (Some(policy), Some(state), false) = (&self.policy, self.state.as_mut(), self.action.is_empty())
            && policy.act(state, live.q(), live.velocity(), &mut self.action).is_err()
        {
            self.action.fill(0.0);
        }
        operator.act(&Observation {
            q: live.q(),
            gripper: live.gripper(),
            goal,
            jacobian: live.linear_jacobian(),
            policy_action: &self.action,
            time,
        })
    }
}

/// What one [`LiveEpisode::step`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveStep {
    /// The tick's status.
    pub status: TickStatus,
    /// The executed step ended in collision (the episode is over).
    pub collided: bool,
    /// Wall-clock time of the arbiter's tick (µs).
    pub tick_us: f64,
    /// Signed distance to the nearest obstacle after the step (m; infinite
    /// without obstacles).
    pub clearance: f64,
}

/// An episode stepped one tick at a time by whoever supplies the
/// operator's command: [`Episode::run`] with a simulated operator, `tandem
/// serve` with a person at the controls. It owns the simulator's buffers
/// and the growing [`EpisodeRecord`]; the [`Arbiter`] is passed to each
/// step (model/workspace split), always the one it was made with.
#[derive(Debug)]
pub struct LiveEpisode {
    kin: KinematicsWorkspace,
    cws: CollisionWorkspace,
    jac: Matrix6xX<f64>,
    linear: Vec<f64>,
    q: Vec<f64>,
    velocity: Vec<f64>,
    next: Vec<f64>,
    gripper: [f64; 3],
    clearance: f64,
    nearest: Option<usize>,
    keep: bool,
    record: EpisodeRecord,
    /// The bodies of the first contact, once the arm collided.
    contact: Option<[String; 2]>,
    /// The status and time (µs) of the tick [`Self::command`] ran last.
    pending: (TickStatus, f64),
    /// The executed sequence against the motion limits.
    audit: MotionAudit,
}

impl LiveEpisode {
    /// Starts at `start` (at rest) and resets `ws`; `keep` records every
    /// tick's configuration, commands, beliefs and status.
    ///
    /// # Errors
    /// A start configuration of the wrong length or not finite.
    pub fn new(
        arbiter: &Arbiter,
        ws: &mut ArbiterWorkspace,
        start: &[f64],
        keep: bool,
    ) -> Result<LiveEpisode, RobotError> {
        let (robot, model) = (arbiter.robot(), arbiter.collision_model());
        robot.check_configuration(start)?;
        let n = robot.nq();
        let mut cws = CollisionWorkspace::new(model);
        let nearest = model.min_distance(&mut cws, start)?;
        let clearance = nearest.map_or(f64::INFINITY, |d| d.signed.distance);
        arbiter.reset(ws);
        let mut live = LiveEpisode {
            kin: KinematicsWorkspace::new(robot),
            cws,
            jac: Matrix6xX::zeros(n),
            linear: vec![0.0; 3 * n],
            q: start.to_vec(),
            velocity: vec![0.0; n],
            next: vec![0.0; n],
            gripper: [0.0; 3],
            clearance,
            nearest: nearest.map(|d| d.pair),
            keep,
            contact: None,
            pending: (TickStatus::Nominal, 0.0),
            audit: MotionAudit::new(n),
            record: EpisodeRecord {
                outcome: Outcome::Timeout,
                reason: Reason::Timeout { distance: f64::NAN },
                steps: 0,
                duration: 0.0,
                tick_us: vec![],
                hard_violations: 0,
                limit_violations: 0,
                peak_acceleration_ratio: 0.0,
                peak_jerk_ratio: 0.0,
                min_clearance: clearance,
                fallbacks: 0,
                travel: 0.0,
                q: vec![],
                gripper: vec![],
                human: vec![],
                executed: vec![],
                qdot: vec![],
                robot: vec![],
                beliefs: vec![],
                statuses: vec![],
                final_q: vec![],
                object: vec![],
            },
        };
        live.update_gripper(arbiter)?;
        live.record.gripper.push(live.gripper);
        if keep {
            live.record.q.push(live.q.clone());
        }
        Ok(live)
    }

    /// The configuration (rad or m).
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// The joint velocity executed last (rad/s or m/s; zero at the start).
    pub fn velocity(&self) -> &[f64] {
        &self.velocity
    }

    /// The gripper position (m, world).
    pub fn gripper(&self) -> [f64; 3] {
        self.gripper
    }

    /// The gripper Jacobian's linear rows at [`Self::q`] (3 × n, row-major).
    pub fn linear_jacobian(&self) -> &[f64] {
        &self.linear
    }

    /// Signed distance to the nearest obstacle at [`Self::q`] (m).
    pub fn clearance(&self) -> f64 {
        self.clearance
    }

    /// The collision pair behind [`Self::clearance`] (`None` without
    /// obstacles); its names from
    /// [`CollisionModel::pair_names`](crate::collision::CollisionModel::pair_names)
    /// of the arbiter's collision model.
    pub fn nearest_pair(&self) -> Option<usize> {
        self.nearest
    }

    /// The first pair of the arbiter's collision model the arm entered
    /// (names from
    /// [`CollisionModel::pair_names`](crate::collision::CollisionModel::pair_names)).
    pub fn first_contact(&self) -> Option<&[String; 2]> {
        self.contact.as_ref()
    }

    /// The record so far (its outcome is set by [`Self::finish`]).
    pub fn record(&self) -> &EpisodeRecord {
        &self.record
    }

    /// One control tick: the arbiter blends `command` at the current state,
    /// the arm moves `q ← q + q̇·dt`, and the new configuration is checked
    /// against the limits and for collision.
    ///
    /// # Errors
    /// Kinematics or collision queries failing on the new configuration.
    pub fn step(
        &mut self,
        arbiter: &Arbiter,
        ws: &mut ArbiterWorkspace,
        command: HumanCommand<'_>,
    ) -> Result<LiveStep, RobotError> {
        let dt = arbiter.settings().period;
        self.command(arbiter, ws, command);
        for j in 0..self.q.len() {
            self.next[j] = self.q[j] + dt * self.velocity[j];
        }
        self.arrive_at_next(arbiter)
    }

    /// The first half of a tick, for a simulator that moves the arm itself
    /// (physics): the arbiter blends `command` at the current state and the
    /// tick is recorded; returns the joint velocity to execute (rad/s or
    /// m/s). [`Self::arrive`] then reports where the arm got to.
    pub fn command(&mut self, arbiter: &Arbiter, ws: &mut ArbiterWorkspace, command: HumanCommand<'_>) -> &[f64] {
        let n = self.q.len();
        let began = Instant::now();
        let input = TickInput { q: &self.q, velocity: Some(&self.velocity), command, beliefs: None };
        let tick = arbiter.tick(ws, &input);
        let tick_us = began.elapsed().as_secs_f64() * 1e6;
        let (status, goal) = (tick.status, tick.diagnostics.goal);
        self.velocity.copy_from_slice(tick.qdot);
        self.pending = (status, tick_us);
        self.audit.observe(&self.velocity, arbiter.settings().period, arbiter.robot().motion_limits());
        let record = &mut self.record;
        record.limit_violations = self.audit.violations;
        record.peak_acceleration_ratio = self.audit.peak_acceleration_ratio;
        record.peak_jerk_ratio = self.audit.peak_jerk_ratio;
        record.tick_us.push(tick_us);
        record.steps += 1;
        if !matches!(
            status,
            TickStatus::Nominal | TickStatus::SingularityDamped | TickStatus::Constrained | TickStatus::StepShortened
        ) {
            record.fallbacks += 1;
        }
        if self.keep {
            let linear = &self.linear;
            let executed = [0, 1, 2].map(|r| (0..n).map(|c| linear[r * n + c] * self.velocity[c]).sum::<f64>());
            let human = match command {
                HumanCommand::Linear(v) | HumanCommand::Twist(v) if v.len() >= 3 => [v[0], v[1], v[2]],
                _ => [f64::NAN; 3],
            };
            record.human.push(human);
            record.executed.push(executed);
            record.qdot.push(self.velocity.clone());
            record.robot.push(goal.map_or_else(Vec::new, |g| ws.robot_action(g).to_vec()));
            record.beliefs.push(ws.beliefs().to_vec());
            record.statuses.push(status);
        }
        &self.velocity
    }

    /// The second half of a tick begun by [`Self::command`]: the arm is at
    /// `q` (rad or m) a period later; the configuration is checked against
    /// the limits and for collision, as in [`Self::step`].
    ///
    /// # Errors
    /// `q` of the wrong length; kinematics or collision queries failing.
    pub fn arrive(&mut self, arbiter: &Arbiter, q: &[f64]) -> Result<LiveStep, RobotError> {
        arbiter.robot().check_configuration(q)?;
        self.next.copy_from_slice(q);
        self.arrive_at_next(arbiter)
    }

    fn arrive_at_next(&mut self, arbiter: &Arbiter) -> Result<LiveStep, RobotError> {
        let (robot, model) = (arbiter.robot(), arbiter.collision_model());
        let (status, tick_us) = self.pending;
        let record = &mut self.record;
        let safety = &arbiter.settings().safety;
        let within_limits = robot.limits().iter().zip(&self.next).zip(&self.velocity).all(|((l, x), v)| {
            let vmax = if l.velocity.is_finite() && l.velocity > 0.0 { l.velocity } else { f64::INFINITY };
            *x >= l.lower - 1e-9 && *x <= l.upper + 1e-9 && v.abs() <= vmax * safety.velocity_scale + 1e-9
        });
        let free = model.collision_free(&mut self.cws, &self.next)?;
        if !within_limits || (safety.collisions && !free) {
            record.hard_violations += 1;
        }
        if !free && self.contact.is_none() {
            // Allocates once, at the end of the episode.
            if let Some(d) = model.min_distance(&mut self.cws, &self.next)? {
                let (a, b) = model.pair_names(d.pair);
                self.contact = Some([a.to_string(), b.to_string()]);
            }
        }
        self.q.copy_from_slice(&self.next);
        let nearest = model.min_distance(&mut self.cws, &self.q)?;
        self.clearance = nearest.map_or(f64::INFINITY, |d| d.signed.distance);
        self.nearest = nearest.map(|d| d.pair);
        self.record.min_clearance = self.record.min_clearance.min(self.clearance);
        let before = self.gripper;
        self.update_gripper(arbiter)?;
        self.record.travel += super::operator::distance(before, self.gripper);
        self.record.gripper.push(self.gripper);
        if self.keep {
            self.record.q.push(self.q.clone());
        }
        Ok(LiveStep { status, collided: !free, tick_us, clearance: self.clearance })
    }

    /// The reason of an episode ending now in `outcome` that the simulator
    /// can tell by itself: success, the collision's pair, or how far from
    /// `target` (m, world) time ran out. A `Failed` episode's reason is its
    /// judge's ([`Judge::diagnose`]): this one says only how far short.
    pub fn reason(&self, outcome: Outcome, target: [f64; 3]) -> Reason {
        let distance = super::operator::distance(self.gripper, target);
        match outcome {
            Outcome::Success => Reason::Success,
            Outcome::Collision => Reason::Collision {
                pair: self.contact.clone().unwrap_or_else(|| ["the arm".into(), "something".into()]),
            },
            Outcome::Timeout => Reason::Timeout { distance },
            _ => Reason::StoppedShort { distance, tolerance: super::REACH_TOLERANCE },
        }
    }

    /// Ends the episode for `reason` (its outcome is `reason.outcome()`);
    /// `dt` is the control period (s).
    pub fn finish(mut self, reason: Reason, dt: f64) -> EpisodeRecord {
        self.record.outcome = reason.outcome();
        self.record.reason = reason;
        self.record.duration = self.record.steps as f64 * dt;
        self.record.final_q = self.q;
        self.record
    }

    /// Gripper position and the Jacobian's linear rows (row-major) at `q`.
    fn update_gripper(&mut self, arbiter: &Arbiter) -> Result<(), RobotError> {
        let robot = arbiter.robot();
        robot.forward_kinematics(&mut self.kin, &self.q)?;
        let pose =
            robot.frame_jacobian(&self.kin, arbiter.gripper_frame(), ReferenceFrame::WorldAligned, &mut self.jac)?;
        let n = self.q.len();
        for r in 0..3 {
            for c in 0..n {
                self.linear[r * n + c] = self.jac[(r, c)];
            }
        }
        self.gripper = pose.translation.vector.into();
        Ok(())
    }
}

/// Median, 99th percentile and maximum of `samples` (NaN when empty).
pub fn percentiles(samples: &[f64]) -> (f64, f64, f64) {
    if samples.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let mut sorted = samples.to_vec();
    sorted.sort_by(f64::total_cmp);
    let at = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    (at(0.5), at(0.99), sorted[sorted.len() - 1])
}
