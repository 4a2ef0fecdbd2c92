//! A tick's stages in their order over an [`ArbiterWorkspace`] (see
//! [`workspace`](super::workspace)): inputs validated and kinematics,
//! beliefs, robot actions, the mode's metric and objective, the
//! hard-constraint rows, the solve (a solver only when the closed form
//! breaks a row), the certified step, and a command with a status. The
//! metric (`metric::stage`), the objective (`objective`) and the solve
//! (`solve`) have modules of their own; the small stages are here.

use super::arbiter::Arbiter;
use super::command::{Command, Diagnostics, HumanCommand, TickInput, TickStatus};
use super::learned::StateLayout;
use super::modes::ArbitrationMode;
use super::motion::stopping_distance;
use super::workspace::ArbiterWorkspace;
use crate::robot::ReferenceFrame;
use tandem_solvers::small::add_scaled;

impl Arbiter {
    /// Starts a new episode: forgets the observed path and the policies'
    /// progress; the arm is taken to be at rest (the acceleration and jerk
    /// limits count from a zero command).
    pub fn reset(&self, ws: &mut ArbiterWorkspace) {
        ws.intent.estimator.reset();
        ws.intent.beliefs.copy_from_slice(ws.intent.estimator.beliefs());
        ws.motion.reset();
        for (goal, state) in self.goals.iter().zip(&mut ws.robot.states) {
            goal.policy.reset(state);
        }
    }

    /// One control tick: the joint velocity to execute for one period, a
    /// status and diagnostics. Never panics; allocates nothing.
    pub fn tick<'w>(&self, ws: &'w mut ArbiterWorkspace, input: &TickInput<'_>) -> Command<'w> {
        self.begin_tick(ws);
        let result = self.run(ws, input);
        self.emit(ws, input.q, result)
    }

    /// A tick that holds without looking at a command: the braking step
    /// from the last executed command (certified at `q` when `q` is a
    /// configuration), recorded as executed, with `status`. For a loop
    /// whose own checks decide to hold (a stale command or state): its
    /// next [`Arbiter::tick`] then continues from the braked command, within
    /// the motion limits. Allocates nothing.
    pub fn hold<'w>(&self, ws: &'w mut ArbiterWorkspace, q: &[f64], status: TickStatus) -> Command<'w> {
        self.begin_tick(ws);
        self.emit(ws, q, Err(status))
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
        self.begin_tick(ws);
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
        self.emit(ws, input.q, result)
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
        ws.rows.build_bounds(&self.robot, q, dt, s, s.motion_limits.then_some(&ws.motion));
        let rate = if mode == ArbitrationMode::ObstacleAvoidance { s.avoidance_gain.min(1.0 / dt) } else { 1.0 / dt };
        if s.motion_limits && ws.objective.conic {
            reach_brake(ws);
        }
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

/// Stage 2 of a tick: the beliefs over the goals.
impl Arbiter {
    /// The beliefs of this tick: `given`, or the estimator's update from
    /// the gripper position.
    fn update_beliefs(&self, ws: &mut ArbiterWorkspace, given: Option<&[f64]>) {
        match given {
            Some(b) => ws.intent.beliefs.copy_from_slice(b),
            None => {
                let b = ws.intent.estimator.observe(ws.input.gripper_position, self.settings.period);
                ws.intent.beliefs.copy_from_slice(b);
            }
        }
        if let Some((g, &b)) = ws.intent.beliefs.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) {
            ws.diagnostics.goal = Some(g);
            ws.diagnostics.confidence = b;
        }
    }
}

/// The learned mode's stage, also [`Arbiter::observe`]'s: the arbitration
/// state and the learned policy's command.
impl Arbiter {
    /// Fills `ws.learned.state` (the first `layout.width()` values) for the tick's
    /// configuration, whose FK, Jacobian, beliefs and robot actions `ws`
    /// already holds, and the operator's `command`. Returns false when a
    /// value is not finite.
    fn fill_state(
        &self,
        ws: &mut ArbiterWorkspace,
        q: &[f64],
        layout: &StateLayout,
        command: &HumanCommand<'_>,
    ) -> bool {
        let (d, n) = (layout.task_dims, self.robot.nq());
        let (length, speed) = (layout.length_scale, layout.speed_scale);
        // The nearest pair's normal points from the robot's body to the obstacle.
        let (obstacle, toward) = match self.collision.min_distance(&mut ws.rows.collision, q) {
            Ok(Some(p)) if p.signed.distance < 1.0 => (p.signed.distance, <[f64; 3]>::from(p.signed.normal)),
            _ => (1.0, [0.0; 3]),
        };
        let p = ws.input.gripper_position;
        let mut human = [0.0; 3];
        match command {
            HumanCommand::Linear(v) | HumanCommand::Twist(v) => human.copy_from_slice(&v[..3]),
            HumanCommand::Joint(v) => {
                for (r, h) in human.iter_mut().enumerate() {
                    *h = (0..n).map(|c| ws.input.jac[(r, c)] * v[c]).sum();
                }
            }
        }
        let s = &mut ws.learned.state;
        for i in 0..d {
            s[i] = p[i] / length;
        }
        for (g, goal) in self.goals.iter().enumerate() {
            for i in 0..d {
                s[d + g * d + i] = (goal.position[i] - p[i]) / length;
            }
        }
        let o = layout.obstacle_offset();
        s[o] = obstacle / length;
        s[o + 1..o + 1 + d].copy_from_slice(&toward[..d]);
        for g in 0..layout.goals {
            let action = &ws.robot.actions[g * n..(g + 1) * n];
            let at = layout.action_offset(g);
            for i in 0..d {
                s[at + i] = (0..n).map(|c| ws.input.jac[(i, c)] * action[c]).sum::<f64>() / speed;
            }
        }
        let b = layout.belief_offset();
        s[b..b + layout.goals].copy_from_slice(&ws.intent.beliefs);
        let h = layout.human_offset();
        for i in 0..d {
            s[h + i] = human[i] / speed;
        }
        s[..layout.width()].iter().all(|x| x.is_finite())
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
        policy.act(&ws.learned.state[..layout.width()], &mut ws.learned.scratch, &mut command[..layout.task_dims]);
        command.iter_mut().for_each(|c| *c *= layout.speed_scale);
        command.iter().all(|c| c.is_finite()).then_some(command)
    }
}

/// Stage 6 of a tick (the rows) and stage 8 (the certification of the step).
impl Arbiter {
    /// Distance rows for the pairs that the step could bring within the
    /// margin: those closer than `margin + bound(|u|·dt) · 1.5 + 1 mm`, `u`
    /// the larger of the closed form's and `at_least`. Returns the reach (m).
    fn build_distance_rows(&self, ws: &mut ArbiterWorkspace, rate: f64, at_least: Option<f64>) -> f64 {
        let reach = self.reach(ws, false).max(at_least.unwrap_or(0.0));
        let s = &self.settings.safety;
        let cutoff = s.margin + 1.5 * reach + 1e-3;
        let braking = s.motion_limits.then_some((self.robot.motion_limits(), self.settings.period));
        ws.rows.build_distances(&self.collision, &ws.input.kin, cutoff, rate, s, braking);
        reach
    }

    fn note_rows(&self, ws: &mut ArbiterWorkspace) {
        ws.diagnostics.min_distance = ws.rows.min_distance;
        ws.diagnostics.rows = ws.rows.total();
        ws.diagnostics.distance_pairs = ws.rows.count;
    }

    /// How far the robot's geometry can move under the solved `u` (m).
    fn step_reach(&self, ws: &mut ArbiterWorkspace) -> f64 {
        self.reach(ws, true)
    }

    /// How far the robot's geometry can move in one step of a command and,
    /// with the motion limits, in the stop after it (m): the solved `u`
    /// (`solved`), else the closed form within this tick's bounds.
    fn reach(&self, ws: &mut ArbiterWorkspace, solved: bool) -> f64 {
        let dt = self.settings.period;
        let limits = self.settings.safety.motion_limits;
        for (j, (d, l)) in ws.certify.step.iter_mut().zip(self.robot.motion_limits()).enumerate() {
            let u = if solved { ws.solve.u[j] } else { ws.objective.u0[j] };
            if !limits {
                *d = u * dt;
                continue;
            }
            let u = u.clamp(ws.rows.lo[j], ws.rows.hi[j]);
            let (speed, s) = (u.abs(), if u < 0.0 { -1.0 } else { 1.0 });
            let accel = s * (u - ws.motion.velocity[j]) / dt;
            *d = s * (speed * dt + stopping_distance(speed, accel, l));
        }
        self.collision.displacement_bound(&ws.certify.step)
    }

    /// Certifies `q → q + c·dt` against the exact geometry, `c` the solved
    /// command, else halfway to the braking step `b` (`c = b + f·(u − b)`,
    /// `f` halved up to 4 times; with the motion limits off `b` is zero);
    /// holds when none is certified.
    fn certify(&self, ws: &mut ArbiterWorkspace, q: &[f64], status: TickStatus) -> Result<TickStatus, TickStatus> {
        let dt = self.settings.period;
        let clearance = self.settings.safety.certification_clearance;
        if ws.solve.u.iter().all(|u| *u == 0.0) {
            return Ok(status);
        }
        let mut fraction = 1.0;
        for attempt in 0..5 {
            for (j, x) in ws.certify.step.iter_mut().enumerate() {
                let (u, b) = (ws.solve.u[j], ws.motion.brake[j]);
                *x = q[j] + dt * (b + fraction * (u - b));
            }
            match self.collision.motion_free_certified(&mut ws.rows.collision, q, &ws.certify.step, clearance) {
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

    /// Resets the diagnostics at the start of a tick and plans its braking step.
    fn begin_tick(&self, ws: &mut ArbiterWorkspace) {
        ws.diagnostics = Diagnostics {
            mode: ws.mode,
            step_fraction: 1.0,
            min_distance: f64::INFINITY,
            metric_condition: 1.0,
            ..Diagnostics::default()
        };
        let limits = if self.settings.safety.motion_limits { self.robot.motion_limits() } else { &[] };
        ws.motion.plan_brake(limits, self.settings.period);
    }

    /// The command of a tick that ended with `result`: on a hold the
    /// braking step when it is certified at `q` (or `q` is not known),
    /// else zero; otherwise the certified step. Recorded as executed.
    fn emit<'w>(&self, ws: &'w mut ArbiterWorkspace, q: &[f64], result: Result<TickStatus, TickStatus>) -> Command<'w> {
        let mut status = match result {
            Ok(status) => status,
            Err(status) => status,
        };
        let mut stopped = false;
        if status.is_hold() || result.is_err() {
            ws.diagnostics.step_fraction = 0.0;
            self.keep_brake_within_position_limits(ws, q);
            let braking = ws.motion.brake.iter().any(|b| *b != 0.0);
            stopped = braking && !self.brake_certified(ws, q);
            if stopped {
                // A category-0 stop: the braking step is not certified.
                ws.motion.brake.fill(0.0);
                status = TickStatus::Halted;
            }
            ws.certify.qdot.copy_from_slice(&ws.motion.brake);
        } else {
            let f = ws.diagnostics.step_fraction;
            for ((v, u), b) in ws.certify.qdot.iter_mut().zip(&ws.solve.u).zip(&ws.motion.brake) {
                *v = b + f * (u - b);
            }
        }
        // The position and velocity limits are hard whatever shaped the command.
        if finite_of_len(q, self.robot.nq()) {
            let dt = self.settings.period;
            let scale = self.settings.safety.velocity_scale;
            let limits = self.robot.limits().iter().zip(self.robot.motion_limits());
            for ((v, (l, m)), x) in ws.certify.qdot.iter_mut().zip(limits).zip(q) {
                let (down, up) = m.velocity_range(*x, scale);
                *v = v.min(((l.upper - x) / dt).max(0.0)).max(((l.lower - x) / dt).min(0.0)).clamp(down, up);
            }
        }
        ws.motion.executed(&ws.certify.qdot, self.settings.period, stopped);
        Command { qdot: &ws.certify.qdot, status, diagnostics: ws.diagnostics }
    }

    /// Clamps the braking step so that it does not carry a joint past its
    /// position limit (the limit is hard; the motion limits give way to it,
    /// see the module `motion`). Nothing for a `q` that is not a
    /// configuration.
    fn keep_brake_within_position_limits(&self, ws: &mut ArbiterWorkspace, q: &[f64]) {
        if !finite_of_len(q, self.robot.nq()) {
            return;
        }
        let dt = self.settings.period;
        for ((b, l), x) in ws.motion.brake.iter_mut().zip(self.robot.limits()).zip(q) {
            let (up, down) = ((l.upper - x) / dt, (l.lower - x) / dt);
            *b = b.min(up.max(0.0)).max(down.min(0.0));
        }
    }

    /// Whether the braking step from `q` is certified free (true without
    /// certification, and for a `q` that is not a configuration: the arm
    /// then keeps braking along its last certified motion).
    fn brake_certified(&self, ws: &mut ArbiterWorkspace, q: &[f64]) -> bool {
        let s = &self.settings.safety;
        if !(s.certify && s.collisions && finite_of_len(q, self.robot.nq())) {
            return true;
        }
        add_scaled(&mut ws.certify.step, q, self.settings.period, &ws.motion.brake);
        matches!(
            self.collision.motion_free_certified(
                &mut ws.rows.collision,
                q,
                &ws.certify.step,
                s.certification_clearance
            ),
            Ok(true)
        )
    }
}

/// Grows `Constrained`'s trust region to reach the braking step when it
/// does not: the cone is the mode's objective, not a safety row, and an arm
/// that cannot slow to it within its limits must be allowed to brake (the
/// cone around standing still shrinks at once when the operator stops; the
/// arm then slows along the operator's direction at the braking speed).
fn reach_brake(ws: &mut ArbiterWorkspace) {
    let n = ws.motion.brake.len();
    let o = &mut ws.objective;
    let far: f64 = (0..n)
        .map(|i| {
            let lb: f64 = (i..n).map(|j| o.cone_l[i * n + j] * ws.motion.brake[j]).sum();
            (lb - o.cone_c[i]).powi(2)
        })
        .sum::<f64>()
        .sqrt();
    if far > o.radius {
        o.radius = far * (1.0 + 1e-9) + 1e-12;
    }
}

fn finite_of_len(x: &[f64], n: usize) -> bool {
    x.len() == n && x.iter().all(|v| v.is_finite())
}
