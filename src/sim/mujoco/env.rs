//! MuJoCo under the arbitration-learning environment
//! ([`ArbitrationEnv`](crate::sim::ArbitrationEnv) with
//! [`ArbitrationEnvSettings::physics`](crate::sim::ArbitrationEnvSettings::physics)):
//! the agent's arbitrated command moves a simulated arm, and reaching the
//! grasp counts only once the box is lifted.

use super::arm::{GraspTicks, PhysicsArm, close_lift_hold, push_check};
use super::scene::PhysicsScene;
use super::{PhysicsError, lift_arbiter};
use crate::arbitration::{Arbiter, ArbiterWorkspace, HumanCommand, TickInput};
use crate::problem::Problem;
use crate::sim::{PhysicsSettings, Reason};
use mujoco_rs::prelude::*;
use std::sync::Arc;

/// One episode's world in MuJoCo, and what closes and lifts.
pub(crate) struct EnvPhysics {
    scene: PhysicsScene,
    lift: Arbiter,
    lift_ws: ArbiterWorkspace,
    arm: PhysicsArm,
    settings: PhysicsSettings,
}

impl EnvPhysics {
    /// `problem`'s world with the arm at rest at `start`; `arbiter` is the
    /// environment's (its period is the control period).
    ///
    /// # Errors
    /// Bad settings, MuJoCo refusing the scene, a problem without an object.
    pub(crate) fn new(
        problem: &Problem,
        arbiter: &Arbiter,
        settings: &PhysicsSettings,
        start: &[f64],
    ) -> Result<EnvPhysics, PhysicsError> {
        let scene = PhysicsScene::new(problem, arbiter.settings().period, settings)?;
        if scene.object_names().is_empty() {
            return Err(PhysicsError::NoObject { index: 0, count: 0 });
        }
        let lift = lift_arbiter(arbiter).map_err(|e| PhysicsError::Settings(e.to_string()))?;
        let lift_ws = lift.workspace();
        let mut arm = PhysicsArm::new(&scene, start.len());
        arm.start(&scene, start);
        Ok(EnvPhysics { scene, lift, lift_ws, arm, settings: *settings })
    }

    /// One control period executing `qdot` (rad/s or m/s); the measured
    /// configuration goes into `q`. `Some` when the robot touched an
    /// obstacle or pushed the box (the episode ends in a collision).
    pub(crate) fn step(&mut self, arbiter: &Arbiter, qdot: &[f64], q: &mut [f64]) -> Option<Reason> {
        let (scene, tolerance) = (&self.scene, self.settings.push_tolerance);
        self.arm.qdot_mut().copy_from_slice(qdot);
        let period = arbiter.settings().period;
        let ended = self
            .arm
            .advance(scene, arbiter.robot().limits(), period, false, |data| push_check(scene, data, 0, tolerance).1);
        q.copy_from_slice(self.arm.measured(scene));
        ended
    }

    /// Closes, lifts and holds from the current state (the gripper at the
    /// grasp, the arm last commanded through `ws`); `q` and `velocity`
    /// follow the arm. Success when the box stays lifted.
    ///
    /// # Errors
    /// Kinematics refusing a measured configuration.
    pub(crate) fn grasp(
        &mut self,
        arbiter: &Arbiter,
        ws: &ArbiterWorkspace,
        q: &mut [f64],
        velocity: &mut [f64],
    ) -> Result<Reason, PhysicsError> {
        self.lift.reset(&mut self.lift_ws);
        // The lift takes over mid-motion: it brakes from the last command.
        self.lift_ws.continue_motion(ws);
        let mut ticks = Follow { lift: &self.lift, ws: &mut self.lift_ws, q, velocity };
        let (limits, period) = (arbiter.robot().limits(), arbiter.settings().period);
        close_lift_hold(&mut self.arm, &self.scene, limits, period, &self.settings, 0, None, &mut ticks)
    }
}

/// The lift arbiter commanding from the environment's configuration.
struct Follow<'a> {
    lift: &'a Arbiter,
    ws: &'a mut ArbiterWorkspace,
    q: &'a mut [f64],
    velocity: &'a mut [f64],
}

impl GraspTicks for Follow<'_> {
    fn command(&mut self, twist: &[f64; 6], qdot: &mut [f64]) {
        let input =
            TickInput { q: self.q, velocity: Some(self.velocity), command: HumanCommand::Twist(twist), beliefs: None };
        qdot.copy_from_slice(self.lift.tick(self.ws, &input).qdot);
        self.velocity.copy_from_slice(qdot);
    }

    fn arrive(&mut self, q: &[f64], _: &MjData<Arc<MjModel>>) -> Result<(), PhysicsError> {
        self.q.copy_from_slice(q);
        Ok(())
    }
}
