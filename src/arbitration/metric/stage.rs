//! Stage 4 of a tick: the metric of the mode — each goal's Hessian or
//! Fisher metric from its policy, repaired, and the mixture over goals by
//! belief (Algorithm 2) — into the [`MetricStage`](crate::arbitration::workspace::MetricStage).

use super::{
    LwrFit, MetricMixture, fisher_metric, gaussian_weight, hessian_metric, repair, sample_count, sample_offset,
};
use crate::arbitration::arbiter::Arbiter;
use crate::arbitration::modes::{ArbitrationMode, MetricKind};
use crate::arbitration::workspace::ArbiterWorkspace;
use crate::control::ControlError;
use crate::robot::ReferenceFrame;
use tandem_solvers::small::add_scaled;

impl Arbiter {
    /// The metric `mode` reads into `ws.metric.joint` (joint space) or
    /// `ws.metric.task`; false when a policy fails.
    pub(crate) fn compute_metric(&self, ws: &mut ArbiterWorkspace, mode: ArbitrationMode, q: &[f64]) -> bool {
        let Some(kind) = mode.metric() else { return true };
        let settings = &self.settings.metric;
        let task = kind == MetricKind::TaskFisher;
        let mut mixture = if task {
            MetricMixture::begin(&mut ws.metric.task_scratch)
        } else {
            MetricMixture::begin(&mut ws.metric.scratch)
        };
        let n = self.robot.nq();
        for g in 0..self.goals.len() {
            let belief = ws.intent.beliefs[g];
            if belief < settings.min_belief {
                continue;
            }
            let policy = &*self.goals[g].policy;
            let state = &mut ws.robot.states[g];
            let result = match kind {
                MetricKind::Hessian => hessian_metric(
                    policy,
                    state,
                    q,
                    &ws.input.velocity,
                    settings.step,
                    &mut ws.metric.scratch,
                    &mut ws.metric.raw[..n * n],
                ),
                MetricKind::Fisher => {
                    let center = &ws.robot.actions[g * n..(g + 1) * n];
                    let r = settings.sample_radius;
                    fisher_metric(
                        policy,
                        state,
                        q,
                        &ws.input.velocity,
                        center,
                        r,
                        &mut ws.metric.scratch,
                        &mut ws.metric.raw[..n * n],
                    )
                }
                MetricKind::TaskFisher => self.task_fisher(ws, g, q),
            };
            let size = if task { 9 } else { n * n };
            if result.is_err() || ws.metric.raw[..size].iter().any(|x| !x.is_finite()) {
                return false;
            }
            if task {
                repair(&mut ws.metric.raw[..9], settings.floor, &mut ws.metric.task_scratch, &mut ws.metric.goal_task);
                mixture.add(&mut ws.metric.task_scratch, belief, &ws.metric.goal_task);
            } else {
                repair(&mut ws.metric.raw[..n * n], settings.floor, &mut ws.metric.scratch, &mut ws.metric.goal_joint);
                mixture.add(&mut ws.metric.scratch, belief, &ws.metric.goal_joint);
            }
        }
        if task {
            mixture.finish(&mut ws.metric.task_scratch, &mut ws.metric.task);
            ws.diagnostics.metric_condition = ws.metric.task.condition();
        } else {
            mixture.finish(&mut ws.metric.scratch, &mut ws.metric.joint);
            ws.diagnostics.metric_condition = ws.metric.joint.condition();
        }
        true
    }

    /// The raw 3 × 3 task-space Fisher metric of goal `g` into `ws.metric.raw[..9]`:
    /// joint samples around `q` (as the joint metric's), fitted from
    /// gripper position to gripper velocity `J(q_k) π(q_k)`.
    fn task_fisher(&self, ws: &mut ArbiterWorkspace, g: usize, q: &[f64]) -> Result<(), ControlError> {
        let n = self.robot.nq();
        let r = self.settings.metric.task_sample_radius;
        let policy = &*self.goals[g].policy;
        let p0 = ws.input.gripper_position;
        let mut fit = LwrFit::new(3, 3, &mut ws.metric.task_scratch.normal, &mut ws.metric.task_scratch.rhs);
        let mut y = [0.0; 3];
        linear_velocity(&ws.input.jac, n, &ws.robot.actions[g * n..(g + 1) * n], &mut y);
        fit.add(&[], &y, 1.0, 1.0);
        for s in 0..sample_count(n) {
            sample_offset(s, n, r, &ws.metric.scratch.directions, &mut ws.metric.scratch.work[..n]);
            add_scaled(&mut ws.metric.scratch.probe, q, 1.0, &ws.metric.scratch.work[..n]);
            self.robot
                .forward_kinematics(&mut ws.metric.probe_kin, &ws.metric.scratch.probe)
                .map_err(|_| ControlError::NonFinite { what: "q", index: 0, value: f64::NAN })?;
            let pose = self
                .robot
                .frame_jacobian(
                    &ws.metric.probe_kin,
                    self.gripper,
                    ReferenceFrame::WorldAligned,
                    &mut ws.metric.probe_jac,
                )
                .map_err(|_| ControlError::ForeignState)?;
            policy.probe(
                &mut ws.robot.states[g],
                &ws.metric.scratch.probe,
                &ws.input.velocity,
                &mut ws.metric.scratch.action,
            )?;
            linear_velocity(&ws.metric.probe_jac, n, &ws.metric.scratch.action, &mut y);
            let x = [pose.translation.x - p0[0], pose.translation.y - p0[1], pose.translation.z - p0[2]];
            fit.add(&x, &y, gaussian_weight(&ws.metric.scratch.work[..n], r), 1.0);
        }
        fit.slope_symmetric_negated(&mut ws.metric.raw[..9]);
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
