//! A shared-control episode with MuJoCo physics under the arm: the same
//! arbiter, operators and judge as the kinematic simulator
//! ([`Episode`](crate::sim::Episode)), but the arm is a simulated robot and
//! the task ends only when the object is lifted (see
//! [`PhysicsSettings`](crate::sim::PhysicsSettings) for the sequence and
//! the success criterion).
//!
//! Each control tick the arbiter blends the operator's command at the
//! *measured* joint positions; its joint velocities are integrated into the
//! servo targets at every physics step (a velocity interface on a
//! position-controlled arm). After every physics step the contacts are
//! read: the robot touching an obstacle is a collision, the object moving
//! more than 2 cm before the fingers close is a push.

use super::PhysicsError;
use super::scene::{GeomRole, PhysicsScene};
use crate::arbitration::{Arbiter, ArbiterWorkspace, HumanCommand};
use crate::robot::RobotError;
use crate::sim::episode::{LiveEpisode, OperatorFeed};
use crate::sim::{
    EpisodeRecord, EpisodeSettings, Judge, Operator, OperatorAction, PhysicsSettings, REACH_TOLERANCE, Reason,
};
use mujoco_rs::prelude::*;
use std::sync::Arc;
use std::time::Instant;

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

/// Per-thread state of physics episodes: MuJoCo's data, the lift arbiter's
/// workspace, the servo targets.
pub struct PhysicsWorkspace {
    data: MjData<Arc<MjModel>>,
    lift: ArbiterWorkspace,
    measured: Vec<f64>,
    target: Vec<f64>,
    qdot: Vec<f64>,
}

impl PhysicsWorkspace {
    /// A workspace for episodes in `scene` lifted by `lift`.
    pub fn new(scene: &PhysicsScene, lift: &Arbiter) -> PhysicsWorkspace {
        let n = lift.robot().nq();
        PhysicsWorkspace {
            data: scene.data(),
            lift: lift.workspace(),
            measured: vec![0.0; n],
            target: vec![0.0; n],
            qdot: vec![0.0; n],
        }
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
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Approach,
    Close,
    Lift,
    Hold,
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
        let h = scene.timestep();
        let substeps = (dt / h).round().max(1.0) as usize;
        let ticks = |seconds: f64| (seconds / dt).ceil() as usize;
        let (approach_ticks, close_ticks) = (ticks(self.settings.max_time), ticks(p.close_time));
        let (lift_ticks, hold_ticks) = (ticks(p.lift_height / p.lift_speed), ticks(p.hold_time));
        let limits = arbiter.robot().limits();
        let mut live = LiveEpisode::new(arbiter, ws, self.start, self.settings.record)?;
        scene.reset(&mut pw.data, self.start);
        let origin = scene.object_start(self.object);
        let keep = self.settings.record;
        let mut object_path = vec![];
        if keep {
            object_path.push(scene.object_pose(&pw.data, self.object));
        }
        arbiter.reset(&mut pw.lift);
        pw.target.copy_from_slice(self.start);
        let mut feed = OperatorFeed::new(arbiter, self.true_goal, operator.needs_policy());
        let (mut phase, mut phase_tick) = (Phase::Approach, 0usize);
        let (mut kinematic, mut ending, mut closed_at) = (None, None, None);
        let (mut pushed, mut lowest_hold, mut rise) = (0.0_f64, f64::INFINITY, 0.0);
        let (mut steps, mut physics_seconds, mut hard_violations) = (0usize, 0.0, 0usize);
        let mut command = [0.0; 6];
        for tick in 0.. {
            if phase == Phase::Approach {
                match self.approach(&mut live, &mut feed, operator, judge, tick, &mut command) {
                    Some(reason) => {
                        kinematic = Some(reason);
                        closed_at = Some(live.gripper());
                        hard_violations = live.record().hard_violations;
                        (phase, phase_tick) = (Phase::Close, 0);
                    }
                    None => {
                        pw.qdot.copy_from_slice(live.command(arbiter, ws, HumanCommand::Linear(&command[..3])));
                        ending = self.advance(
                            pw,
                            substeps,
                            h,
                            limits,
                            false,
                            &mut steps,
                            &mut physics_seconds,
                            |scene, data| {
                                let moved = distance(&scene.object_pose(data, self.object), &origin);
                                pushed = pushed.max(moved);
                                (moved > p.push_tolerance).then_some(Reason::Pushed { distance: moved })
                            },
                        );
                        self.arrive(&mut live, pw, keep, &mut object_path)?;
                        if ending.is_none() && tick + 1 >= approach_ticks {
                            ending = Some(live.reason(crate::sim::Outcome::Timeout, self.target));
                        }
                        if ending.is_some() {
                            break;
                        }
                        continue;
                    }
                }
            }
            command = [0.0; 6];
            if phase == Phase::Lift {
                command[2] = p.lift_speed;
            }
            pw.qdot.copy_from_slice(live.command(self.lift, &mut pw.lift, HumanCommand::Twist(&command)));
            let hold = phase == Phase::Hold;
            let z0 = origin[2];
            ending = self.advance(pw, substeps, h, limits, true, &mut steps, &mut physics_seconds, |scene, data| {
                if hold {
                    lowest_hold = lowest_hold.min(scene.object_pose(data, self.object)[2] - z0);
                }
                None
            });
            self.arrive(&mut live, pw, keep, &mut object_path)?;
            rise = scene.object_pose(&pw.data, self.object)[2] - origin[2];
            if ending.is_some() {
                break;
            }
            phase_tick += 1;
            match phase {
                Phase::Close if phase_tick >= close_ticks => {
                    // Fingers closed on nothing: the operator stopped where
                    // no grasp was, and the kinematic judge says why.
                    if !touches_object(scene, &pw.data, self.object) {
                        ending = Some(match kinematic.clone() {
                            Some(reason) if reason != Reason::Success => reason,
                            _ => Reason::Slipped { lifted: rise },
                        });
                        break;
                    }
                    (phase, phase_tick) = (Phase::Lift, 0);
                }
                Phase::Lift if phase_tick >= lift_ticks => {
                    if rise < p.lifted {
                        ending = Some(Reason::Slipped { lifted: rise });
                        break;
                    }
                    (phase, phase_tick) = (Phase::Hold, 0);
                }
                Phase::Hold if phase_tick >= hold_ticks => {
                    ending =
                        Some(if lowest_hold >= p.lifted { Reason::Success } else { Reason::Dropped { lifted: rise } });
                    break;
                }
                _ => {}
            }
        }
        let reason = ending.unwrap_or(Reason::Timeout { distance: f64::NAN });
        if phase == Phase::Approach {
            hard_violations = live.record().hard_violations;
        }
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
            lifted: rise,
            physics_steps: steps,
            physics_seconds,
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

    /// Runs one control period of physics: the servo targets integrate
    /// `pw.qdot` (within the joint limits) at each step; after each step
    /// the robot's contacts with obstacles end the episode, and `check`
    /// may.
    #[allow(clippy::too_many_arguments)]
    fn advance(
        &self,
        pw: &mut PhysicsWorkspace,
        substeps: usize,
        h: f64,
        limits: &[crate::robot::JointLimits],
        closed: bool,
        steps: &mut usize,
        seconds: &mut f64,
        mut check: impl FnMut(&PhysicsScene, &MjData<Arc<MjModel>>) -> Option<Reason>,
    ) -> Option<Reason> {
        let scene = self.scene;
        for _ in 0..substeps {
            for ((t, v), l) in pw.target.iter_mut().zip(&pw.qdot).zip(limits) {
                *t = (*t + h * v).clamp(l.lower, l.upper);
            }
            scene.set_targets(&mut pw.data, &pw.target, Some(&pw.qdot), closed);
            let began = Instant::now();
            pw.data.step();
            *seconds += began.elapsed().as_secs_f64();
            *steps += 1;
            if let Some(reason) = robot_collision(scene, &pw.data).or_else(|| check(scene, &pw.data)) {
                return Some(reason);
            }
        }
        None
    }

    /// Ends a tick at the measured configuration.
    fn arrive(
        &self,
        live: &mut LiveEpisode,
        pw: &mut PhysicsWorkspace,
        keep: bool,
        object_path: &mut Vec<[f64; 7]>,
    ) -> Result<(), RobotError> {
        self.scene.arm_positions(&pw.data, &mut pw.measured);
        live.arrive(self.arbiter, &pw.measured)?;
        if keep {
            object_path.push(self.scene.object_pose(&pw.data, self.object));
        }
        Ok(())
    }
}

/// The first contact of the robot with an obstacle, as a collision.
fn robot_collision(scene: &PhysicsScene, data: &MjData<Arc<MjModel>>) -> Option<Reason> {
    data.contact().iter().find_map(|c| {
        let (a, b) = (c.geom[0] as usize, c.geom[1] as usize);
        match (scene.role(a), scene.role(b)) {
            (GeomRole::Robot, GeomRole::Obstacle) => Some((a, b)),
            (GeomRole::Obstacle, GeomRole::Robot) => Some((b, a)),
            _ => None,
        }
        .map(|(robot, other)| Reason::Collision { pair: [scene.geom_label(robot), scene.geom_label(other)] })
    })
}

/// Whether the robot touches object `k`.
fn touches_object(scene: &PhysicsScene, data: &MjData<Arc<MjModel>>, k: usize) -> bool {
    data.contact().iter().any(|c| {
        let roles = (scene.role(c.geom[0] as usize), scene.role(c.geom[1] as usize));
        roles == (GeomRole::Robot, GeomRole::Object(k)) || roles == (GeomRole::Object(k), GeomRole::Robot)
    })
}

/// Distance between the positions of two poses (m).
fn distance(a: &[f64; 7], b: &[f64; 7]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
