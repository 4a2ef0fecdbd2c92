//! The damped Gauss-Newton step of the inner loop, with the inequality
//! rows' active set following the step (semi-smooth Newton on the hinges).

use super::{ACTIVATION_ROUNDS, AugmentedLagrangian};

impl AugmentedLagrangian {
    /// Solves `(JᵀJ + δI) s = −Jᵀφ` into `step`, raising `δ` until the step
    /// is within `max_step`, and
    /// returns the decrease the Gauss-Newton model predicts, or `None` when
    /// the damped matrix cannot be factorised.
    ///
    /// The inequality rows' active set follows the step (see
    /// [`update_active_set`](Self::update_active_set)) for up to
    /// `ACTIVATION_ROUNDS` re-solves: otherwise a large penalty turns every
    /// step that crosses a constraint into a rejection.
    pub(super) fn damped_step(&mut self, merit: f64) -> Option<f64> {
        self.augmented.copy_from(&self.undamped);
        self.rhs.copy_from_slice(&self.gradient);
        let (mu, rows) = (self.penalty, &self.current.inequality);
        self.active.clear();
        self.active
            .extend((0..rows.len()).map(|r| rows.value(r) + self.inequality.get(rows.key(r)) / (2.0 * mu) > 0.0));
        let mut rounds = 0;
        // Rows of the damped matrix before `from` are unchanged since the
        // last factorisation, and so are those of its factor.
        let mut from = 0;
        loop {
            self.normal.copy_rows_from(&self.augmented, from);
            self.normal.add_to_diagonal_from(self.damping, from);
            self.normal.factorize_from(from).ok()?;
            for (s, g) in self.step.iter_mut().zip(&self.rhs) {
                *s = -g;
            }
            self.normal.solve_in_place(&mut self.step);
            // A step beyond the trust bound is shortened by damping, which
            // bends it towards the gradient, not by scaling it.
            if self.step_norm() > self.settings.max_step {
                self.damping *= 4.0;
                if self.damping > 1e20 * self.undamped.max_diagonal().max(1.0) {
                    return None;
                }
                from = 0;
                continue;
            }
            if rounds == ACTIVATION_ROUNDS {
                break;
            }
            match self.update_active_set() {
                Some(first) => from = first,
                None => break,
            }
            rounds += 1;
        }
        let predicted = merit - self.model_merit();
        predicted.is_finite().then_some(predicted)
    }

    /// Semi-smooth Newton on the hinges: makes the model's set of active
    /// inequality rows those with `g + λ/2μ + J·step > 0`, adding and
    /// removing rows; the first variable of the changed rows when the set
    /// changed. At a fixed point the step minimises the damped
    /// piecewise-quadratic model exactly.
    fn update_active_set(&mut self) -> Option<usize> {
        let (mu, rows) = (self.penalty, &self.current.inequality);
        let mut changed: Option<usize> = None;
        for r in 0..rows.len() {
            let v = rows.value(r) + self.inequality.get(rows.key(r)) / (2.0 * mu);
            let (first, jac) = rows.gradient(r);
            let moved: f64 = jac.iter().zip(&self.step[first..]).map(|(j, s)| j * s).sum();
            let active = v + moved > 0.0;
            if active != self.active[r] {
                let sign = if active { mu } else { -mu };
                self.augmented.add_outer(first, jac, sign);
                for (g, j) in self.rhs[first..first + jac.len()].iter_mut().zip(jac) {
                    *g += sign * v * j;
                }
                self.active[r] = active;
                changed = Some(changed.map_or(first, |c| c.min(first)));
            }
        }
        changed
    }

    /// The Gauss-Newton model of the merit after `step`: every row
    /// linearised, inequalities through their hinge.
    fn model_merit(&self) -> f64 {
        self.rows(&self.current)
            .map(|(block, r, w, v, hinge)| {
                let (first, jac) = block.gradient(r);
                let lin = v + jac.iter().zip(&self.step[first..]).map(|(j, s)| j * s).sum::<f64>();
                let lin = if hinge { lin.max(0.0) } else { lin };
                w * lin * lin
            })
            .sum()
    }
}
