//! A shared-control episode in the kinematic simulator: a velocity-
//! controlled arm stepped at the arbiter's period (`q ← q + q̇·dt`), a
//! simulated operator, and after every step a collision check (the
//! arbiter's collision model, exact geometry) and the task's judge. It ends
//! in success as soon as the judge agrees (seed §5.5.3: "a success when the
//! object lies between the gripper's fingers"), in a collision when the arm
//! touches anything first, as failed when the operator stops where the task
//! is not done (it believes it has arrived), or in a timeout.

use super::operator::{Observation, Operator, OperatorAction};
use crate::arbitration::{Arbiter, ArbiterWorkspace, HumanCommand, TickInput, TickStatus};
use crate::collision::CollisionWorkspace;
use crate::control::PolicyState;
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
    /// Control ticks run.
    pub steps: usize,
    /// Simulated duration (s).
    pub duration: f64,
    /// Wall-clock time of each tick (µs).
    pub tick_us: Vec<f64>,
    /// Executed steps that left the joint limits, exceeded a velocity
    /// limit, or (when the arbiter avoids collisions) ended in collision.
    pub hard_violations: usize,
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
}

impl EpisodeRecord {
    /// Mean cosine distance `1 − cos` between the operator's command and
    /// the executed gripper velocity, over the ticks where both move
    /// (seed Table 4.1); NaN without such ticks.
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
    /// Runs the episode with `operator`; `judge(q)` says whether the task
    /// is done, at the start and after every step.
    ///
    /// # Errors
    /// A bad start configuration.
    pub fn run(
        &self,
        ws: &mut ArbiterWorkspace,
        operator: &mut dyn Operator,
        judge: &mut dyn FnMut(&[f64]) -> bool,
    ) -> Result<EpisodeRecord, RobotError> {
        let arbiter = self.arbiter;
        let (robot, model) = (arbiter.robot(), arbiter.collision_model());
        let dt = arbiter.settings().period;
        let avoids = arbiter.settings().safety.collisions;
        let n = robot.nq();
        let mut kin = KinematicsWorkspace::new(robot);
        let mut cws = CollisionWorkspace::new(model);
        let mut jac = Matrix6xX::zeros(n);
        let mut linear = vec![0.0; 3 * n];
        let (mut q, mut velocity, mut next) = (self.start.to_vec(), vec![0.0; n], vec![0.0; n]);
        let true_policy = arbiter.goals().get(self.true_goal).map(|g| g.policy.clone());
        let mut policy_state: Option<PolicyState> = true_policy.as_ref().map(|p| p.new_state());
        let mut policy_action = vec![0.0; if operator.needs_policy() { n } else { 0 }];
        arbiter.reset(ws);
        let steps_max = (self.settings.max_time / dt).ceil() as usize;
        let mut record = EpisodeRecord {
            outcome: Outcome::Timeout,
            steps: 0,
            duration: 0.0,
            tick_us: Vec::with_capacity(steps_max),
            hard_violations: 0,
            min_clearance: model.min_distance(&mut cws, &q)?.map_or(f64::INFINITY, |d| d.signed.distance),
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
        };
        let mut gripper = self.gripper_state(&mut kin, &mut jac, &mut linear, &q)?;
        record.gripper.push(gripper);
        if self.settings.record {
            record.q.push(q.clone());
        }
        for step in 0..steps_max {
            if judge(&q) {
                record.outcome = Outcome::Success;
                break;
            }
            if let (Some(policy), Some(state), false) = (&true_policy, policy_state.as_mut(), policy_action.is_empty())
                && policy.act(state, &q, &velocity, &mut policy_action).is_err()
            {
                policy_action.fill(0.0);
            }
            let seen = Observation {
                q: &q,
                gripper,
                goal: self.target,
                jacobian: &linear,
                policy_action: &policy_action,
                time: step as f64 * dt,
            };
            let v = match operator.act(&seen) {
                OperatorAction::Done => {
                    record.outcome = Outcome::Failed;
                    break;
                }
                OperatorAction::Move(v) => v,
            };
            let began = Instant::now();
            let input =
                TickInput { q: &q, velocity: Some(&velocity), command: HumanCommand::Linear(&v), beliefs: None };
            let command = arbiter.tick(ws, &input);
            record.tick_us.push(began.elapsed().as_secs_f64() * 1e6);
            record.steps += 1;
            let (status, goal) = (command.status, command.diagnostics.goal);
            if !matches!(status, TickStatus::Nominal | TickStatus::Constrained | TickStatus::StepShortened) {
                record.fallbacks += 1;
            }
            velocity.copy_from_slice(command.qdot);
            for j in 0..n {
                next[j] = q[j] + dt * velocity[j];
            }
            if self.settings.record {
                let executed = [0, 1, 2].map(|r| (0..n).map(|c| linear[r * n + c] * velocity[c]).sum::<f64>());
                record.human.push(v);
                record.executed.push(executed);
                record.qdot.push(velocity.clone());
                record.robot.push(goal.map_or_else(Vec::new, |g| ws.robot_action(g).to_vec()));
                record.beliefs.push(ws.beliefs().to_vec());
                record.statuses.push(status);
            }
            let within_limits = robot.limits().iter().zip(&next).zip(&velocity).all(|((l, x), v)| {
                let vmax = if l.velocity.is_finite() && l.velocity > 0.0 { l.velocity } else { f64::INFINITY };
                *x >= l.lower - 1e-9
                    && *x <= l.upper + 1e-9
                    && v.abs() <= vmax * arbiter.settings().safety.velocity_scale + 1e-9
            });
            let free = model.collision_free(&mut cws, &next)?;
            if !within_limits || (avoids && !free) {
                record.hard_violations += 1;
            }
            q.copy_from_slice(&next);
            if let Some(d) = model.min_distance(&mut cws, &q)? {
                record.min_clearance = record.min_clearance.min(d.signed.distance);
            }
            let before = gripper;
            gripper = self.gripper_state(&mut kin, &mut jac, &mut linear, &q)?;
            record.travel += super::operator::distance(before, gripper);
            record.gripper.push(gripper);
            if self.settings.record {
                record.q.push(q.clone());
            }
            if !free {
                record.outcome = Outcome::Collision;
                break;
            }
        }
        if record.outcome == Outcome::Timeout && judge(&q) {
            record.outcome = Outcome::Success;
        }
        record.duration = record.steps as f64 * dt;
        record.final_q = q;
        Ok(record)
    }

    /// Gripper position at `q`, and the Jacobian's linear rows (row-major).
    fn gripper_state(
        &self,
        kin: &mut KinematicsWorkspace,
        jac: &mut Matrix6xX<f64>,
        linear: &mut [f64],
        q: &[f64],
    ) -> Result<[f64; 3], RobotError> {
        let robot = self.arbiter.robot();
        robot.forward_kinematics(kin, q)?;
        let pose = robot.frame_jacobian(kin, self.arbiter.gripper_frame(), ReferenceFrame::WorldAligned, jac)?;
        let n = q.len();
        for r in 0..3 {
            for c in 0..n {
                linear[r * n + c] = jac[(r, c)];
            }
        }
        Ok(pose.translation.vector.into())
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
