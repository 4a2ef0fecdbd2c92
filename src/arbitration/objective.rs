//! Each mode's objective and closed form, and the metrics they read.
//!
//! Task commands use the first `k` rows of the gripper Jacobian (`k = 3`
//! for a linear velocity, 6 for a twist); `J†v` is the damped least-squares
//! solution `(JᵀJ + D)⁻¹Jᵀv` with `D` from [`DampingSettings`](super::DampingSettings).

use super::arbiter::{Arbiter, ArbiterWorkspace, task_dim};
use super::command::HumanCommand;
use super::metric::{
    LwrFit, MetricMixture, fisher_metric, gaussian_weight, hessian_metric, repair, sample_count, sample_offset,
};
use super::modes::{ArbitrationMode, MetricKind, MetricSpace};
use crate::control::ControlError;
use crate::robot::ReferenceFrame;
use tandem_solvers::small::{add_scaled, cholesky_in_place, cholesky_solve_factored, dot, mat_vec, symmetric_eigen};

/// Largest command component kept as given (m/s, rad/s): larger commands
/// are scaled down to it, direction kept.
const COMMAND_CAP: f64 = 1e3;

impl Arbiter {
    /// Fills `ws.p`, `ws.q` (and the cone) with `mode`'s problem and
    /// `ws.u0` with its unconstrained solution.
    pub(crate) fn objective(&self, ws: &mut ArbiterWorkspace, mode: ArbitrationMode, command: &HumanCommand<'_>) {
        let n = self.robot.nq();
        ws.conic = false;
        let k = task_dim(command);
        // Commands beyond any physical speed keep their direction only: the
        // hard limits clip the magnitude, and the arithmetic stays finite.
        let given = command.values();
        let largest = given.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let scale = if largest > COMMAND_CAP { COMMAND_CAP / largest } else { 1.0 };
        let mut command_values = std::mem::take(&mut ws.command);
        for (c, x) in command_values.iter_mut().zip(given) {
            *c = x * scale;
        }
        let v = &command_values[..given.len()];
        let damping = &self.settings.damping;
        match k {
            Some(k) => {
                load_task(ws, k, v);
                damped_normal(&ws.jk, k, n, damping, &mut ws.column, &mut ws.chol);
                dls(&ws.jk, k, n, &mut ws.chol, v, &mut ws.human);
            }
            None => ws.human.copy_from_slice(v),
        }
        let modes = &self.settings.modes;
        match mode {
            // `Learned` reaches here as direct control with the learned command.
            ArbitrationMode::DirectControl | ArbitrationMode::ObstacleAvoidance | ArbitrationMode::Learned => match k {
                Some(k) => task_objective(ws, k, n, damping),
                None => joint_objective(ws, n, |ws, t| t.copy_from_slice(&ws.human)),
            },
            ArbitrationMode::LinearBlending(style) => {
                let alpha = modes.blending_alpha(style, ws.diagnostics.confidence, self.goals.len());
                ws.diagnostics.alpha = alpha;
                let goal = ws.diagnostics.goal.unwrap_or(0);
                joint_objective(ws, n, |ws, t| {
                    let robot = ws.actions.get(goal * n..(goal + 1) * n).filter(|_| alpha > 0.0);
                    for (j, t) in t.iter_mut().enumerate() {
                        *t = alpha * robot.map_or(0.0, |a| a[j]) + (1.0 - alpha) * ws.human[j];
                    }
                });
            }
            ArbitrationMode::NaturalGradient(MetricSpace::Task) if k.is_some() => {
                let k = k.unwrap_or(3);
                // t = F_t⁻¹ v_lin at the operator's speed; angular rates pass through.
                let mut shaped = [0.0; 3];
                mat_vec(ws.task_metric.inverse(), 3, 3, &ws.task[..3], &mut shaped);
                let scale = speed_ratio(norm(&ws.task[..3]), norm(&shaped), modes.keep_speed);
                for (t, s) in ws.task.iter_mut().zip(shaped) {
                    *t = scale * s;
                }
                task_objective(ws, k, n, damping);
            }
            ArbitrationMode::NaturalGradient(_) => {
                joint_objective(ws, n, |ws, t| mat_vec(ws.metric.inverse(), n, n, &ws.human, t));
                let scale = operator_speed_ratio(ws, k, n, &ws.target[..n], modes.keep_speed);
                ws.target[..n].iter_mut().for_each(|t| *t *= scale);
                ws.u0.copy_from_slice(&ws.target[..n]);
                for j in 0..n {
                    ws.q[j] = -2.0 * ws.u0[j];
                }
            }
            ArbitrationMode::Constrained => self.constrained_objective(ws, k, n),
            ArbitrationMode::SumOfSquares => {
                robot_mean(ws, n, modes.sum_of_squares_center);
                sum_of_squares_objective(ws, k, n, modes.sum_of_squares_epsilon);
            }
        }
        ws.command = command_values;
    }

    /// `max ⟨g, u⟩ s.t. ‖u − c‖_W ≤ r`, `g = J† v_H`, `c = κ ā_R`: closed
    /// form `u = c + η W⁻¹ g`, `r = η √(gᵀW⁻¹g)`, η keeping the operator's speed.
    fn constrained_objective(&self, ws: &mut ArbiterWorkspace, k: Option<usize>, n: usize) {
        let modes = &self.settings.modes;
        // The trust region's centre: κ times the belief-weighted robot action.
        robot_mean(ws, n, modes.constrained_center);
        mat_vec(ws.metric.inverse(), n, n, &ws.human, &mut ws.target[..n]);
        let s2 = dot(&ws.human, &ws.target[..n]);
        ws.chol.copy_from_slice(ws.metric.matrix());
        if s2.is_nan() || s2 <= 1e-300 || !cholesky_in_place(&mut ws.chol, n) {
            // No command (or a broken metric): the centre.
            joint_objective(ws, n, |ws, t| t.copy_from_slice(&ws.cone_c[..n]));
            return;
        }
        let eta = operator_speed_ratio(ws, k, n, &ws.target[..n], modes.keep_speed);
        for j in 0..n {
            ws.u0[j] = ws.cone_c[j] + eta * ws.target[j];
            ws.q[j] = -ws.human[j];
        }
        ws.p.fill(0.0);
        ws.radius = eta * s2.sqrt();
        // W = R Rᵀ (R lower, in ws.chol): ‖u − c‖_W = ‖Rᵀ(u − c)‖, so L = Rᵀ.
        for i in 0..n {
            for j in 0..n {
                ws.cone_l[i * n + j] = if j >= i { ws.chol[j + i * n] } else { 0.0 };
            }
        }
        let center = &mut ws.target[..n];
        center.copy_from_slice(&ws.cone_c[..n]);
        for i in 0..n {
            ws.cone_c[i] = (i..n).map(|j| ws.cone_l[i * n + j] * center[j]).sum();
        }
        ws.conic = true;
    }

    /// The metric `mode` reads into `ws.metric` (joint space) or
    /// `ws.task_metric`; false when a policy fails.
    pub(crate) fn compute_metric(&self, ws: &mut ArbiterWorkspace, mode: ArbitrationMode, q: &[f64]) -> bool {
        let Some(kind) = mode.metric() else { return true };
        let settings = &self.settings.metric;
        let task = kind == MetricKind::TaskFisher;
        let mut mixture =
            if task { MetricMixture::begin(&mut ws.task_scratch) } else { MetricMixture::begin(&mut ws.scratch) };
        let n = self.robot.nq();
        for g in 0..self.goals.len() {
            let belief = ws.beliefs[g];
            if belief < settings.min_belief {
                continue;
            }
            let policy = &*self.goals[g].policy;
            let state = &mut ws.states[g];
            let result = match kind {
                MetricKind::Hessian => {
                    hessian_metric(policy, state, q, &ws.velocity, settings.step, &mut ws.scratch, &mut ws.raw)
                }
                MetricKind::Fisher => {
                    let center = &ws.actions[g * n..(g + 1) * n];
                    let r = settings.sample_radius;
                    fisher_metric(policy, state, q, &ws.velocity, center, r, &mut ws.scratch, &mut ws.raw)
                }
                MetricKind::TaskFisher => self.task_fisher(ws, g, q),
            };
            if result.is_err() || ws.raw.iter().any(|x| !x.is_finite()) {
                return false;
            }
            if task {
                repair(&mut ws.raw[..9], settings.floor, &mut ws.task_scratch, &mut ws.task_goal_metric);
                mixture.add(&mut ws.task_scratch, belief, &ws.task_goal_metric);
            } else {
                repair(&mut ws.raw, settings.floor, &mut ws.scratch, &mut ws.goal_metric);
                mixture.add(&mut ws.scratch, belief, &ws.goal_metric);
            }
        }
        if task {
            mixture.finish(&mut ws.task_scratch, &mut ws.task_metric);
            ws.diagnostics.metric_condition = ws.task_metric.condition();
        } else {
            mixture.finish(&mut ws.scratch, &mut ws.metric);
            ws.diagnostics.metric_condition = ws.metric.condition();
        }
        true
    }

    /// The raw 3 × 3 task-space Fisher metric of goal `g` into `ws.raw[..9]`:
    /// joint samples around `q` (as the joint metric's), fitted from
    /// gripper position to gripper velocity `J(q_k) π(q_k)`.
    fn task_fisher(&self, ws: &mut ArbiterWorkspace, g: usize, q: &[f64]) -> Result<(), ControlError> {
        let n = self.robot.nq();
        let r = self.settings.metric.task_sample_radius;
        let policy = &*self.goals[g].policy;
        let p0 = ws.gripper_position;
        let mut fit = LwrFit::new(3, 3, &mut ws.task_scratch.normal, &mut ws.task_scratch.rhs);
        let mut y = [0.0; 3];
        linear_velocity(&ws.jac, n, &ws.actions[g * n..(g + 1) * n], &mut y);
        fit.add(&[], &y, 1.0, 1.0);
        for s in 0..sample_count(n) {
            sample_offset(s, n, r, &ws.scratch.directions, &mut ws.scratch.work[..n]);
            add_scaled(&mut ws.scratch.probe, q, 1.0, &ws.scratch.work[..n]);
            self.robot
                .forward_kinematics(&mut ws.probe_kin, &ws.scratch.probe)
                .map_err(|_| ControlError::NonFinite { what: "q", index: 0, value: f64::NAN })?;
            let pose = self
                .robot
                .frame_jacobian(&ws.probe_kin, self.gripper, ReferenceFrame::WorldAligned, &mut ws.probe_jac)
                .map_err(|_| ControlError::ForeignState)?;
            policy.probe(&mut ws.states[g], &ws.scratch.probe, &ws.velocity, &mut ws.scratch.action)?;
            linear_velocity(&ws.probe_jac, n, &ws.scratch.action, &mut y);
            let x = [pose.translation.x - p0[0], pose.translation.y - p0[1], pose.translation.z - p0[2]];
            fit.add(&x, &y, gaussian_weight(&ws.scratch.work[..n], r), 1.0);
        }
        fit.slope_symmetric_negated(&mut ws.raw[..9]);
        Ok(())
    }
}

/// `y = J_lin u` (the first three rows of a 6 × n Jacobian).
fn linear_velocity(jac: &nalgebra::Matrix6xX<f64>, n: usize, u: &[f64], y: &mut [f64; 3]) {
    let data = jac.as_slice();
    *y = [0.0; 3];
    for c in 0..n {
        for (r, yr) in y.iter_mut().enumerate() {
            *yr += data[6 * c + r] * u[c];
        }
    }
}

/// Copies the first `k` Jacobian rows (row-major) and the command.
fn load_task(ws: &mut ArbiterWorkspace, k: usize, v: &[f64]) {
    let n = ws.jac.ncols();
    let data = ws.jac.as_slice();
    for r in 0..k {
        for c in 0..n {
            ws.jk[r * n + c] = data[6 * c + r];
        }
    }
    ws.task[..k].copy_from_slice(v);
}

/// `N = J_kᵀJ_k + D` (n × n, column-major) with the damping `D = μI + Σᵢ
/// δᵢ vᵢvᵢᵀ` over the right singular vectors `vᵢ` of `J_k` whose singular
/// value `σᵢ` is below the threshold, `δᵢ = λ²(1 − (σᵢ/σ₀)²)` (Nakamura's
/// variable damping, per direction: only the directions losing rank slow
/// down, the others keep the operator's speed).
fn damped_normal(jk: &[f64], k: usize, n: usize, s: &super::DampingSettings, v: &mut [f64], out: &mut [f64]) {
    let mut m = [0.0; 36];
    for a in 0..k {
        for b in 0..k {
            m[a + b * k] = dot(&jk[a * n..(a + 1) * n], &jk[b * n..(b + 1) * n]);
        }
    }
    for c in 0..n {
        for r in 0..n {
            out[r + c * n] =
                (0..k).map(|a| jk[a * n + r] * jk[a * n + c]).sum::<f64>() + if r == c { s.floor } else { 0.0 };
        }
    }
    let (mut values, mut vectors) = ([0.0; 6], [0.0; 36]);
    symmetric_eigen(&mut m[..k * k], k, &mut values[..k], &mut vectors[..k * k]);
    for i in 0..k {
        let sigma = values[i].max(0.0).sqrt();
        let ratio = sigma / s.threshold;
        if ratio >= 1.0 || sigma < 1e-12 {
            continue;
        }
        let delta = s.max_damping * s.max_damping * (1.0 - ratio * ratio);
        // vᵢ = J_kᵀ uᵢ / σᵢ.
        for (c, vc) in v.iter_mut().enumerate().take(n) {
            *vc = (0..k).map(|a| jk[a * n + c] * vectors[a + i * k]).sum::<f64>() / sigma;
        }
        for c in 0..n {
            for r in 0..n {
                out[r + c * n] += delta * v[r] * v[c];
            }
        }
    }
}

/// `out = N⁻¹ J_kᵀ v` with `N` from [`damped_normal`] in `normal` (the
/// damped least-squares solution; `normal` is factorised in place).
fn dls(jk: &[f64], k: usize, n: usize, normal: &mut [f64], v: &[f64], out: &mut [f64]) {
    for (c, o) in out.iter_mut().enumerate().take(n) {
        *o = (0..k).map(|a| jk[a * n + c] * v[a]).sum();
    }
    if cholesky_in_place(normal, n) {
        cholesky_solve_factored(normal, n, out);
    } else {
        out.fill(0.0);
    }
}

/// `min ‖J_k (u − h)‖² + ν‖u − h‖²` with `h = J†t` the damped
/// least-squares joint velocity of the task target `t = ws.task[..k]`: its
/// minimiser is `h`, and when a constraint binds the command gives way in
/// the null space (weight ν) before it gives way in the task (weight 1).
/// Minimising `‖J_k u − t‖²` alone would leave the null space nearly flat,
/// and the constrained solution ill-defined.
fn task_objective(ws: &mut ArbiterWorkspace, k: usize, n: usize, damping: &super::DampingSettings) {
    damped_normal(&ws.jk, k, n, damping, &mut ws.column, &mut ws.chol);
    let task = ws.task;
    dls(&ws.jk, k, n, &mut ws.chol, &task[..k], &mut ws.u0);
    let nu = damping.null_space_weight;
    for c in 0..n {
        for r in 0..n {
            let jtj: f64 = (0..k).map(|a| ws.jk[a * n + r] * ws.jk[a * n + c]).sum();
            ws.p[r + c * n] = 2.0 * (jtj + if r == c { nu } else { 0.0 });
        }
    }
    mat_vec(&ws.p, n, n, &ws.u0, &mut ws.q);
    ws.q.iter_mut().for_each(|q| *q = -*q);
}

/// `min ‖u − t‖²` with `t` written by `fill` into `ws.target[..n]`.
fn joint_objective(ws: &mut ArbiterWorkspace, n: usize, fill: impl FnOnce(&ArbiterWorkspace, &mut [f64])) {
    let mut target = std::mem::take(&mut ws.target);
    fill(ws, &mut target[..n]);
    ws.target = target;
    ws.p.fill(0.0);
    for j in 0..n {
        ws.p[j + j * n] = 2.0;
        ws.q[j] = -2.0 * ws.target[j];
        ws.u0[j] = ws.target[j];
    }
}

/// `ws.cone_c = κ ā_R`, the belief-weighted robot action scaled by `κ`.
fn robot_mean(ws: &mut ArbiterWorkspace, n: usize, kappa: f64) {
    for j in 0..n {
        let mean: f64 = ws.beliefs.iter().enumerate().map(|(g, b)| b * ws.actions[g * n + j]).sum();
        ws.cone_c[j] = kappa * mean;
    }
}

/// `min ‖J u − v‖²/ε + (u − c)ᵀW(u − c)` with `c = ws.cone_c` (from
/// [`robot_mean`]; J = I for joint commands).
fn sum_of_squares_objective(ws: &mut ArbiterWorkspace, k: Option<usize>, n: usize, eps: f64) {
    let w = ws.metric.matrix();
    for c in 0..n {
        for r in 0..n {
            let jtj: f64 = match k {
                Some(k) => (0..k).map(|a| ws.jk[a * n + r] * ws.jk[a * n + c]).sum(),
                None => f64::from(r == c),
            };
            ws.p[r + c * n] = 2.0 * (jtj / eps + w[r + c * n]);
        }
        let jtv = match k {
            Some(k) => (0..k).map(|a| ws.jk[a * n + c] * ws.task[a]).sum::<f64>(),
            None => ws.human[c],
        };
        let wc: f64 = (0..n).map(|r| w[c + r * n] * ws.cone_c[r]).sum();
        ws.q[c] = -2.0 * (jtv / eps + wc);
    }
    ws.chol.copy_from_slice(&ws.p);
    for j in 0..n {
        ws.u0[j] = -ws.q[j];
    }
    if cholesky_in_place(&mut ws.chol, n) {
        cholesky_solve_factored(&ws.chol, n, &mut ws.u0);
    } else {
        ws.u0.fill(0.0);
    }
}

/// The factor that brings `shaped` to the operator's speed: task speed
/// `‖J_k shaped‖` against `‖v‖` for task commands, joint speed for joint
/// commands; 1 when `keep` is off or the shaped command does not move.
fn operator_speed_ratio(ws: &ArbiterWorkspace, k: Option<usize>, n: usize, shaped: &[f64], keep: bool) -> f64 {
    match k {
        Some(k) => {
            let mut moved = [0.0; 6];
            for (a, m) in moved.iter_mut().enumerate().take(k) {
                *m = dot(&ws.jk[a * n..(a + 1) * n], shaped);
            }
            speed_ratio(norm(&ws.task[..k]), norm(&moved[..k]), keep)
        }
        None => speed_ratio(norm(&ws.human), norm(shaped), keep),
    }
}

fn speed_ratio(wanted: f64, got: f64, keep: bool) -> f64 {
    if keep && got > 1e-12 { wanted / got } else { 1.0 }
}

fn norm(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}
