//! A shared-control episode in the kinematic simulator: a velocity-
//! controlled arm stepped at the arbiter's period, a simulated operator,
//! a collision check at every step, and termination by success, collision
//! or timeout.

use super::operator::{Observation, Operator, distance};
use crate::arbitration::{Arbiter, ArbiterWorkspace, HumanCommand, TickInput, TickStatus};
use crate::collision::CollisionWorkspace;
use crate::robot::{KinematicsWorkspace, RobotError};
use nalgebra::{IsometryMatrix3, Vector3};
use std::time::Instant;

/// When an episode ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeSettings {
    /// Timeout (s of simulated time; default 30).
    pub max_time: f64,
    /// Success: the gripper within this distance of the goal pose's origin (m; default 0.01) …
    pub position_tolerance: f64,
    /// … and its z axis within this angle of the goal pose's z axis (rad; default 0.2).
    pub orientation_tolerance: f64,
    /// Record the configurations and commands of every step (default true).
    pub record: bool,
}

impl Default for EpisodeSettings {
    fn default() -> Self {
        EpisodeSettings { max_time: 30.0, position_tolerance: 0.01, orientation_tolerance: 0.2, record: true }
    }
}

/// How an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Success,
    Collision,
    Timeout,
}

impl Outcome {
    /// `success`, `collision` or `timeout`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Outcome::Success => "success",
            Outcome::Collision => "collision",
            Outcome::Timeout => "timeout",
        }
    }
}

/// What happened in an episode.
#[derive(Debug, Clone)]
pub struct EpisodeRecord {
    pub outcome: Outcome,
    /// Control ticks run.
    pub steps: usize,
    /// Wall-clock time of each tick (µs).
    pub tick_us: Vec<f64>,
    /// Executed steps that left the joint limits, exceeded a velocity limit
    /// or ended in collision.
    pub hard_violations: usize,
    /// Smallest signed distance over the visited configurations (m).
    pub min_clearance: f64,
    /// Ticks whose status was a hold or a fallback (not `Nominal`,
    /// `Constrained` or `StepShortened`).
    pub fallbacks: usize,
    /// Configurations, the start first (when recorded).
    pub q: Vec<Vec<f64>>,
    /// Gripper positions (m, world), the start first.
    pub gripper: Vec<[f64; 3]>,
    /// Operator commands (m/s) and statuses, one per tick.
    pub commands: Vec<[f64; 3]>,
    pub statuses: Vec<TickStatus>,
    /// The gripper's final pose.
    pub final_pose: IsometryMatrix3<f64>,
}

/// Runs one episode: from `start`, `operator` steers toward `goal` (the
/// goal's final gripper pose, world) through `arbiter` until the gripper
/// reaches it (within the tolerances), the arm collides (checked with the
/// arbiter's collision model at every step, exact geometry), or time runs out.
///
/// # Errors
/// A bad start configuration or gripper frame.
pub fn run_episode(
    arbiter: &Arbiter,
    ws: &mut ArbiterWorkspace,
    start: &[f64],
    goal: &IsometryMatrix3<f64>,
    operator: &mut dyn Operator,
    settings: &EpisodeSettings,
) -> Result<EpisodeRecord, RobotError> {
    let robot = arbiter.robot();
    let model = arbiter.collision_model();
    let gripper = arbiter.gripper_frame();
    let dt = arbiter.settings().period;
    let n = robot.nq();
    let mut kin = KinematicsWorkspace::new(robot);
    let mut cws = CollisionWorkspace::new(model);
    let (mut q, mut velocity, mut next) = (start.to_vec(), vec![0.0; n], vec![0.0; n]);
    arbiter.reset(ws);
    robot.forward_kinematics(&mut kin, &q)?;
    let mut pose = robot.frame_pose(&kin, gripper);
    let goal_point: [f64; 3] = goal.translation.vector.into();
    let steps_max = (settings.max_time / dt).ceil() as usize;
    let mut record = EpisodeRecord {
        outcome: Outcome::Timeout,
        steps: 0,
        tick_us: Vec::with_capacity(steps_max),
        hard_violations: 0,
        min_clearance: model.min_distance(&mut cws, &q)?.map_or(f64::INFINITY, |d| d.signed.distance),
        fallbacks: 0,
        q: vec![],
        gripper: vec![],
        commands: vec![],
        statuses: vec![],
        final_pose: pose,
    };
    if settings.record {
        record.q.push(q.clone());
        record.gripper.push(pose.translation.vector.into());
    }
    for step in 0..steps_max {
        if reached(&pose, goal, settings) {
            record.outcome = Outcome::Success;
            break;
        }
        let seen =
            Observation { q: &q, gripper: pose.translation.vector.into(), goal: goal_point, time: step as f64 * dt };
        let mut v = [0.0; 3];
        operator.command(&seen, &mut v);
        let began = Instant::now();
        let command = arbiter.tick(
            ws,
            &TickInput { q: &q, velocity: Some(&velocity), command: HumanCommand::Linear(&v), beliefs: None },
        );
        record.tick_us.push(began.elapsed().as_secs_f64() * 1e6);
        record.steps += 1;
        if !matches!(command.status, TickStatus::Nominal | TickStatus::Constrained | TickStatus::StepShortened) {
            record.fallbacks += 1;
        }
        velocity.copy_from_slice(command.qdot);
        for j in 0..n {
            next[j] = q[j] + dt * velocity[j];
        }
        if settings.record {
            record.commands.push(v);
            record.statuses.push(command.status);
        }
        let within_limits = robot.limits().iter().zip(&next).zip(&velocity).all(|((l, x), v)| {
            let vmax = if l.velocity.is_finite() && l.velocity > 0.0 { l.velocity } else { f64::INFINITY };
            *x >= l.lower - 1e-9
                && *x <= l.upper + 1e-9
                && v.abs() <= vmax * arbiter.settings().safety.velocity_scale + 1e-9
        });
        let free = model.collision_free(&mut cws, &next)?;
        if !within_limits || !free {
            record.hard_violations += 1;
        }
        q.copy_from_slice(&next);
        if let Some(d) = model.min_distance(&mut cws, &q)? {
            record.min_clearance = record.min_clearance.min(d.signed.distance);
        }
        robot.forward_kinematics(&mut kin, &q)?;
        pose = robot.frame_pose(&kin, gripper);
        if settings.record {
            record.q.push(q.clone());
            record.gripper.push(pose.translation.vector.into());
        }
        if !free {
            record.outcome = Outcome::Collision;
            break;
        }
    }
    if record.outcome == Outcome::Timeout && reached(&pose, goal, settings) {
        record.outcome = Outcome::Success;
    }
    record.final_pose = pose;
    Ok(record)
}

/// The gripper at `goal` within the tolerances.
fn reached(pose: &IsometryMatrix3<f64>, goal: &IsometryMatrix3<f64>, s: &EpisodeSettings) -> bool {
    let close = distance(pose.translation.vector.into(), goal.translation.vector.into()) <= s.position_tolerance;
    let z = pose.rotation * Vector3::z();
    let aligned = z.angle(&(goal.rotation * Vector3::z())) <= s.orientation_tolerance;
    close && aligned
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
