//! The [`Arbiter`] (immutable, shared) and the order of a tick's stages
//! over its [`ArbiterWorkspace`] (see [`workspace`](super::workspace)):
//! inputs validated and kinematics, beliefs, robot actions, the mode's
//! metric and objective, the hard-constraint rows, the solve (a solver
//! only when the closed form breaks a row), the certified step, and a
//! command with a status.

use super::ArbitrationError;
use super::command::{Command, Diagnostics, HumanCommand, TickInput, TickStatus};
use super::learned::{ArbitrationPolicy, StateLayout};
use super::modes::ArbitrationMode;
use super::settings::ArbiterSettings;
use super::workspace::ArbiterWorkspace;
use crate::collision::CollisionModel;
use crate::control::RobotPolicy;
use crate::robot::{FrameId, ReferenceFrame, RobotModel};
use std::sync::Arc;

/// One goal the operator may be heading for: a name, a point in the world
/// the intent estimator compares the gripper path with (m), and the robot
/// policy that reaches it.
#[derive(Debug, Clone)]
pub struct ArbiterGoal {
    /// Its name.
    pub name: String,
    /// A world point (m).
    pub position: [f64; 3],
    /// The robot policy that reaches it.
    pub policy: Arc<dyn RobotPolicy>,
}

/// Shared control every tick: the robot, its collision model, the goals
/// with their policies, and the settings. Immutable and `Send + Sync`; each
/// control loop owns an [`ArbiterWorkspace`].
#[derive(Debug)]
pub struct Arbiter {
    pub(crate) robot: Arc<RobotModel>,
    pub(crate) collision: Arc<CollisionModel>,
    pub(crate) gripper: FrameId,
    pub(crate) goals: Vec<ArbiterGoal>,
    pub(crate) settings: ArbiterSettings,
    /// The policy of [`ArbitrationMode::Learned`].
    pub(crate) learned: Option<Arc<dyn ArbitrationPolicy>>,
}

/// Distance rows beyond the bounds the solver may take per tick.
pub(crate) const MAX_SOLVER_ROWS: usize = 64;

impl Arbiter {
    /// An arbiter for the robot of `collision`, the gripper frame `gripper`
    /// (task commands and intent refer to it) and `goals`.
    ///
    /// # Errors
    /// An unknown gripper frame, a goal policy for another number of
    /// joints, a non-finite goal position, invalid settings.
    pub fn new(
        collision: Arc<CollisionModel>,
        gripper: &str,
        goals: Vec<ArbiterGoal>,
        settings: ArbiterSettings,
    ) -> Result<Arbiter, ArbitrationError> {
        let robot = collision.robot().clone();
        let gripper = robot.frame_id(gripper)?;
        for goal in &goals {
            if goal.policy.dof() != robot.nq() {
                return Err(ArbitrationError::PolicyDof {
                    goal: goal.name.clone(),
                    expected: robot.nq(),
                    got: goal.policy.dof(),
                });
            }
            if goal.position.iter().any(|x| !x.is_finite()) {
                return Err(ArbitrationError::GoalPosition { goal: goal.name.clone() });
            }
        }
        settings.validate()?;
        if settings.mode == ArbitrationMode::Learned {
            return Err(ArbitrationError::NoArbitrationPolicy);
        }
        Ok(Arbiter { robot, collision, gripper, goals, settings, learned: None })
    }

    /// The same robot, collision model and goals with other settings
    /// (cheap: shares them).
    ///
    /// # Errors
    /// Invalid settings.
    pub fn with_settings(&self, settings: ArbiterSettings) -> Result<Arbiter, ArbitrationError> {
        settings.validate()?;
        if settings.mode == ArbitrationMode::Learned && self.learned.is_none() {
            return Err(ArbitrationError::NoArbitrationPolicy);
        }
        Ok(Arbiter {
            robot: self.robot.clone(),
            collision: self.collision.clone(),
            gripper: self.gripper,
            goals: self.goals.clone(),
            settings,
            learned: self.learned.clone(),
        })
    }

    /// The same arbiter with `policy` as the policy of
    /// [`ArbitrationMode::Learned`] (cheap: shares the rest).
    ///
    /// # Errors
    /// A policy whose [`StateLayout`] has another number of goals or
    /// other task dimensions than [`Self::task_dims`], or an invalid layout.
    pub fn with_arbitration_policy(&self, policy: Arc<dyn ArbitrationPolicy>) -> Result<Arbiter, ArbitrationError> {
        let layout = policy.layout();
        let expected_task_dims = self.task_dims();
        if layout.goals != self.goals.len() || !layout.is_valid() || layout.task_dims != expected_task_dims {
            return Err(ArbitrationError::PolicyLayout {
                expected_goals: self.goals.len(),
                expected_task_dims,
                goals: layout.goals,
                task_dims: layout.task_dims,
            });
        }
        Ok(Arbiter {
            robot: self.robot.clone(),
            collision: self.collision.clone(),
            gripper: self.gripper,
            goals: self.goals.clone(),
            settings: self.settings,
            learned: Some(policy),
        })
    }

    /// The task dimensions the gripper moves in: 2 when no joint moves it
    /// along the world's z axis (a planar robot: an arbitration policy
    /// trained on the x–y plane), else 3. Read from the gripper's Jacobian
    /// at the middle of the joint limits and two configurations beside it.
    pub fn task_dims(&self) -> usize {
        let robot = &self.robot;
        let mut ws = crate::robot::KinematicsWorkspace::new(robot);
        let mut jacobian = nalgebra::Matrix6xX::zeros(robot.nq());
        let middle: Vec<f64> = robot.limits().iter().map(|l| 0.5 * (l.lower + l.upper)).collect();
        for offset in [0.0, 0.3, -0.2] {
            let q: Vec<f64> = middle
                .iter()
                .zip(robot.limits())
                .map(|(m, l)| (m + offset * (l.upper - l.lower)).clamp(l.lower, l.upper))
                .collect();
            let moves_in_z = robot.forward_kinematics(&mut ws, &q).is_ok()
                && robot.frame_jacobian(&ws, self.gripper, ReferenceFrame::WorldAligned, &mut jacobian).is_ok()
                && (0..robot.nq()).any(|k| jacobian[(2, k)].abs() > 1e-9);
            if moves_in_z {
                return 3;
            }
        }
        2
    }

    /// The policy of [`ArbitrationMode::Learned`], if any.
    pub fn arbitration_policy(&self) -> Option<&Arc<dyn ArbitrationPolicy>> {
        self.learned.as_ref()
    }

    /// The settings.
    pub fn settings(&self) -> &ArbiterSettings {
        &self.settings
    }

    /// The goals.
    pub fn goals(&self) -> &[ArbiterGoal] {
        &self.goals
    }

    /// The robot.
    pub fn robot(&self) -> &Arc<RobotModel> {
        &self.robot
    }

    /// The gripper frame task commands and intent refer to.
    pub fn gripper_frame(&self) -> FrameId {
        self.gripper
    }

    /// The collision model the hard constraints use.
    pub fn collision_model(&self) -> &Arc<CollisionModel> {
        &self.collision
    }

    /// Starts a new episode: forgets the observed path and the policies' progress.
    pub fn reset(&self, ws: &mut ArbiterWorkspace) {
        ws.intent.estimator.reset();
        ws.intent.beliefs.copy_from_slice(ws.intent.estimator.beliefs());
        for (goal, state) in self.goals.iter().zip(&mut ws.robot.states) {
            goal.policy.reset(state);
        }
    }

    /// One control tick: the joint velocity to execute for one period, a
    /// status and diagnostics. Never panics; allocates nothing.
    pub fn tick<'w>(&self, ws: &'w mut ArbiterWorkspace, input: &TickInput<'_>) -> Command<'w> {
        begin_tick(ws);
        let result = self.run(ws, input);
        emit(ws, result)
    }

    /// The first half of a tick for an external arbitration policy (a
    /// learner, a Gymnasium environment): validates `input`, updates the
    /// beliefs, queries the robot policies and returns the arbitration
    /// state in `layout` (see [`StateLayout`]). Follow it with
    /// [`Arbiter::act_observed`] for the same `input`. Allocates nothing.
    ///
    /// # Errors
    /// The status a tick would hold with: invalid inputs, a failed robot
    /// policy, a non-finite state, or a `layout` for another number of goals.
    pub fn observe<'w>(
        &self,
        ws: &'w mut ArbiterWorkspace,
        input: &TickInput<'_>,
        layout: &StateLayout,
    ) -> Result<&'w [f64], TickStatus> {
        begin_tick(ws);
        ws.learned.observed = false;
        if layout.goals != self.goals.len() || !layout.is_valid() || layout.width() > ws.learned.state.len() {
            return Err(TickStatus::InvalidBeliefs);
        }
        let (_, policy_failed) = self.prepare(ws, input)?;
        if policy_failed {
            return Err(TickStatus::PolicyFailed);
        }
        if !self.fill_state(ws, input.q, layout, &input.command) {
            return Err(TickStatus::InvalidState);
        }
        ws.learned.observed = true;
        Ok(&ws.learned.state[..layout.width()])
    }

    /// The second half: executes `command` (the arbitrated gripper
    /// velocity, m/s, world axes; 2 values for a planar layout, z = 0) under
    /// the hard constraints at the configuration of the last
    /// [`Arbiter::observe`], which must have succeeded for this `input`
    /// (else the tick holds with [`TickStatus::InvalidState`]).
    pub fn act_observed<'w>(
        &self,
        ws: &'w mut ArbiterWorkspace,
        input: &TickInput<'_>,
        command: &[f64],
    ) -> Command<'w> {
        let mut linear = [0.0; 3];
        let result = if !ws.learned.observed || command.len() > 3 || command.iter().any(|c| !c.is_finite()) {
            Err(if ws.learned.observed { TickStatus::InvalidCommand } else { TickStatus::InvalidState })
        } else {
            linear[..command.len()].copy_from_slice(command);
            self.finish(ws, input.q, ArbitrationMode::DirectControl, &HumanCommand::Linear(&linear), false)
        };
        ws.learned.observed = false;
        if result.is_err() {
            ws.solve.u.fill(0.0);
        }
        emit(ws, result)
    }

    fn run(&self, ws: &mut ArbiterWorkspace, input: &TickInput<'_>) -> Result<TickStatus, TickStatus> {
        let (mut mode, mut policy_failed) = self.prepare(ws, input)?;
        let mut learned = [0.0; 3];
        if mode == ArbitrationMode::Learned && !policy_failed {
            match self.learned_command(ws, input) {
                Some(command) => learned = command,
                None => policy_failed = true,
            }
        }
        if policy_failed {
            mode = ArbitrationMode::DirectControl;
        }
        match mode {
            // The learned command is executed as the operator's would be under direct control.
            ArbitrationMode::Learned => {
                self.finish(ws, input.q, ArbitrationMode::DirectControl, &HumanCommand::Linear(&learned), false)
            }
            _ => self.finish(ws, input.q, mode, &input.command, policy_failed),
        }
    }

    /// The first half of a tick: inputs validated, kinematics, beliefs,
    /// robot actions and the mode's metric. Returns the mode to run and
    /// whether a policy failed (the tick then falls back to direct control).
    fn prepare(&self, ws: &mut ArbiterWorkspace, input: &TickInput<'_>) -> Result<(ArbitrationMode, bool), TickStatus> {
        self.validate(ws, input)?;
        // Validated above: FK and the Jacobian cannot fail.
        let _ = self.robot.forward_kinematics(&mut ws.input.kin, input.q);
        let pose = self
            .robot
            .frame_jacobian(&ws.input.kin, self.gripper, ReferenceFrame::WorldAligned, &mut ws.input.jac)
            .map_err(|_| TickStatus::InvalidState)?;
        ws.input.gripper_position = pose.translation.vector.into();
        self.update_beliefs(ws, input.beliefs);
        let mut mode = ws.mode;
        if let (ArbitrationMode::NaturalGradient(_), HumanCommand::Joint(_)) = (mode, &input.command) {
            mode = ArbitrationMode::NaturalGradient(super::modes::MetricSpace::Joint);
        }
        let mut policy_failed = !self.robot_actions(ws, input.q);
        if !policy_failed && mode.metric().is_some() && !self.compute_metric(ws, mode, input.q) {
            policy_failed = true;
        }
        Ok((mode, policy_failed))
    }

    /// The second half of a tick: `mode`'s objective for `command`, the
    /// hard constraints, the solve and the certification.
    fn finish(
        &self,
        ws: &mut ArbiterWorkspace,
        q: &[f64],
        mode: ArbitrationMode,
        command: &HumanCommand<'_>,
        policy_failed: bool,
    ) -> Result<TickStatus, TickStatus> {
        self.objective(ws, mode, command);
        let s = &self.settings.safety;
        let dt = self.settings.period;
        ws.rows.build_bounds(&self.robot, q, dt, s);
        let rate = if mode == ArbitrationMode::ObstacleAvoidance { s.avoidance_gain.min(1.0 / dt) } else { 1.0 / dt };
        let reach = self.build_distance_rows(ws, rate, None);
        self.note_rows(ws);
        let mut solved = ws.solve.enforce(&ws.rows, &ws.objective, &self.settings, &mut ws.diagnostics)?;
        // A solution that moves farther than the rows were built for: rebuild once.
        let moved = self.step_reach(ws);
        if moved > reach {
            self.build_distance_rows(ws, rate, Some(moved));
            self.note_rows(ws);
            solved = ws.solve.enforce(&ws.rows, &ws.objective, &self.settings, &mut ws.diagnostics)? || solved;
        }
        if ws.solve.u.iter().any(|u| !u.is_finite()) {
            return Err(TickStatus::SolverFailed);
        }
        ws.rows.clamp(&mut ws.solve.u);
        ws.diagnostics.active_rows = ws.rows.rows().filter(|&r| ws.rows.slack(r, &ws.solve.u) <= 1e-7).count();
        // A contact no joint moves (a mounting, say) cannot be helped: it does
        // not stop the certification of everything else.
        let in_collision = ws.rows.min_moving_distance < 0.0;
        let mut status = match (solved || ws.diagnostics.active_rows > 0, ws.objective.damped) {
            (true, _) => TickStatus::Constrained,
            (false, true) => TickStatus::SingularityDamped,
            (false, false) => TickStatus::Nominal,
        };
        if in_collision {
            status = TickStatus::InCollision;
        } else if s.certify && s.collisions {
            status = self.certify(ws, q, status)?;
        }
        if policy_failed {
            status = TickStatus::PolicyFailed;
        }
        Ok(status)
    }

    fn validate(&self, ws: &mut ArbiterWorkspace, input: &TickInput<'_>) -> Result<(), TickStatus> {
        let n = self.robot.nq();
        if !finite_of_len(input.q, n) {
            return Err(TickStatus::InvalidState);
        }
        match input.velocity {
            Some(v) if !finite_of_len(v, n) => return Err(TickStatus::InvalidState),
            Some(v) => ws.input.velocity.copy_from_slice(v),
            None => ws.input.velocity.fill(0.0),
        }
        let c = &input.command;
        if !finite_of_len(c.values(), c.expected_len(n)) {
            return Err(TickStatus::InvalidCommand);
        }
        if let Some(b) = input.beliefs {
            let ok = b.len() == self.goals.len()
                && b.iter().all(|x| x.is_finite() && *x >= 0.0)
                && (b.is_empty() || (b.iter().sum::<f64>() - 1.0).abs() <= 1e-6);
            if !ok {
                return Err(TickStatus::InvalidBeliefs);
            }
        }
        Ok(())
    }

    /// Every goal's action at `q`; false when a policy fails or returns a
    /// non-finite action.
    fn robot_actions(&self, ws: &mut ArbiterWorkspace, q: &[f64]) -> bool {
        let n = self.robot.nq();
        for (g, goal) in self.goals.iter().enumerate() {
            let action = &mut ws.robot.actions[g * n..(g + 1) * n];
            let ok = goal.policy.act(&mut ws.robot.states[g], q, &ws.input.velocity, action).is_ok();
            if !ok || action.iter().any(|a| !a.is_finite()) {
                return false;
            }
        }
        true
    }
}

/// Resets the diagnostics at the start of a tick.
fn begin_tick(ws: &mut ArbiterWorkspace) {
    ws.diagnostics = Diagnostics {
        mode: ws.mode,
        step_fraction: 1.0,
        min_distance: f64::INFINITY,
        metric_condition: 1.0,
        ..Diagnostics::default()
    };
}

/// The command of a tick that ended with `result`: zero on a hold, else
/// the step (shortened by the certification).
fn emit(ws: &mut ArbiterWorkspace, result: Result<TickStatus, TickStatus>) -> Command<'_> {
    let status = match result {
        Ok(status) => status,
        Err(status) => {
            ws.solve.u.fill(0.0);
            status
        }
    };
    if status.is_hold() {
        ws.certify.qdot.fill(0.0);
    } else {
        let f = ws.diagnostics.step_fraction;
        for (v, u) in ws.certify.qdot.iter_mut().zip(&ws.solve.u) {
            *v = f * u;
        }
    }
    Command { qdot: &ws.certify.qdot, status, diagnostics: ws.diagnostics }
}

fn finite_of_len(x: &[f64], n: usize) -> bool {
    x.len() == n && x.iter().all(|v| v.is_finite())
}

/// Whether the human command is a task command, and its dimension.
pub(crate) fn task_dim(command: &HumanCommand<'_>) -> Option<usize> {
    match command {
        HumanCommand::Linear(_) => Some(3),
        HumanCommand::Twist(_) => Some(6),
        HumanCommand::Joint(_) => None,
    }
}
