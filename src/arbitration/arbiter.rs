//! The [`Arbiter`] (immutable, shared) and its per-loop
//! [`ArbiterWorkspace`]: one tick validates the inputs, updates the goal
//! beliefs, queries the robot policies, builds the mode's objective, adds
//! the hard constraints, solves (Clarabel only when the closed form breaks a
//! constraint), certifies the step, and returns a command with a status.

use super::ArbitrationError;
use super::command::{Command, Diagnostics, HumanCommand, TickInput, TickStatus};
use super::intent::{IntentEstimator, IntentSettings};
use super::learned::{ArbitrationPolicy, StateLayout};
use super::metric::{Metric, MetricScratch, MetricSettings};
use super::modes::{ArbitrationMode, ModeSettings};
use super::safety::{Row, SafetyRows, SafetySettings};
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::control::{PolicyState, RobotPolicy};
use crate::robot::{FrameId, KinematicsWorkspace, ReferenceFrame, RobotModel};
use nalgebra::Matrix6xX;
use std::sync::Arc;
use tandem_solvers::conic::{ActiveSetSolver, ConicData, ConicError, ConicSettings, ConicSolverPool, SecondOrderCone};
use tandem_solvers::small::add_scaled;

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

/// Damped least squares for task commands near singularities (Nakamura's
/// variable damping, per singular direction): a direction of the task
/// Jacobian whose singular value `σ` is below `threshold` is damped by
/// `max_damping² · (1 − (σ/threshold)²)`; `floor` regularises the null
/// space. Only the directions losing rank slow down: the arm keeps moving
/// where it can.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampingSettings {
    /// σ_min below which damping grows (m/rad; default 0.03).
    pub threshold: f64,
    /// Largest damping factor (m/rad; default 0.05).
    pub max_damping: f64,
    /// Damping always present, regularising the null space (default 1e-6).
    pub floor: f64,
    /// Weight of joint-space deviation from the operator's command against
    /// task-space deviation when a constraint binds (m²/rad²; default
    /// 0.01): the command gives way in the null space first.
    pub null_space_weight: f64,
}

impl Default for DampingSettings {
    fn default() -> Self {
        DampingSettings { threshold: 0.03, max_damping: 0.05, floor: 1e-6, null_space_weight: 0.01 }
    }
}

/// Which solver handles the QP modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SolverBackend {
    /// A dense Goldfarb–Idnani dual active-set method for the QP modes
    /// (exact up to rounding, allocation-free), Clarabel for `Constrained`'s
    /// cone and whenever the active set cannot finish (dependent active
    /// rows, a step limit).
    #[default]
    ActiveSet,
    /// Clarabel's interior point method (every mode).
    Clarabel,
    /// OSQP (QP modes; `Constrained` still uses Clarabel). Needs the `osqp`
    /// cargo feature.
    #[cfg(feature = "osqp")]
    Osqp,
}

/// Everything an [`Arbiter`] can be told.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArbiterSettings {
    /// The mode new workspaces start in.
    pub mode: ArbitrationMode,
    /// Control period `dt` (s; default 1/15, the seed's 15 Hz).
    pub period: f64,
    /// The metrics' settings.
    pub metric: MetricSettings,
    /// The goal posterior's settings.
    pub intent: IntentSettings,
    /// The modes' settings.
    pub modes: ModeSettings,
    /// The hard constraints' settings.
    pub safety: SafetySettings,
    /// Damped least squares of task commands.
    pub damping: DampingSettings,
    /// Tolerance and iteration limit of the solver.
    pub solver: ConicSettings,
    /// Which solver solves the QP modes.
    pub backend: SolverBackend,
    /// Skip the solver when the mode's closed form meets every constraint
    /// (it is then the optimum of the convex problem; default true).
    pub closed_form_first: bool,
}

impl Default for ArbiterSettings {
    fn default() -> Self {
        ArbiterSettings {
            mode: ArbitrationMode::default(),
            period: 1.0 / 15.0,
            metric: MetricSettings::default(),
            intent: IntentSettings::default(),
            modes: ModeSettings::default(),
            safety: SafetySettings::default(),
            damping: DampingSettings::default(),
            solver: ConicSettings::default(),
            backend: SolverBackend::default(),
            closed_form_first: true,
        }
    }
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

/// Per-control-loop state of an [`Arbiter`]: buffers, policy states, the
/// intent estimate and the solvers, allocated once.
pub struct ArbiterWorkspace {
    pub(crate) mode: ArbitrationMode,
    pub(crate) kin: KinematicsWorkspace,
    pub(crate) probe_kin: KinematicsWorkspace,
    pub(crate) collision: CollisionWorkspace,
    pub(crate) jac: Matrix6xX<f64>,
    pub(crate) probe_jac: Matrix6xX<f64>,
    pub(crate) gripper_position: [f64; 3],
    pub(crate) states: Vec<PolicyState>,
    /// Robot actions, goal-major (`k × n`).
    pub(crate) actions: Vec<f64>,
    pub(crate) intent: IntentEstimator,
    pub(crate) beliefs: Vec<f64>,
    pub(crate) scratch: MetricScratch,
    pub(crate) task_scratch: MetricScratch,
    pub(crate) raw: Vec<f64>,
    pub(crate) goal_metric: Metric,
    pub(crate) metric: Metric,
    pub(crate) task_goal_metric: Metric,
    pub(crate) task_metric: Metric,
    pub(crate) velocity: Vec<f64>,
    /// The operator's command in joint space (rad/s).
    pub(crate) human: Vec<f64>,
    /// The operator's command as used (capped), `max(n, 6)` values.
    pub(crate) command: Vec<f64>,
    /// Task Jacobian rows in use (row-major `k × n`) and the task target.
    pub(crate) jk: Vec<f64>,
    pub(crate) task: [f64; 6],
    pub(crate) target: Vec<f64>,
    /// The problem: `½uᵀPu + qᵀu`, its unconstrained minimiser, the cone.
    pub(crate) p: Vec<f64>,
    pub(crate) q: Vec<f64>,
    pub(crate) u0: Vec<f64>,
    pub(crate) chol: Vec<f64>,
    pub(crate) column: Vec<f64>,
    pub(crate) cone_l: Vec<f64>,
    pub(crate) cone_c: Vec<f64>,
    pub(crate) radius: f64,
    pub(crate) conic: bool,
    pub(crate) rows: SafetyRows,
    active: Vec<Row>,
    qp_g: Vec<f64>,
    qp_h: Vec<f64>,
    qp_z: Vec<f64>,
    /// Rows of the last solve (0 when the closed form was feasible).
    solved_rows: usize,
    qp: ConicSolverPool,
    dense: ActiveSetSolver,
    socp: ConicSolverPool,
    #[cfg(feature = "osqp")]
    osqp: tandem_solvers::conic::OsqpSolver,
    pub(crate) u: Vec<f64>,
    qnext: Vec<f64>,
    qdot: Vec<f64>,
    pub(crate) diagnostics: Diagnostics,
    /// The arbitration state of the learned mode and of [`Arbiter::observe`].
    pub(crate) state: Vec<f64>,
    pub(crate) learned_scratch: Vec<f32>,
    /// Whether the last call was a successful [`Arbiter::observe`].
    pub(crate) observed: bool,
}

/// Distance rows beyond the bounds the solver may take per tick.
const MAX_SOLVER_ROWS: usize = 64;

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
        validate_settings(&settings)?;
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
        validate_settings(&settings)?;
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
    /// A policy whose [`StateLayout`] has another number of goals, or an
    /// invalid layout.
    pub fn with_arbitration_policy(&self, policy: Arc<dyn ArbitrationPolicy>) -> Result<Arbiter, ArbitrationError> {
        let layout = policy.layout();
        if layout.goals != self.goals.len() || !layout.is_valid() {
            return Err(ArbitrationError::PolicyLayout {
                expected_goals: self.goals.len(),
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

    /// A workspace for one control loop (allocates; ticks do not).
    pub fn workspace(&self) -> ArbiterWorkspace {
        let n = self.robot.nq();
        let k = self.goals.len();
        let positions: Vec<[f64; 3]> = self.goals.iter().map(|g| g.position).collect();
        let max_rows = 2 * n + MAX_SOLVER_ROWS;
        let solver = &self.settings.solver;
        ArbiterWorkspace {
            mode: self.settings.mode,
            kin: KinematicsWorkspace::new(&self.robot),
            probe_kin: KinematicsWorkspace::new(&self.robot),
            collision: CollisionWorkspace::new(&self.collision),
            jac: Matrix6xX::zeros(n),
            probe_jac: Matrix6xX::zeros(n),
            gripper_position: [0.0; 3],
            states: self.goals.iter().map(|g| g.policy.new_state()).collect(),
            actions: vec![0.0; k * n],
            intent: IntentEstimator::new(&positions, self.settings.intent),
            beliefs: vec![if k == 0 { 0.0 } else { 1.0 / k as f64 }; k],
            scratch: MetricScratch::new(n),
            task_scratch: MetricScratch::new(3),
            raw: vec![0.0; n * n],
            goal_metric: Metric::identity(n),
            metric: Metric::identity(n),
            task_goal_metric: Metric::identity(3),
            task_metric: Metric::identity(3),
            velocity: vec![0.0; n],
            human: vec![0.0; n],
            command: vec![0.0; n.max(6)],
            jk: vec![0.0; 6 * n.max(1)],
            task: [0.0; 6],
            target: vec![0.0; n.max(6)],
            p: vec![0.0; n * n],
            q: vec![0.0; n],
            u0: vec![0.0; n],
            chol: vec![0.0; n * n],
            column: vec![0.0; n],
            cone_l: vec![0.0; n * n],
            cone_c: vec![0.0; n],
            radius: 0.0,
            conic: false,
            rows: SafetyRows::new(n, self.settings.safety.max_distance_rows, self.collision.pair_count()),
            active: Vec::with_capacity(max_rows + self.settings.safety.max_distance_rows),
            qp_g: vec![0.0; max_rows * n],
            qp_h: vec![0.0; max_rows],
            qp_z: vec![0.0; max_rows],
            solved_rows: 0,
            qp: ConicSolverPool::new(n, max_rows, None, solver),
            dense: ActiveSetSolver::new(n, max_rows, solver),
            socp: ConicSolverPool::new(n, max_rows, Some(n), solver),
            #[cfg(feature = "osqp")]
            osqp: tandem_solvers::conic::OsqpSolver::new(n, max_rows, solver),
            u: vec![0.0; n],
            qnext: vec![0.0; n],
            qdot: vec![0.0; n],
            diagnostics: Diagnostics::default(),
            state: vec![0.0; StateLayout { task_dims: 3, goals: k, length_scale: 1.0, speed_scale: 1.0 }.width()],
            learned_scratch: vec![0.0; self.learned.as_ref().map_or(0, |p| p.scratch_len())],
            observed: false,
        }
    }

    /// Starts a new episode: forgets the observed path and the policies' progress.
    pub fn reset(&self, ws: &mut ArbiterWorkspace) {
        ws.intent.reset();
        ws.beliefs.copy_from_slice(ws.intent.beliefs());
        for (goal, state) in self.goals.iter().zip(&mut ws.states) {
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
        ws.observed = false;
        if layout.goals != self.goals.len() || !layout.is_valid() || layout.width() > ws.state.len() {
            return Err(TickStatus::InvalidBeliefs);
        }
        let (_, policy_failed) = self.prepare(ws, input)?;
        if policy_failed {
            return Err(TickStatus::PolicyFailed);
        }
        if !self.fill_state(ws, input.q, layout, &input.command) {
            return Err(TickStatus::InvalidState);
        }
        ws.observed = true;
        Ok(&ws.state[..layout.width()])
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
        let result = if !ws.observed || command.len() > 3 || command.iter().any(|c| !c.is_finite()) {
            Err(if ws.observed { TickStatus::InvalidCommand } else { TickStatus::InvalidState })
        } else {
            linear[..command.len()].copy_from_slice(command);
            self.finish(ws, input.q, ArbitrationMode::DirectControl, &HumanCommand::Linear(&linear), false)
        };
        ws.observed = false;
        if result.is_err() {
            ws.u.fill(0.0);
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
        let _ = self.robot.forward_kinematics(&mut ws.kin, input.q);
        let pose = self
            .robot
            .frame_jacobian(&ws.kin, self.gripper, ReferenceFrame::WorldAligned, &mut ws.jac)
            .map_err(|_| TickStatus::InvalidState)?;
        ws.gripper_position = pose.translation.vector.into();
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

    /// The learned policy's command (m/s, world) for this tick's state;
    /// `None` without a policy or when the state or the command is not finite.
    fn learned_command(&self, ws: &mut ArbiterWorkspace, input: &TickInput<'_>) -> Option<[f64; 3]> {
        let policy = self.learned.as_ref()?;
        let layout = policy.layout();
        if !self.fill_state(ws, input.q, &layout, &input.command) {
            return None;
        }
        let mut command = [0.0; 3];
        policy.act(&ws.state[..layout.width()], &mut ws.learned_scratch, &mut command[..layout.task_dims]);
        command.iter_mut().for_each(|c| *c *= layout.speed_scale);
        command.iter().all(|c| c.is_finite()).then_some(command)
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
        let mut solved = self.enforce(ws)?;
        // A solution that moves farther than the rows were built for: rebuild once.
        let moved = self.step_reach(ws);
        if moved > reach {
            self.build_distance_rows(ws, rate, Some(moved));
            self.note_rows(ws);
            solved = self.enforce(ws)? || solved;
        }
        if ws.u.iter().any(|u| !u.is_finite()) {
            return Err(TickStatus::SolverFailed);
        }
        ws.rows.clamp(&mut ws.u);
        ws.diagnostics.active_rows = ws.rows.rows().filter(|&r| ws.rows.slack(r, &ws.u) <= 1e-7).count();
        // A contact no joint moves (a mounting, say) cannot be helped: it does
        // not stop the certification of everything else.
        let in_collision = ws.rows.min_moving_distance < 0.0;
        let mut status =
            if solved || ws.diagnostics.active_rows > 0 { TickStatus::Constrained } else { TickStatus::Nominal };
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
            Some(v) => ws.velocity.copy_from_slice(v),
            None => ws.velocity.fill(0.0),
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

    fn update_beliefs(&self, ws: &mut ArbiterWorkspace, given: Option<&[f64]>) {
        match given {
            Some(b) => ws.beliefs.copy_from_slice(b),
            None => {
                let b = ws.intent.observe(ws.gripper_position, self.settings.period);
                ws.beliefs.copy_from_slice(b);
            }
        }
        if let Some((g, &b)) = ws.beliefs.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) {
            ws.diagnostics.goal = Some(g);
            ws.diagnostics.confidence = b;
        }
    }

    /// Every goal's action at `q`; false when a policy fails or returns a
    /// non-finite action.
    fn robot_actions(&self, ws: &mut ArbiterWorkspace, q: &[f64]) -> bool {
        let n = self.robot.nq();
        for (g, goal) in self.goals.iter().enumerate() {
            let action = &mut ws.actions[g * n..(g + 1) * n];
            let ok = goal.policy.act(&mut ws.states[g], q, &ws.velocity, action).is_ok();
            if !ok || action.iter().any(|a| !a.is_finite()) {
                return false;
            }
        }
        true
    }

    /// Distance rows for the pairs that the step could bring within the
    /// margin: those closer than `margin + bound(|u|·dt) · 1.5 + 1 mm`, `u`
    /// the larger of the closed form's and `at_least`. Returns the reach (m).
    fn build_distance_rows(&self, ws: &mut ArbiterWorkspace, rate: f64, at_least: Option<f64>) -> f64 {
        let dt = self.settings.period;
        for (d, u) in ws.qnext.iter_mut().zip(&ws.u0) {
            *d = u * dt;
        }
        let reach = self.collision.displacement_bound(&ws.qnext).max(at_least.unwrap_or(0.0));
        let cutoff = self.settings.safety.margin + 1.5 * reach + 1e-3;
        ws.rows.build_distances(&self.collision, &mut ws.collision, &ws.kin, cutoff, rate, &self.settings.safety);
        reach
    }

    fn note_rows(&self, ws: &mut ArbiterWorkspace) {
        ws.diagnostics.min_distance = ws.rows.min_distance;
        ws.diagnostics.rows = ws.rows.total();
        ws.diagnostics.distance_pairs = ws.rows.count;
    }

    /// How far the robot's geometry can move under the current `u` (m).
    fn step_reach(&self, ws: &mut ArbiterWorkspace) -> f64 {
        let dt = self.settings.period;
        for (d, u) in ws.qnext.iter_mut().zip(&ws.u) {
            *d = u * dt;
        }
        self.collision.displacement_bound(&ws.qnext)
    }

    /// Meets every row: the closed form when it does (and
    /// `closed_form_first`), else the solver on the violated rows, adding
    /// rows the solution violates, up to 6 rounds. Returns whether the
    /// solver ran.
    fn enforce(&self, ws: &mut ArbiterWorkspace) -> Result<bool, TickStatus> {
        ws.u.copy_from_slice(&ws.u0);
        ws.active.clear();
        ws.solved_rows = 0;
        let mut solved = !self.settings.closed_form_first;
        if solved {
            ws.active.extend(ws.rows.rows());
            self.solve(ws)?;
        }
        for _round in 0..6 {
            let before = ws.active.len();
            for row in ws.rows.rows() {
                if !ws.active.contains(&row) && ws.rows.slack(row, &ws.u) < -violation_tolerance(&ws.rows, row) {
                    ws.active.push(row);
                }
            }
            if ws.active.len() == before {
                return Ok(solved);
            }
            self.solve(ws)?;
            solved = true;
        }
        let worst = ws.rows.rows().map(|r| ws.rows.slack(r, &ws.u)).fold(0.0f64, f64::min);
        if worst < -1e-6 { Err(TickStatus::SolverFailed) } else { Ok(solved) }
    }

    /// Solves the mode's problem with the active rows into `ws.u`.
    fn solve(&self, ws: &mut ArbiterWorkspace) -> Result<(), TickStatus> {
        let n = self.robot.nq();
        if ws.active.len() > ws.qp_h.len() {
            // More rows than the solvers take: the most violated first.
            let rows = &ws.rows;
            let u = &ws.u;
            ws.active.sort_by(|a, b| rows.slack(*a, u).total_cmp(&rows.slack(*b, u)));
            ws.active.truncate(ws.qp_h.len());
        }
        let m = ws.active.len();
        for (i, &row) in ws.active.iter().enumerate() {
            ws.qp_h[i] = ws.rows.row(row, &mut ws.qp_g[i * n..(i + 1) * n]);
        }
        let cone = ws.conic.then(|| SecondOrderCone { l: &ws.cone_l, c: &ws.cone_c, radius: ws.radius });
        let data = ConicData { p: &ws.p, q: &ws.q, g: &ws.qp_g[..m * n], h: &ws.qp_h[..m], cone };
        let result = match (cone.is_some(), self.settings.backend) {
            (true, _) => ws.socp.solve(&data),
            (false, SolverBackend::ActiveSet) => match ws.dense.solve(&data) {
                Ok(solution) => Ok(solution),
                Err(_) => ws.qp.solve(&data),
            },
            #[cfg(feature = "osqp")]
            (false, SolverBackend::Osqp) => ws.osqp.solve(&data),
            (false, _) => ws.qp.solve(&data),
        };
        match result {
            Ok(solution) if solution.x.iter().all(|x| x.is_finite()) => {
                ws.u.copy_from_slice(solution.x);
                ws.qp_z[..m].copy_from_slice(solution.z);
                ws.solved_rows = m;
                ws.diagnostics.solver_iterations += solution.iterations;
                ws.diagnostics.solves += 1;
                Ok(())
            }
            Ok(_) | Err(ConicError::Numerical | ConicError::MaxIterations | ConicError::Capacity { .. }) => {
                Err(TickStatus::SolverFailed)
            }
            Err(ConicError::Infeasible | ConicError::Unbounded) => Err(TickStatus::Infeasible),
        }
    }

    /// Certifies `q → q + u·dt` against the exact geometry, halving the
    /// step up to 4 times; holds when none is certified.
    fn certify(&self, ws: &mut ArbiterWorkspace, q: &[f64], status: TickStatus) -> Result<TickStatus, TickStatus> {
        let dt = self.settings.period;
        let clearance = self.settings.safety.certification_clearance;
        if ws.u.iter().all(|u| *u == 0.0) {
            return Ok(status);
        }
        let mut fraction = 1.0;
        for attempt in 0..5 {
            add_scaled(&mut ws.qnext, q, fraction * dt, &ws.u);
            match self.collision.motion_free_certified(&mut ws.collision, q, &ws.qnext, clearance) {
                Ok(true) => {
                    ws.diagnostics.step_fraction = fraction;
                    return Ok(if attempt == 0 { status } else { TickStatus::StepShortened });
                }
                Ok(false) => fraction *= 0.5,
                Err(_) => break,
            }
        }
        ws.diagnostics.step_fraction = 0.0;
        Err(TickStatus::Halted)
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
            ws.u.fill(0.0);
            status
        }
    };
    if status.is_hold() {
        ws.qdot.fill(0.0);
    } else {
        let f = ws.diagnostics.step_fraction;
        for (v, u) in ws.qdot.iter_mut().zip(&ws.u) {
            *v = f * u;
        }
    }
    Command { qdot: &ws.qdot, status, diagnostics: ws.diagnostics }
}

impl ArbiterWorkspace {
    /// The mode the next ticks run.
    pub fn mode(&self) -> ArbitrationMode {
        self.mode
    }

    /// Switches the mode from the next tick on.
    pub fn set_mode(&mut self, mode: ArbitrationMode) {
        self.mode = mode;
    }

    /// Beliefs over the goals after the last tick.
    pub fn beliefs(&self) -> &[f64] {
        &self.beliefs
    }

    /// Goal `g`'s robot action at the last tick (rad/s).
    pub fn robot_action(&self, g: usize) -> &[f64] {
        let n = self.u.len();
        &self.actions[g * n..(g + 1) * n]
    }

    /// The joint-space metric of the last tick (the Hessian metric `W` for
    /// `Constrained` and `SumOfSquares`, the Fisher metric `F` for
    /// `NaturalGradient(Joint)`; the identity otherwise).
    pub fn metric(&self) -> &Metric {
        &self.metric
    }

    /// The 3 × 3 task-space Fisher metric of the last
    /// `NaturalGradient(Task)` tick.
    pub fn task_metric(&self) -> &Metric {
        &self.task_metric
    }

    /// The gripper Jacobian of the last tick (6 × n, world-aligned, linear rows first).
    pub fn jacobian(&self) -> &Matrix6xX<f64> {
        &self.jac
    }

    /// The gripper position of the last tick (m, world).
    pub fn gripper_position(&self) -> [f64; 3] {
        self.gripper_position
    }

    /// The operator's command mapped to joint space at the last tick (rad/s).
    pub fn human_joint_command(&self) -> &[f64] {
        &self.human
    }

    /// The last problem the solver solved this tick, with its multipliers
    /// (for KKT checks); `None` when the closed form met every constraint.
    pub fn last_solve(&self) -> Option<SolvedProblem<'_>> {
        let (n, m) = (self.u.len(), self.solved_rows);
        (m > 0).then(|| SolvedProblem {
            p: &self.p,
            q: &self.q,
            g: &self.qp_g[..m * n],
            h: &self.qp_h[..m],
            z: &self.qp_z[..m],
            conic: self.conic,
        })
    }

    /// The mode's unconstrained solution at the last tick (rad/s).
    pub fn closed_form(&self) -> &[f64] {
        &self.u0
    }
}

/// A solved problem `min ½uᵀPu + qᵀu s.t. Gu ≤ h` (plus the trust-region
/// cone when `conic`) and the solver's multipliers `z` of the rows.
#[derive(Debug, Clone, Copy)]
pub struct SolvedProblem<'w> {
    /// `P` (n × n, column-major) and `q`.
    pub p: &'w [f64],
    /// `q` of the objective.
    pub q: &'w [f64],
    /// `G` (m × n, row-major) and `h`.
    pub g: &'w [f64],
    /// `h` of the rows.
    pub h: &'w [f64],
    /// The solver's multipliers of the rows (≥ 0).
    pub z: &'w [f64],
    /// Whether the trust-region cone was part of it.
    pub conic: bool,
}

fn finite_of_len(x: &[f64], n: usize) -> bool {
    x.len() == n && x.iter().all(|v| v.is_finite())
}

/// How far below zero a row's slack may go before it counts as violated.
fn violation_tolerance(rows: &SafetyRows, row: Row) -> f64 {
    let h = match row {
        Row::Upper(j) => rows.hi[j],
        Row::Lower(j) => rows.lo[j],
        Row::Distance(_) => 0.0,
    };
    1e-9 * (1.0 + h.abs())
}

fn validate_settings(s: &ArbiterSettings) -> Result<(), ArbitrationError> {
    let bad = |what: &'static str, value: f64| Err(ArbitrationError::Setting { what, value });
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if !positive(s.period) {
        return bad("period", s.period);
    }
    if !positive(s.metric.step) {
        return bad("metric.step", s.metric.step);
    }
    if !positive(s.metric.sample_radius) {
        return bad("metric.sample_radius", s.metric.sample_radius);
    }
    if !positive(s.metric.task_sample_radius) {
        return bad("metric.task_sample_radius", s.metric.task_sample_radius);
    }
    if !(s.metric.floor > 0.0 && s.metric.floor <= 1.0) {
        return bad("metric.floor", s.metric.floor);
    }
    if !positive(s.modes.sum_of_squares_epsilon) {
        return bad("modes.sum_of_squares_epsilon", s.modes.sum_of_squares_epsilon);
    }
    if !s.modes.sum_of_squares_center.is_finite() {
        return bad("modes.sum_of_squares_center", s.modes.sum_of_squares_center);
    }
    if !s.modes.constrained_center.is_finite() {
        return bad("modes.constrained_center", s.modes.constrained_center);
    }
    if !(s.safety.margin.is_finite() && s.safety.margin >= 0.0) {
        return bad("safety.margin", s.safety.margin);
    }
    if !positive(s.safety.avoidance_gain) {
        return bad("safety.avoidance_gain", s.safety.avoidance_gain);
    }
    if !positive(s.safety.default_velocity_limit) {
        return bad("safety.default_velocity_limit", s.safety.default_velocity_limit);
    }
    if !positive(s.safety.velocity_scale) {
        return bad("safety.velocity_scale", s.safety.velocity_scale);
    }
    if !positive(s.safety.certification_clearance) {
        return bad("safety.certification_clearance", s.safety.certification_clearance);
    }
    if !positive(s.damping.null_space_weight) {
        return bad("damping.null_space_weight", s.damping.null_space_weight);
    }
    if !(s.damping.floor >= 0.0 && s.damping.floor.is_finite()) {
        return bad("damping.floor", s.damping.floor);
    }
    if !positive(s.intent.length_scale) {
        return bad("intent.length_scale", s.intent.length_scale);
    }
    if !(s.intent.cap > 0.0 && s.intent.cap <= 1.0) {
        return bad("intent.cap", s.intent.cap);
    }
    Ok(())
}

/// Whether the human command is a task command, and its dimension.
pub(crate) fn task_dim(command: &HumanCommand<'_>) -> Option<usize> {
    match command {
        HumanCommand::Linear(_) => Some(3),
        HumanCommand::Twist(_) => Some(6),
        HumanCommand::Joint(_) => None,
    }
}
