//! A shared-control episode with MuJoCo physics under the arm: the same
//! arbiter, operators and judge as the kinematic simulator
//! ([`Episode`](crate::sim::Episode)), but the arm is a simulated robot and
//! the task ends only when the object is lifted (see
//! [`PhysicsSettings`] for the sequence and
//! the success criterion).
//!
//! Each control tick the arbiter blends the operator's command at the
//! *measured* joint positions; its joint velocities are integrated into the
//! servo targets at every physics step (a velocity interface on a
//! position-controlled arm). After every physics step the contacts are
//! read: the robot touching an obstacle is a collision, the object moving
//! more than 2 cm before the fingers close is a push.

use super::PhysicsError;
use super::arm::{GraspTicks, PhysicsArm, close_lift_hold, push_check};
use super::scene::PhysicsScene;
use crate::arbitration::{Arbiter, ArbiterWorkspace, HumanCommand};
use crate::sim::episode::{LiveEpisode, OperatorFeed};
use crate::sim::{
    EpisodeRecord, EpisodeSettings, Judge, Operator, OperatorAction, PhysicsSettings, REACH_TOLERANCE, Reason,
};
use mujoco_rs::prelude::*;
use std::sync::Arc;

/// One physics episode's setup.
#[derive(Clone, Copy)]
pub struct PhysicsEpisode<'a> {
    /// The world.
    pub scene: &'a PhysicsScene,
    /// The arbiter blending the operator's commands (the approach).
    pub arbiter: &'a Arbiter,
    /// The arbiter that closes, lifts and holds: the same robot in direct
    /// control of a gripper twist ([`lift_arbiter`]).
    pub lift: &'a Arbiter,
    /// The start configuration (rad or m).
    pub start: &'a [f64],
    /// The true goal's grasp point (m, world).
    pub target: [f64; 3],
    /// The true goal among the arbiter's goals.
    pub true_goal: usize,
    /// The object to lift, among the scene's objects.
    pub object: usize,
    /// Timeout of the approach (s) and recording.
    pub settings: EpisodeSettings,
    /// The grasp sequence and its thresholds.
    pub physics: PhysicsSettings,
}

/// The arbiter that lifts: `arbiter`'s robot and goals in direct control
/// (a gripper twist through the damped pseudo-inverse, joint limits only:
/// the held object would be an obstacle to the collision constraints).
///
/// # Errors
/// The arbiter refusing the settings.
pub fn lift_arbiter(arbiter: &Arbiter) -> Result<Arbiter, crate::arbitration::ArbitrationError> {
    let mut settings = *arbiter.settings();
    settings.mode = crate::arbitration::ArbitrationMode::DirectControl;
    settings.safety.collisions = false;
    arbiter.with_settings(settings)
}

/// Per-thread state of physics episodes: MuJoCo's data, the servo
/// targets, the lift arbiter's workspace.
pub struct PhysicsWorkspace {
    arm: PhysicsArm,
    lift: ArbiterWorkspace,
}

impl PhysicsWorkspace {
    /// A workspace for episodes in `scene` lifted by `lift`.
    pub fn new(scene: &PhysicsScene, lift: &Arbiter) -> PhysicsWorkspace {
        PhysicsWorkspace { arm: PhysicsArm::new(scene, lift.robot().nq()), lift: lift.workspace() }
    }
}

/// What a physics episode did.
#[derive(Debug, Clone)]
pub struct PhysicsRecord {
    /// The episode as the kinematic simulator records it (configurations
    /// measured; `object` holds the object's pose at each).
    pub record: EpisodeRecord,
    /// What the kinematic judge said when the fingers began to close
    /// (`None`: they never closed).
    pub kinematic: Option<Reason>,
    /// Where the gripper was when the fingers began to close (m, world).
    pub closed_at: Option<[f64; 3]>,
    /// How far the object moved before the fingers closed (m).
    pub pushed: f64,
    /// The first pair of the arbiter's (conservative) collision model the
    /// measured arm entered during the approach: the physical arm lags or
    /// overshoots the commanded one, and the box may have moved.
    pub model_contact: Option<[String; 2]>,
    /// The object's rise at the end (m).
    pub lifted: f64,
    /// Physics steps run.
    pub physics_steps: usize,
    /// Wall-clock time inside MuJoCo's steps (s).
    pub physics_seconds: f64,
    /// The largest |servo target − measured position| of an arm joint over
    /// the episode's physics steps (rad or m): the servo targets integrate
    /// the commanded joint velocities, so this is how far the physical arm
    /// lagged the commanded motion.
    pub tracking_error: f64,
}

impl PhysicsEpisode<'_> {
    /// Runs the episode with `operator`; `judge` decides when the gripper
    /// is in position (as in the kinematic simulator) and what it would
    /// have said (recorded as [`PhysicsRecord::kinematic`]); physics
    /// decides the outcome.
    ///
    /// # Errors
    /// A bad start configuration, an object index the scene does not have;
    /// kinematics failing on a measured configuration.
    pub fn run(
        &self,
        ws: &mut ArbiterWorkspace,
        pw: &mut PhysicsWorkspace,
        operator: &mut dyn Operator,
        judge: &mut dyn Judge,
    ) -> Result<PhysicsRecord, PhysicsError> {
        let (scene, arbiter, p) = (self.scene, self.arbiter, &self.physics);
        let count = scene.object_names().len();
        if self.object >= count {
            return Err(PhysicsError::NoObject { index: self.object, count });
        }
        let dt = arbiter.settings().period;
        let approach_ticks = (self.settings.max_time / dt).ceil() as usize;
        let limits = arbiter.robot().limits();
        let mut live = LiveEpisode::new(arbiter, ws, self.start, self.settings.record)?;
        let arm = &mut pw.arm;
        arm.start(scene, self.start);
        let keep = self.settings.record;
        let mut object_path = vec![];
        if keep {
            object_path.push(scene.object_pose(arm.data(), self.object));
        }
        arbiter.reset(&mut pw.lift);
        let mut feed = OperatorFeed::new(arbiter, self.true_goal, operator.needs_policy());
        let (mut kinematic, mut ending, mut closed_at, mut pushed) = (None, None, None, 0.0_f64);
        let mut command = [0.0; 6];
        for tick in 0..approach_ticks {
            if let Some(reason) = self.approach(&mut live, &mut feed, operator, judge, tick, &mut command) {
                kinematic = Some(reason);
                closed_at = Some(live.gripper());
                break;
            }
            arm.qdot_mut().copy_from_slice(live.command(arbiter, ws, HumanCommand::Linear(&command[..3])));
            ending = arm.advance(scene, limits, dt, false, |data| {
                let (moved, push) = push_check(scene, data, self.object, p.push_tolerance);
                pushed = pushed.max(moved);
                push
            });
            let mut sink = Recorder {
                live: &mut live,
                arbiter,
                lift: None,
                scene,
                object: self.object,
                keep,
                path: &mut object_path,
            };
            let (q, data) = arm.measured_with_data(scene);
            sink.arrive(q, data)?;
            if ending.is_some() {
                break;
            }
        }
        let hard_violations = live.record().hard_violations;
        let reason = match (ending, &kinematic) {
            (Some(reason), _) => reason,
            (None, None) => live.reason(crate::sim::Outcome::Timeout, self.target),
            (None, Some(verdict)) => {
                // The lift takes over mid-motion: it brakes from the last command.
                pw.lift.continue_motion(ws);
                let mut sink = Recorder {
                    live: &mut live,
                    arbiter,
                    lift: Some((self.lift, &mut pw.lift)),
                    scene,
                    object: self.object,
                    keep,
                    path: &mut object_path,
                };
                close_lift_hold(arm, scene, limits, dt, p, self.object, Some(verdict), &mut sink)?
            }
        };
        let lifted = scene.object_pose(arm.data(), self.object)[2] - scene.object_start(self.object)[2];
        let model_contact = if hard_violations > 0 { live.first_contact().cloned() } else { None };
        let mut record = live.finish(reason, dt);
        record.hard_violations = hard_violations;
        record.object = object_path;
        Ok(PhysicsRecord {
            record,
            kinematic,
            closed_at,
            pushed,
            model_contact,
            lifted,
            physics_steps: arm.steps,
            physics_seconds: arm.seconds,
            tracking_error: arm.tracking_error,
        })
    }

    /// One approach tick's decision: `Some(judge's verdict)` when the
    /// gripper is in position (the judge agrees, or the operator stops),
    /// else the operator's command in `command`.
    fn approach(
        &self,
        live: &mut LiveEpisode,
        feed: &mut OperatorFeed,
        operator: &mut dyn Operator,
        judge: &mut dyn Judge,
        tick: usize,
        command: &mut [f64; 6],
    ) -> Option<Reason> {
        // The kinematic judge agrees as soon as the pads' (conservative)
        // spheres straddle the object, often a centimetre above the grasp
        // point, where the real pads overlap the box by a few millimetres:
        // the fingers close there only once the gripper is at the grasp point.
        let at_grasp = crate::sim::operator::distance(live.gripper(), self.target) <= REACH_TOLERANCE;
        if at_grasp && judge.succeeded(live.q()) {
            return Some(Reason::Success);
        }
        let time = tick as f64 * self.arbiter.settings().period;
        match feed.act(operator, live, self.target, time) {
            OperatorAction::Done => Some(judge.diagnose(live.q(), live.gripper(), self.target)),
            OperatorAction::Move(v) => {
                *command = [v[0], v[1], v[2], 0.0, 0.0, 0.0];
                None
            }
        }
    }
}

/// Records the ticks of a physics episode in its [`LiveEpisode`]: the
/// measured configurations and the object's pose; while the grasp closes
/// and lifts, the lift arbiter commands.
struct Recorder<'a, 'w> {
    live: &'a mut LiveEpisode,
    arbiter: &'a Arbiter,
    lift: Option<(&'a Arbiter, &'w mut ArbiterWorkspace)>,
    scene: &'a PhysicsScene,
    object: usize,
    keep: bool,
    path: &'a mut Vec<[f64; 7]>,
}

impl GraspTicks for Recorder<'_, '_> {
    fn command(&mut self, twist: &[f64; 6], qdot: &mut [f64]) {
        match self.lift.as_mut() {
            Some((lift, ws)) => qdot.copy_from_slice(self.live.command(lift, ws, HumanCommand::Twist(twist))),
            None => qdot.fill(0.0),
        }
    }

    fn arrive(&mut self, q: &[f64], data: &MjData<Arc<MjModel>>) -> Result<(), PhysicsError> {
        self.live.arrive(self.arbiter, q)?;
        if self.keep {
            self.path.push(self.scene.object_pose(data, self.object));
        }
        Ok(())
    }
}
