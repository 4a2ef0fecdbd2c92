//! Each mode's objective and closed form, and the metrics they read.
//!
//! Task commands use the first `k` rows of the gripper Jacobian (`k = 3`
//! for a linear velocity, 6 for a twist); `J†v` is the damped least-squares
//! solution `(JᵀJ + D)⁻¹Jᵀv` with `D` from [`DampingSettings`](super::DampingSettings).

use super::arbiter::{Arbiter, task_dim};
use super::command::HumanCommand;
use super::modes::{ArbitrationMode, MetricSpace};
use super::workspace::ArbiterWorkspace;
use tandem_solvers::small::{cholesky_in_place, cholesky_solve_factored, dot, mat_vec, symmetric_eigen};

/// Largest command component kept as given (m/s, rad/s): larger commands
/// are scaled down to it, direction kept.
const COMMAND_CAP: f64 = 1e3;

impl Arbiter {
    /// Fills `ws.objective.p`, `ws.objective.q` (and the cone) with `mode`'s problem and
    /// `ws.objective.u0` with its unconstrained solution.
    pub(crate) fn objective(&self, ws: &mut ArbiterWorkspace, mode: ArbitrationMode, command: &HumanCommand<'_>) {
        let n = self.robot.nq();
        ws.objective.conic = false;
        ws.objective.damped = false;
        let k = task_dim(command);
        // Commands beyond any physical speed keep their direction only: the
        // hard limits clip the magnitude, and the arithmetic stays finite.
        let given = command.values();
        let largest = given.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let scale = if largest > COMMAND_CAP { COMMAND_CAP / largest } else { 1.0 };
        let mut command_values = std::mem::take(&mut ws.objective.command);
        for (c, x) in command_values.iter_mut().zip(given) {
            *c = x * scale;
        }
        let v = &command_values[..given.len()];
        let damping = &self.settings.damping;
        match k {
            Some(k) => {
                load_task(ws, k, v);
                ws.objective.damped =
                    damped_normal(&ws.objective.jk, k, n, damping, &mut ws.objective.column, &mut ws.objective.chol);
                dls(&ws.objective.jk, k, n, &mut ws.objective.chol, v, &mut ws.objective.human);
            }
            None => ws.objective.human.copy_from_slice(v),
        }
        let modes = &self.settings.modes;
        match mode {
            // `Learned` reaches here as direct control with the learned command.
            ArbitrationMode::DirectControl | ArbitrationMode::ObstacleAvoidance | ArbitrationMode::Learned => match k {
                Some(k) => task_objective(ws, k, n, damping),
                None => joint_objective(ws, n, |ws, t| t.copy_from_slice(&ws.objective.human)),
            },
            ArbitrationMode::LinearBlending(style) => {
                let alpha = modes.blending_alpha(style, ws.diagnostics.confidence, self.goals.len());
                ws.diagnostics.alpha = alpha;
                let goal = ws.diagnostics.goal.unwrap_or(0);
                joint_objective(ws, n, |ws, t| {
                    let robot = ws.robot.actions.get(goal * n..(goal + 1) * n).filter(|_| alpha > 0.0);
                    for (j, t) in t.iter_mut().enumerate() {
                        *t = alpha * robot.map_or(0.0, |a| a[j]) + (1.0 - alpha) * ws.objective.human[j];
                    }
                });
            }
            ArbitrationMode::NaturalGradient(MetricSpace::Task) if k.is_some() => {
                let k = k.unwrap_or(3);
                // t = F_t⁻¹ v_lin at the operator's speed; angular rates pass through.
                let mut shaped = [0.0; 3];
                mat_vec(ws.metric.task.inverse(), 3, 3, &ws.objective.task[..3], &mut shaped);
                let scale = speed_ratio(norm(&ws.objective.task[..3]), norm(&shaped), modes.keep_speed);
                for (t, s) in ws.objective.task.iter_mut().zip(shaped) {
                    *t = scale * s;
                }
                task_objective(ws, k, n, damping);
            }
            ArbitrationMode::NaturalGradient(_) => {
                joint_objective(ws, n, |ws, t| mat_vec(ws.metric.joint.inverse(), n, n, &ws.objective.human, t));
                let scale = operator_speed_ratio(ws, k, n, &ws.objective.target[..n], modes.keep_speed);
                ws.objective.target[..n].iter_mut().for_each(|t| *t *= scale);
                ws.objective.u0.copy_from_slice(&ws.objective.target[..n]);
                for j in 0..n {
                    ws.objective.q[j] = -2.0 * ws.objective.u0[j];
                }
            }
            ArbitrationMode::Constrained => self.constrained_objective(ws, k, n),
            ArbitrationMode::SumOfSquares => {
                robot_mean(ws, n, modes.sum_of_squares_center);
                sum_of_squares_objective(ws, k, n, modes.sum_of_squares_epsilon);
            }
        }
        ws.objective.command = command_values;
    }

    /// `max ⟨g, u⟩ s.t. ‖u − c‖_W ≤ r`, `g = J† v_H`, `c = κ ā_R`: closed
    /// form `u = c + η W⁻¹ g`, `r = η √(gᵀW⁻¹g)`, η keeping the operator's speed.
    fn constrained_objective(&self, ws: &mut ArbiterWorkspace, k: Option<usize>, n: usize) {
        let modes = &self.settings.modes;
        // The trust region's centre: κ times the belief-weighted robot action.
        robot_mean(ws, n, modes.constrained_center);
        mat_vec(ws.metric.joint.inverse(), n, n, &ws.objective.human, &mut ws.objective.target[..n]);
        let s2 = dot(&ws.objective.human, &ws.objective.target[..n]);
        ws.objective.chol.copy_from_slice(ws.metric.joint.matrix());
        if s2.is_nan() || s2 <= 1e-300 || !cholesky_in_place(&mut ws.objective.chol, n) {
            // No command (or a broken metric): the centre.
            joint_objective(ws, n, |ws, t| t.copy_from_slice(&ws.objective.cone_c[..n]));
            return;
        }
        let eta = operator_speed_ratio(ws, k, n, &ws.objective.target[..n], modes.keep_speed);
        for j in 0..n {
            ws.objective.u0[j] = ws.objective.cone_c[j] + eta * ws.objective.target[j];
            ws.objective.q[j] = -ws.objective.human[j];
        }
        ws.objective.p.fill(0.0);
        ws.objective.radius = eta * s2.sqrt();
        // W = R Rᵀ (R lower, in ws.objective.chol): ‖u − c‖_W = ‖Rᵀ(u − c)‖, so L = Rᵀ.
        for i in 0..n {
            for j in 0..n {
                ws.objective.cone_l[i * n + j] = if j >= i { ws.objective.chol[j + i * n] } else { 0.0 };
            }
        }
        let center = &mut ws.objective.target[..n];
        center.copy_from_slice(&ws.objective.cone_c[..n]);
        for i in 0..n {
            ws.objective.cone_c[i] = (i..n).map(|j| ws.objective.cone_l[i * n + j] * center[j]).sum();
        }
        ws.objective.conic = true;
    }
}

/// Copies the first `k` Jacobian rows (row-major) and the command.
fn load_task(ws: &mut ArbiterWorkspace, k: usize, v: &[f64]) {
    let n = ws.input.jac.ncols();
    let data = ws.input.jac.as_slice();
    for r in 0..k {
        for c in 0..n {
            ws.objective.jk[r * n + c] = data[6 * c + r];
        }
    }
    ws.objective.task[..k].copy_from_slice(v);
}

/// `N = J_kᵀJ_k + D` (n × n, column-major) with the damping `D = μI + Σᵢ
/// δᵢ vᵢvᵢᵀ` over the right singular vectors `vᵢ` of `J_k` whose singular
/// value `σᵢ` is below the threshold, `δᵢ = λ²(1 − (σᵢ/σ₀)²)` (Nakamura's
/// variable damping, per direction: only the directions losing rank slow
/// down, the others keep the operator's speed). Returns whether a
/// direction was damped (a singular value below the threshold).
fn damped_normal(jk: &[f64], k: usize, n: usize, s: &super::DampingSettings, v: &mut [f64], out: &mut [f64]) -> bool {
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
    let mut damped = false;
    for i in 0..k {
        let sigma = values[i].max(0.0).sqrt();
        let ratio = sigma / s.threshold;
        if ratio >= 1.0 || sigma < 1e-12 {
            continue;
        }
        let delta = s.max_damping * s.max_damping * (1.0 - ratio * ratio);
        damped = true;
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
    damped
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
/// least-squares joint velocity of the task target `t = ws.objective.task[..k]`: its
/// minimiser is `h`, and when a constraint binds the command gives way in
/// the null space (weight ν) before it gives way in the task (weight 1).
/// Minimising `‖J_k u − t‖²` alone would leave the null space nearly flat,
/// and the constrained solution ill-defined.
fn task_objective(ws: &mut ArbiterWorkspace, k: usize, n: usize, damping: &super::DampingSettings) {
    let _ = damped_normal(&ws.objective.jk, k, n, damping, &mut ws.objective.column, &mut ws.objective.chol);
    let task = ws.objective.task;
    dls(&ws.objective.jk, k, n, &mut ws.objective.chol, &task[..k], &mut ws.objective.u0);
    let nu = damping.null_space_weight;
    for c in 0..n {
        for r in 0..n {
            let jtj: f64 = (0..k).map(|a| ws.objective.jk[a * n + r] * ws.objective.jk[a * n + c]).sum();
            ws.objective.p[r + c * n] = 2.0 * (jtj + if r == c { nu } else { 0.0 });
        }
    }
    mat_vec(&ws.objective.p, n, n, &ws.objective.u0, &mut ws.objective.q);
    ws.objective.q.iter_mut().for_each(|q| *q = -*q);
}

/// `min ‖u − t‖²` with `t` written by `fill` into `ws.objective.target[..n]`.
fn joint_objective(ws: &mut ArbiterWorkspace, n: usize, fill: impl FnOnce(&ArbiterWorkspace, &mut [f64])) {
    let mut target = std::mem::take(&mut ws.objective.target);
    fill(ws, &mut target[..n]);
    ws.objective.target = target;
    ws.objective.p.fill(0.0);
    for j in 0..n {
        ws.objective.p[j + j * n] = 2.0;
        ws.objective.q[j] = -2.0 * ws.objective.target[j];
        ws.objective.u0[j] = ws.objective.target[j];
    }
}

/// `ws.objective.cone_c = κ ā_R`, the belief-weighted robot action scaled by `κ`.
fn robot_mean(ws: &mut ArbiterWorkspace, n: usize, kappa: f64) {
    for j in 0..n {
        let mean: f64 = ws.intent.beliefs.iter().enumerate().map(|(g, b)| b * ws.robot.actions[g * n + j]).sum();
        ws.objective.cone_c[j] = kappa * mean;
    }
}

/// `min ‖J u − v‖²/ε + (u − c)ᵀW(u − c)` with `c = ws.objective.cone_c` (from
/// [`robot_mean`]; J = I for joint commands).
fn sum_of_squares_objective(ws: &mut ArbiterWorkspace, k: Option<usize>, n: usize, eps: f64) {
    let w = ws.metric.joint.matrix();
    for c in 0..n {
        for r in 0..n {
            let jtj: f64 = match k {
                Some(k) => (0..k).map(|a| ws.objective.jk[a * n + r] * ws.objective.jk[a * n + c]).sum(),
                None => f64::from(r == c),
            };
            ws.objective.p[r + c * n] = 2.0 * (jtj / eps + w[r + c * n]);
        }
        let jtv = match k {
            Some(k) => (0..k).map(|a| ws.objective.jk[a * n + c] * ws.objective.task[a]).sum::<f64>(),
            None => ws.objective.human[c],
        };
        let wc: f64 = (0..n).map(|r| w[c + r * n] * ws.objective.cone_c[r]).sum();
        ws.objective.q[c] = -2.0 * (jtv / eps + wc);
    }
    ws.objective.chol.copy_from_slice(&ws.objective.p);
    for j in 0..n {
        ws.objective.u0[j] = -ws.objective.q[j];
    }
    if cholesky_in_place(&mut ws.objective.chol, n) {
        cholesky_solve_factored(&ws.objective.chol, n, &mut ws.objective.u0);
    } else {
        ws.objective.u0.fill(0.0);
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
                *m = dot(&ws.objective.jk[a * n..(a + 1) * n], shaped);
            }
            speed_ratio(norm(&ws.objective.task[..k]), norm(&moved[..k]), keep)
        }
        None => speed_ratio(norm(&ws.objective.human), norm(shaped), keep),
    }
}

fn speed_ratio(wanted: f64, got: f64, keep: bool) -> f64 {
    if keep && got > 1e-12 { wanted / got } else { 1.0 }
}

fn norm(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}
