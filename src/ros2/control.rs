//! The node's control loop without the middleware: the latest joint state
//! and command as messages deliver them, then one arbiter tick per period
//! and what to publish. Holds (a braking stop within the motion limits,
//! then still) when the command or the joint states are stale or
//! malformed, and never panics on what arrives. Allocation-free after the
//! first messages: the joint-name mapping is rebuilt only when a message's
//! names change.
//!
//! With position outputs the ticks run from the node's *reference*, its own
//! last commanded positions, not from the measurement: a robot reports its
//! state a period or more late, and a command integrated from a lagging
//! measurement moves a held arm back and forth between two readings. The
//! reference is re-anchored to the measurement when they differ by more
//! than [`NodeSettings::reference_deviation_limit`] (the robot did not
//! follow: a reflex, a push, a controller switched off), counted in the
//! `reanchors` diagnostic.

use super::messages::{JointJog, JointState, Time, TwistStamped};
use super::settings::NodeSettings;
use super::status::status_code;
use crate::arbitration::{
    Arbiter, ArbiterWorkspace, ArbitrationMode, HumanCommand, TickInput, TickStatus, limit_speed,
};
use crate::robot::{FrameId, KinematicsWorkspace};
use std::time::Instant;

/// The status code of a hold for a command older than
/// `incoming_command_timeout` (or none yet).
pub const COMMAND_STALE: i8 = 15;
/// The status code of a hold for joint states older than
/// `joint_state_timeout` (or none yet).
pub const STATE_STALE: i8 = 16;
/// The status code of a hold for a point cloud older than
/// `point_cloud_max_age` (or none yet) with `point_cloud_stale: hold`.
pub const POINT_CLOUD_STALE: i8 = 17;

/// The node's own holds (not the arbiter's), in the order of the `hold`
/// diagnostic: its value is the index here plus one, 0 when the node did
/// not hold. `hold_joint` names the arm's joint at fault, when one is.
pub const HOLDS: [&str; 10] = [
    "joint states stale",
    "joint states invalid: one of the arm's joints missing, or lengths that differ",
    "joint states invalid: a position not finite",
    "joint states invalid: one of the arm's joints named twice",
    "command stale",
    "command invalid: a frame other than the root link or the gripper frame",
    "command invalid: an unknown joint, lengths that differ or no velocities",
    "command invalid: a joint named twice",
    "command invalid: not finite (NaN or infinite)",
    "point cloud stale",
];

// Indices into HOLDS.
const STATE_STALE_HOLD: usize = 0;
const STATE_SHAPE: usize = 1;
const STATE_NOT_FINITE: usize = 2;
const STATE_DUPLICATE: usize = 3;
const COMMAND_STALE_HOLD: usize = 4;
const COMMAND_FRAME: usize = 5;
const COMMAND_SHAPE: usize = 6;
const COMMAND_DUPLICATE: usize = 7;
const COMMAND_NOT_FINITE: usize = 8;
const CLOUD_STALE_HOLD: usize = 9;

/// Why a mode name was refused (no allocation: the name itself is the
/// caller's to echo, bounded).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeRefusal {
    /// No mode has the name.
    Unknown,
    /// `learned` without an arbitration actor.
    NeedsActor,
}

impl std::fmt::Display for ModeRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ModeRefusal::Unknown => {
                "unknown arbitration mode (have: direct, blend-timid, blend-aggressive, avoid, natural-gradient, \
                 natural-gradient-joint, constrained, sos, learned)"
            }
            ModeRefusal::NeedsActor => "mode learned needs an arbitration actor (--arbiter)",
        })
    }
}

/// The diagnostics topic's values, in order (`std_msgs/Float64MultiArray`;
/// the layout's one dimension is labelled with these names).
pub const DIAGNOSTICS: [&str; 21] = [
    "tick_us",
    "command_stamp_s",
    "status",
    "gripper_x_m",
    "gripper_y_m",
    "gripper_z_m",
    "min_distance_m",
    "rows",
    "active_rows",
    "solves",
    "step_fraction",
    "confidence",
    "mode",
    "late_ticks",
    "ticks",
    "goal_updates",
    "hold",
    "hold_joint",
    "reference_deviation",
    "reanchors",
    "point_cloud_age_s",
];

/// What the latest command was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CommandKind {
    None,
    /// A twist in the root frame (world axes).
    Twist,
    /// A twist in the gripper frame: rotated into world axes each tick.
    GripperTwist,
    Joint,
    /// Refused (the reason an index into [`HOLDS`], the arm's joint at
    /// fault): holds with `invalid_command` until the next command.
    Invalid(usize, Option<usize>),
}

/// What a tick decided.
#[derive(Debug, Clone, Default)]
pub struct ControlOutput {
    /// The joint velocity to execute this period (rad/s or m/s).
    pub qdot: Vec<f64>,
    /// Where it takes the arm after one period (rad or m): the
    /// configuration the tick ran from (the reference with position
    /// outputs, else the measurement) plus `qdot` × period.
    pub positions: Vec<f64>,
    /// The change of `qdot` from the previous tick over the period
    /// (rad/s² or m/s²): a JointTrajectory point's accelerations, consistent
    /// with its velocities as the next position is with `positions`.
    pub accelerations: Vec<f64>,
    /// The status topic's value.
    pub code: i8,
    /// The arbiter's status (`None` for the node's own holds, codes 15–16).
    pub status: Option<TickStatus>,
    /// Why the node held, when it was not the arbiter's decision (one of [`HOLDS`]).
    pub hold_reason: Option<&'static str>,
    /// The arm's joint (index in the arbiter's joints) the hold is about, if one is.
    pub hold_joint: Option<usize>,
    /// The stamp of the command this tick used, the first time a tick used
    /// it (s since the epoch, from its header); NaN otherwise.
    pub command_stamp: f64,
    /// The diagnostics topic's values ([`DIAGNOSTICS`]).
    pub diagnostics: [f64; DIAGNOSTICS.len()],
}

/// The node's state between ticks.
pub struct ControlLoop {
    arbiter: Arbiter,
    ws: ArbiterWorkspace,
    kinematics: KinematicsWorkspace,
    gripper: FrameId,
    settings: NodeSettings,
    /// The root link: twists in this frame (or with an empty frame) are in world axes.
    root_frame: String,
    gripper_frame: String,
    /// Measured configuration and when it arrived.
    q: Vec<f64>,
    /// The configuration the ticks run from: with position outputs the
    /// last commanded positions (re-anchored past the deviation limit),
    /// else the measurement. Valid once a valid joint state has arrived.
    reference: Vec<f64>,
    has_reference: bool,
    /// Whether the reference continues from the last command (position outputs).
    continue_reference: bool,
    /// Re-anchor when the reference is farther than this from the measurement (rad or m).
    reference_limit: f64,
    reanchors: u64,
    q_at: Option<Instant>,
    state_valid: bool,
    /// Why the last joint state is invalid: an index into [`HOLDS`], the joint.
    state_fault: Option<(usize, Option<usize>)>,
    /// The first of the arm's joints the last names list twice (found when the names change).
    state_duplicate: Option<usize>,
    /// Scratch for a JointJog: which of the arm's joints it named.
    jog_named: Vec<bool>,
    /// For each of the arbiter's joints, its index in the last JointState's names.
    state_map: Vec<usize>,
    /// The last JointState's names: the first `state_count` of these.
    state_names: Vec<String>,
    state_count: usize,
    /// The latest command.
    kind: CommandKind,
    twist: [f64; 6],
    joint: Vec<f64>,
    command_at: Option<Instant>,
    command_stamp: f64,
    stamp_used: bool,
    /// The velocity executed last tick (the robot policies' state).
    qdot_prev: Vec<f64>,
    out: ControlOutput,
    ticks: u64,
    late_ticks: u64,
    goal_updates: u64,
    /// When the point cloud in the arbiter's scene arrived (`None`: no cloud yet).
    cloud_at: Option<Instant>,
    /// Hold when the cloud is older than this (s); `None`: never.
    cloud_hold_after: Option<f64>,
    /// Goal updates accepted; a cloud built for other goals is not swapped in.
    goal_generation: u64,
}

impl ControlLoop {
    /// A loop for `arbiter` (its mode, period and centres replaced by the settings').
    ///
    /// # Errors
    /// The settings' mode not one the arbiter runs (`learned` without an actor).
    pub fn new(arbiter: &Arbiter, settings: &NodeSettings) -> Result<ControlLoop, String> {
        let arbiter_settings = crate::arbitration::ArbiterSettings {
            mode: settings.mode,
            ..settings.arbiter_settings(arbiter.settings())
        };
        let arbiter = arbiter.with_settings(arbiter_settings).map_err(|e| e.to_string())?;
        let robot = arbiter.robot().clone();
        let n = robot.nq();
        let gripper = arbiter.gripper_frame();
        let out = ControlOutput {
            qdot: vec![0.0; n],
            positions: vec![0.0; n],
            accelerations: vec![0.0; n],
            command_stamp: f64::NAN,
            ..ControlOutput::default()
        };
        Ok(ControlLoop {
            ws: arbiter.workspace(),
            kinematics: KinematicsWorkspace::new(&robot),
            gripper,
            root_frame: robot.description().root_link().to_string(),
            gripper_frame: robot.frame_name(gripper).to_string(),
            settings: settings.clone(),
            q: vec![0.0; n],
            reference: vec![0.0; n],
            has_reference: false,
            continue_reference: settings.publishes_positions(),
            reference_limit: settings.reference_deviation_limit(
                robot.motion_limits().iter().map(|l| l.velocity).filter(|v| v.is_finite()).fold(0.0, f64::max),
            ),
            reanchors: 0,
            q_at: None,
            state_valid: false,
            state_fault: None,
            state_duplicate: None,
            jog_named: vec![false; n],
            state_map: vec![usize::MAX; n],
            state_names: Vec::new(),
            state_count: 0,
            kind: CommandKind::None,
            twist: [0.0; 6],
            joint: vec![0.0; n],
            command_at: None,
            command_stamp: f64::NAN,
            stamp_used: true,
            qdot_prev: vec![0.0; n],
            out,
            ticks: 0,
            late_ticks: 0,
            goal_updates: 0,
            cloud_at: None,
            cloud_hold_after: settings.camera.hold_after(),
            goal_generation: 0,
            arbiter,
        })
    }

    /// The arbiter (its goals, robot, settings).
    pub fn arbiter(&self) -> &Arbiter {
        &self.arbiter
    }

    /// Replaces the arbiter (new goals, e.g. from a PoseArray) from the
    /// next tick, keeping the mode, the rate and the latest state and
    /// command; the intent estimate starts afresh.
    ///
    /// # Errors
    /// A robot with other joints, or the mode not one the new arbiter runs.
    pub fn replace_arbiter(&mut self, arbiter: &Arbiter) -> Result<(), String> {
        if arbiter.robot().joint_names() != self.arbiter.robot().joint_names() {
            return Err("the new arbiter's robot has other joints".into());
        }
        let settings = crate::arbitration::ArbiterSettings { mode: self.ws.mode(), ..*self.arbiter.settings() };
        self.arbiter = arbiter.with_settings(settings).map_err(|e| e.to_string())?;
        let mut ws = self.arbiter.workspace();
        // Mid-motion: the new goals' first command continues the last one.
        ws.continue_motion(&self.ws);
        self.ws = ws;
        self.goal_updates += 1;
        Ok(())
    }

    /// Swaps in `arbiter` — the same goals against a scene with a new
    /// point cloud that arrived at `cloud_at`, from
    /// [`Arbiter::with_collision_model`] — and its hard-constraint `rows`
    /// (from [`Arbiter::safety_rows`]), from the next tick. Everything else
    /// carries over: the beliefs, the motion, the mode. The old arbiter and
    /// rows are left in `arbiter` and `rows`, for the caller to drop off
    /// the loop's thread. Allocates nothing.
    ///
    /// Swaps nothing (and returns false) when `arbiter` was built for
    /// other goals than the loop's (`generation` is not
    /// [`Self::goal_generation`]: the goals changed while the cloud was
    /// being built) or for another robot.
    pub fn swap_collision(
        &mut self,
        arbiter: &mut Arbiter,
        rows: &mut crate::arbitration::SafetyRows,
        generation: u64,
        cloud_at: Instant,
    ) -> bool {
        if generation != self.goal_generation
            || arbiter.robot().joint_names() != self.arbiter.robot().joint_names()
            || rows.joints() != self.arbiter.robot().nq()
        {
            return false;
        }
        self.ws.swap_safety_rows(rows);
        self.cloud_at = Some(cloud_at);
        std::mem::swap(&mut self.arbiter, arbiter);
        true
    }

    /// Goal updates accepted so far ([`Self::accept_goals`]).
    pub fn goal_generation(&self) -> u64 {
        self.goal_generation
    }

    /// Notes that the arbiter of goal update `generation` (just given to
    /// [`Self::replace_arbiter`]) keeps the cloud that arrived at `cloud_at`.
    pub fn accept_goals(&mut self, generation: u64, cloud_at: Option<Instant>) {
        self.goal_generation = generation;
        if cloud_at.is_some() {
            self.cloud_at = cloud_at;
        }
    }

    /// The measured configuration, when the last joint state was valid.
    pub fn measured(&self) -> Option<&[f64]> {
        self.state_valid.then_some(&self.q[..])
    }

    /// The mode running.
    pub fn mode(&self) -> ArbitrationMode {
        self.ws.mode()
    }

    /// Switches the mode (from the next tick).
    ///
    /// # Errors
    /// An unknown name, or `learned` without an actor.
    pub fn set_mode(&mut self, name: &str) -> Result<ArbitrationMode, String> {
        let mode: ArbitrationMode = name.trim().parse().map_err(|e| format!("{e}"))?;
        self.switch_mode(mode).map_err(|e| e.to_string())?;
        Ok(mode)
    }

    /// The mode named `name` (surrounding whitespace ignored), if this
    /// loop can run it. Allocates nothing, whatever the name.
    ///
    /// # Errors
    /// An unknown name, or `learned` without an actor.
    pub fn parse_mode(&self, name: &str) -> Result<ArbitrationMode, ModeRefusal> {
        let name = name.trim();
        let mode = ArbitrationMode::ALL
            .into_iter()
            .chain([ArbitrationMode::Learned])
            .find(|m| m.as_str() == name)
            .ok_or(ModeRefusal::Unknown)?;
        if mode == ArbitrationMode::Learned && self.arbiter.arbitration_policy().is_none() {
            return Err(ModeRefusal::NeedsActor);
        }
        Ok(mode)
    }

    /// Switches to `mode` (from the next tick).
    ///
    /// # Errors
    /// `learned` without an actor.
    pub fn switch_mode(&mut self, mode: ArbitrationMode) -> Result<(), ModeRefusal> {
        if mode == ArbitrationMode::Learned && self.arbiter.arbitration_policy().is_none() {
            return Err(ModeRefusal::NeedsActor);
        }
        self.ws.set_mode(mode);
        Ok(())
    }

    /// The beliefs over the goals after the last tick.
    pub fn beliefs(&self) -> &[f64] {
        self.ws.beliefs()
    }

    /// Reads a `/joint_states` message received at `now`. Joints the
    /// arbiter does not drive are ignored; a missing joint, one of the
    /// arm's joints named twice (which value would be the arm's?), a
    /// wrong-length position list or a non-finite position makes the state
    /// invalid (the arm holds) until a good message arrives.
    pub fn joint_state(&mut self, msg: &JointState, now: Instant) {
        if !same_names(&self.state_names[..self.state_count], &msg.name) {
            // Each slot keeps its allocation: once a names list has been
            // seen, switching back to it allocates nothing.
            for (i, name) in msg.name.iter().enumerate() {
                match self.state_names.get_mut(i) {
                    Some(slot) => slot.clone_from(name),
                    None => self.state_names.push(name.clone()),
                }
            }
            self.state_count = msg.name.len();
            let joints = self.arbiter.robot().joint_names();
            self.state_duplicate = None;
            for (j, (slot, joint)) in self.state_map.iter_mut().zip(joints).enumerate() {
                let mut named = msg.name.iter().enumerate().filter(|(_, n)| *n == joint).map(|(i, _)| i);
                *slot = named.next().unwrap_or(usize::MAX);
                if named.next().is_some() && self.state_duplicate.is_none() {
                    self.state_duplicate = Some(j);
                }
            }
        }
        self.q_at = Some(now);
        let missing = self.state_map.iter().position(|&i| i == usize::MAX);
        self.state_fault = if let Some(j) = self.state_duplicate {
            Some((STATE_DUPLICATE, Some(j)))
        } else if missing.is_some() || msg.position.len() != msg.name.len() {
            Some((STATE_SHAPE, missing))
        } else {
            self.state_map.iter().position(|&i| !msg.position[i].is_finite()).map(|j| (STATE_NOT_FINITE, Some(j)))
        };
        self.state_valid = self.state_fault.is_none();
        if self.state_valid {
            for (q, &i) in self.q.iter_mut().zip(&self.state_map) {
                *q = msg.position[i];
            }
        }
    }

    /// Reads a twist command (MoveIt Servo's `delta_twist_cmds`) received
    /// at `now`: its frame the root link (or empty: the root link) or the
    /// gripper frame; any other frame, or a component that is NaN or
    /// infinite (even the angular part when only the linear one is
    /// executed), is refused (the arm holds with `invalid_command`). A
    /// finite twist faster than `max_speed` keeps its direction at that speed.
    pub fn twist(&mut self, msg: &TwistStamped, now: Instant) {
        let t = &msg.twist;
        self.twist = [t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z];
        let frame = msg.header.frame_id.as_str();
        self.kind = if !(frame.is_empty() || frame == self.root_frame || frame == self.gripper_frame) {
            CommandKind::Invalid(COMMAND_FRAME, None)
        } else if self.twist.iter().any(|v| !v.is_finite()) {
            // limit_speed would scale an infinite component to max_speed
            // along its axis: the arm moved on an input it cannot trust.
            CommandKind::Invalid(COMMAND_NOT_FINITE, None)
        } else if frame == self.gripper_frame {
            CommandKind::GripperTwist
        } else {
            CommandKind::Twist
        };
        self.arrived(&msg.header.stamp, now);
    }

    /// Reads a joint command (MoveIt Servo's `delta_joint_cmds`) received
    /// at `now`: velocities for some of the arbiter's joints (the others
    /// zero). Displacements without velocities, an unknown joint, a joint
    /// named twice, a velocity that is not finite or lengths that differ
    /// are refused (hold with `invalid_command`).
    pub fn joint_jog(&mut self, msg: &JointJog, now: Instant) {
        self.joint.iter_mut().for_each(|v| *v = 0.0);
        self.jog_named.iter_mut().for_each(|v| *v = false);
        let joints = self.arbiter.robot().joint_names();
        let mut fault = (msg.velocities.len() != msg.joint_names.len() || msg.joint_names.is_empty())
            .then_some((COMMAND_SHAPE, None));
        for (name, v) in msg.joint_names.iter().zip(&msg.velocities) {
            match joints.iter().position(|j| j == name) {
                Some(j) if self.jog_named[j] => {
                    fault = fault.or(Some((COMMAND_DUPLICATE, Some(j))));
                }
                Some(j) if !v.is_finite() => fault = fault.or(Some((COMMAND_NOT_FINITE, Some(j)))),
                Some(j) => {
                    self.jog_named[j] = true;
                    self.joint[j] = *v;
                }
                None => fault = fault.or(Some((COMMAND_SHAPE, None))),
            }
        }
        self.kind = match fault {
            Some((reason, joint)) => CommandKind::Invalid(reason, joint),
            None => CommandKind::Joint,
        };
        self.arrived(&msg.header.stamp, now);
    }

    fn arrived(&mut self, stamp: &Time, now: Instant) {
        self.command_at = Some(now);
        self.command_stamp = f64::from(stamp.sec) + f64::from(stamp.nanosec) * 1e-9;
        self.stamp_used = false;
    }

    /// Counts a tick that started more than half a period late.
    pub fn count_late(&mut self) {
        self.late_ticks += 1;
    }

    /// One control tick at `now`: the arbiter's command for the latest
    /// state and command, or a hold.
    pub fn tick(&mut self, now: Instant) -> &ControlOutput {
        let began = Instant::now();
        self.ticks += 1;
        let period = self.settings.period();
        let fresh =
            |at: Option<Instant>, timeout: f64| at.is_some_and(|t| now.duration_since(t).as_secs_f64() <= timeout);
        let codes = self.settings.status_codes;
        let invalid = |status: TickStatus, (reason, joint): (usize, Option<usize>)| {
            (status_code(status, codes), reason, joint, Some(status))
        };
        // The reference: the last command continued, or the measurement
        // when there is no reference yet, when the robot did not follow,
        // or with velocity outputs (nothing is integrated there).
        let state_fresh = fresh(self.q_at, self.settings.joint_state_timeout);
        let deviation = match self.has_reference && self.state_valid {
            // NaN stays NaN (f64::max would drop it): a reference that is
            // not finite is re-anchored below.
            true => self
                .reference
                .iter()
                .zip(&self.q)
                .map(|(r, q)| (r - q).abs())
                .fold(0.0, |m: f64, d| if m.is_nan() || d.is_nan() { f64::NAN } else { m.max(d) }),
            false => f64::NAN,
        };
        if self.state_valid && state_fresh {
            let reanchor = self.continue_reference
                && self.has_reference
                && (deviation > self.reference_limit || deviation.is_nan());
            if reanchor || !self.continue_reference || !self.has_reference {
                self.reference.copy_from_slice(&self.q);
                self.has_reference = true;
                self.reanchors += u64::from(reanchor);
            }
        }
        let hold = if !state_fresh {
            Some((STATE_STALE, STATE_STALE_HOLD, None, None))
        } else if let Some(fault) = self.state_fault {
            Some(invalid(TickStatus::InvalidState, fault))
        } else if self.cloud_hold_after.is_some_and(|age| !fresh(self.cloud_at, age)) {
            Some((POINT_CLOUD_STALE, CLOUD_STALE_HOLD, None, None))
        } else if !fresh(self.command_at, self.settings.incoming_command_timeout) || self.kind == CommandKind::None {
            Some((COMMAND_STALE, COMMAND_STALE_HOLD, None, None))
        } else if let CommandKind::Invalid(reason, joint) = self.kind {
            Some(invalid(TickStatus::InvalidCommand, (reason, joint)))
        } else {
            None
        };
        // The gripper's pose at the reference, needed before the tick for
        // twists in its frame and for the diagnostics of a hold (NaN until
        // a valid state); a tick finds the position itself.
        let robot = self.arbiter.robot();
        let pose_first = hold.is_some() || self.kind == CommandKind::GripperTwist;
        let pose = match pose_first
            && self.has_reference
            && robot.forward_kinematics(&mut self.kinematics, &self.reference).is_ok()
        {
            true => robot.frame_pose(&self.kinematics, self.gripper),
            false => nalgebra::IsometryMatrix3::translation(f64::NAN, f64::NAN, f64::NAN),
        };
        let mut gripper: [f64; 3] = pose.translation.vector.into();
        let out = &mut self.out;
        out.command_stamp = f64::NAN;
        if let Some((code, reason, joint, status)) = hold {
            // The arbiter's braking step: a controlled stop within the
            // motion limits, then zero (and its next tick continues from it).
            let braking = self.arbiter.hold(&mut self.ws, &self.reference, status.unwrap_or(TickStatus::Halted));
            out.qdot.copy_from_slice(braking.qdot);
            out.code = code;
            out.status = status;
            out.hold_reason = Some(HOLDS[reason]);
            out.hold_joint = joint;
            out.diagnostics[16] = (reason + 1) as f64;
            out.diagnostics[17] = joint.map_or(f64::NAN, |j| j as f64);
            // No arbiter tick: nothing to say about distances or the solver.
            out.diagnostics[6..12].iter_mut().for_each(|v| *v = f64::NAN);
        } else {
            if !self.stamp_used {
                out.command_stamp = self.command_stamp;
                self.stamp_used = true;
            }
            let twist = match self.kind {
                CommandKind::GripperTwist => {
                    let r = pose.rotation;
                    let lin = r * nalgebra::Vector3::new(self.twist[0], self.twist[1], self.twist[2]);
                    let ang = r * nalgebra::Vector3::new(self.twist[3], self.twist[4], self.twist[5]);
                    [lin.x, lin.y, lin.z, ang.x, ang.y, ang.z]
                }
                _ => self.twist,
            };
            let linear = limit_speed([twist[0], twist[1], twist[2]], self.settings.max_speed);
            let twist6 = [linear[0], linear[1], linear[2], twist[3], twist[4], twist[5]];
            let command = match self.kind {
                CommandKind::Joint => HumanCommand::Joint(&self.joint),
                _ if self.settings.angular_commands => HumanCommand::Twist(&twist6),
                _ => HumanCommand::Linear(&twist6[..3]),
            };
            let input = TickInput { q: &self.reference, velocity: Some(&self.qdot_prev), command, beliefs: None };
            let result = self.arbiter.tick(&mut self.ws, &input);
            out.qdot.copy_from_slice(result.qdot);
            out.code = status_code(result.status, self.settings.status_codes);
            out.status = Some(result.status);
            out.hold_reason = None;
            out.hold_joint = None;
            out.diagnostics[16] = 0.0;
            out.diagnostics[17] = f64::NAN;
            let d = result.diagnostics;
            out.diagnostics[6] = d.min_distance;
            out.diagnostics[7] = d.rows as f64;
            out.diagnostics[8] = d.active_rows as f64;
            out.diagnostics[9] = f64::from(d.solves);
            out.diagnostics[10] = d.step_fraction;
            out.diagnostics[11] = d.confidence;
            gripper = self.ws.gripper_position();
        }
        for (((a, v), before), r) in
            out.accelerations.iter_mut().zip(&out.qdot).zip(&self.qdot_prev).zip(&mut self.reference)
        {
            *a = (v - before) / period;
            // The next point continues this one: consecutive positions
            // differ by exactly qdot × period (zero once held).
            *r += v * period;
        }
        out.positions.copy_from_slice(&self.reference);
        self.qdot_prev.copy_from_slice(&out.qdot);
        out.diagnostics[0] = began.elapsed().as_secs_f64() * 1e6;
        out.diagnostics[1] = out.command_stamp;
        out.diagnostics[2] = f64::from(out.code);
        out.diagnostics[3..6].copy_from_slice(&gripper);
        out.diagnostics[12] = ArbitrationMode::ALL.iter().position(|m| *m == self.ws.mode()).map_or(-1.0, |i| i as f64);
        out.diagnostics[13] = self.late_ticks as f64;
        out.diagnostics[14] = self.ticks as f64;
        out.diagnostics[15] = self.goal_updates as f64;
        out.diagnostics[18] = deviation;
        out.diagnostics[19] = self.reanchors as f64;
        out.diagnostics[20] = self.cloud_at.map_or(f64::NAN, |t| now.saturating_duration_since(t).as_secs_f64());
        &self.out
    }

    /// Whether a valid joint state has arrived (the node publishes no
    /// command before: positions would be made up).
    pub fn has_state(&self) -> bool {
        self.has_reference
    }
}

fn same_names(a: &[String], b: &[String]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x == y)
}
