//! The physical arm every physics episode drives: MuJoCo's state, the
//! servo targets the arbiter's joint velocities are integrated into, the
//! contact checks after each physics step, and the grasp's end — close,
//! lift, hold — shared by [`PhysicsEpisode`](super::PhysicsEpisode) and the
//! Gymnasium environment's physics variant.

use super::PhysicsError;
use super::scene::{GeomRole, PhysicsScene};
use crate::robot::JointLimits;
use crate::sim::{PhysicsSettings, Reason};
use mujoco_rs::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// MuJoCo's state of one episode and the servo targets (per thread).
pub(crate) struct PhysicsArm {
    data: MjData<Arc<MjModel>>,
    measured: Vec<f64>,
    target: Vec<f64>,
    qdot: Vec<f64>,
    /// Physics steps run and the wall-clock time inside them (s).
    pub(crate) steps: usize,
    pub(crate) seconds: f64,
    /// The largest |servo target − measured position| of an arm joint
    /// after any physics step since the start (rad or m): how closely the
    /// physical arm tracks the commanded motion.
    pub(crate) tracking_error: f64,
}

impl PhysicsArm {
    /// An arm of `n` joints in `scene`.
    pub(crate) fn new(scene: &PhysicsScene, n: usize) -> PhysicsArm {
        PhysicsArm {
            data: scene.data(),
            measured: vec![0.0; n],
            target: vec![0.0; n],
            qdot: vec![0.0; n],
            steps: 0,
            seconds: 0.0,
            tracking_error: 0.0,
        }
    }

    /// The world in its start state, the arm at rest at `q`.
    pub(crate) fn start(&mut self, scene: &PhysicsScene, q: &[f64]) {
        scene.reset(&mut self.data, q);
        self.target.copy_from_slice(q);
        self.qdot.fill(0.0);
        (self.steps, self.seconds, self.tracking_error) = (0, 0.0, 0.0);
    }

    /// MuJoCo's state.
    pub(crate) fn data(&self) -> &MjData<Arc<MjModel>> {
        &self.data
    }

    /// The joint velocity the next [`Self::advance`] executes (rad/s or m/s).
    pub(crate) fn qdot_mut(&mut self) -> &mut [f64] {
        &mut self.qdot
    }

    /// The arm's measured joint positions (rad or m).
    pub(crate) fn measured(&mut self, scene: &PhysicsScene) -> &[f64] {
        scene.arm_positions(&self.data, &mut self.measured);
        &self.measured
    }

    /// The measured joint positions, as [`measured`](Self::measured), and
    /// the simulation state, borrowed together (for [`GraspTicks::arrive`]).
    pub(crate) fn measured_with_data(&mut self, scene: &PhysicsScene) -> (&[f64], &MjData<Arc<MjModel>>) {
        scene.arm_positions(&self.data, &mut self.measured);
        (&self.measured, &self.data)
    }

    /// One control period of `period` s: the servo targets integrate the
    /// joint velocity (within the joint limits) at each physics step, the
    /// fingers open or `closed`; after each step the robot touching an
    /// obstacle ends the period as a collision, and `check` may end it.
    pub(crate) fn advance(
        &mut self,
        scene: &PhysicsScene,
        limits: &[JointLimits],
        period: f64,
        closed: bool,
        mut check: impl FnMut(&MjData<Arc<MjModel>>) -> Option<Reason>,
    ) -> Option<Reason> {
        let h = scene.timestep();
        for _ in 0..(period / h).round().max(1.0) as usize {
            for ((t, v), l) in self.target.iter_mut().zip(&self.qdot).zip(limits) {
                *t = (*t + h * v).clamp(l.lower, l.upper);
            }
            scene.set_targets(&mut self.data, &self.target, Some(&self.qdot), closed);
            let began = Instant::now();
            self.data.step();
            self.seconds += began.elapsed().as_secs_f64();
            self.steps += 1;
            scene.arm_positions(&self.data, &mut self.measured);
            for (t, q) in self.target.iter().zip(&self.measured) {
                // NaN (a diverged simulation) stays NaN.
                let e = (t - q).abs();
                self.tracking_error =
                    if e.is_nan() || self.tracking_error.is_nan() { f64::NAN } else { self.tracking_error.max(e) };
            }
            if let Some(reason) = robot_collision(scene, &self.data).or_else(|| check(&self.data)) {
                return Some(reason);
            }
        }
        None
    }
}

/// Who commands the arm while it closes, lifts and holds: the joint
/// velocity for a gripper twist, and where the arm got to after each tick.
pub(crate) trait GraspTicks {
    /// Writes into `qdot` the joint velocity (rad/s or m/s) for the gripper
    /// `twist` (m/s and rad/s, world) at the arm's current configuration.
    fn command(&mut self, twist: &[f64; 6], qdot: &mut [f64]);

    /// The arm is at `q` a control period later; `data` is the world then.
    ///
    /// # Errors
    /// Whatever recording the tick needs failing.
    fn arrive(&mut self, q: &[f64], data: &MjData<Arc<MjModel>>) -> Result<(), PhysicsError>;
}

/// The end of a grasp whose gripper is in position: the fingers close for
/// `p.close_time`, the arm lifts `p.lift_height` and holds `p.hold_time`.
/// Returns why the episode ended: success (object `k` at least `p.lifted`
/// above its start through the hold), `dropped`, `slipped`, a collision,
/// or — when the fingers closed on nothing — `kinematic`, the kinematic
/// judge's verdict when closing began (if it was not a success).
///
/// # Errors
/// `ticks` failing.
#[allow(clippy::too_many_arguments)]
pub(crate) fn close_lift_hold(
    arm: &mut PhysicsArm,
    scene: &PhysicsScene,
    limits: &[JointLimits],
    period: f64,
    p: &PhysicsSettings,
    k: usize,
    kinematic: Option<&Reason>,
    ticks: &mut dyn GraspTicks,
) -> Result<Reason, PhysicsError> {
    let count = |seconds: f64| (seconds / period).ceil() as usize;
    let z0 = scene.object_start(k)[2];
    let rise = |data: &MjData<Arc<MjModel>>| scene.object_pose(data, k)[2] - z0;
    let mut lowest = f64::INFINITY;
    let phases =
        [(count(p.close_time), 0.0), (count(p.lift_height / p.lift_speed), p.lift_speed), (count(p.hold_time), 0.0)];
    for (phase, &(ticks_in_phase, speed)) in phases.iter().enumerate() {
        let hold = phase == 2;
        for _ in 0..ticks_in_phase {
            ticks.command(&[0.0, 0.0, speed, 0.0, 0.0, 0.0], arm.qdot_mut());
            let ended = arm.advance(scene, limits, period, true, |data| {
                if hold {
                    lowest = lowest.min(rise(data));
                }
                None
            });
            let (q, data) = arm.measured_with_data(scene);
            ticks.arrive(q, data)?;
            if let Some(reason) = ended {
                return Ok(reason);
            }
        }
        let up = rise(arm.data());
        match phase {
            // Fingers closed on nothing: the operator stopped where no
            // grasp was, and the kinematic judge says why.
            0 if !touches_object(scene, arm.data(), k) => {
                return Ok(match kinematic {
                    Some(reason) if *reason != Reason::Success => reason.clone(),
                    _ => Reason::Slipped { lifted: up, needed: p.lifted },
                });
            }
            1 if up < p.lifted => return Ok(Reason::Slipped { lifted: up, needed: p.lifted }),
            2 => {
                return Ok(if lowest >= p.lifted {
                    Reason::Success
                } else {
                    Reason::Dropped { lifted: up, needed: p.lifted }
                });
            }
            _ => {}
        }
    }
    Ok(Reason::Success)
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

/// How far object `k` has moved from its start (m), and a push when that
/// is more than `tolerance`.
pub(crate) fn push_check(
    scene: &PhysicsScene,
    data: &MjData<Arc<MjModel>>,
    k: usize,
    tolerance: f64,
) -> (f64, Option<Reason>) {
    let (a, b) = (scene.object_pose(data, k), scene.object_start(k));
    let moved = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    (moved, (moved > tolerance).then_some(Reason::Pushed { distance: moved, limit: tolerance }))
}
