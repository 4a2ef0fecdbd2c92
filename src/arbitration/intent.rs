//! Goal prediction from the observed gripper path (Dragan & Srinivasa; the
//! dissertation's §6.5: cost = sum of squared velocities).
//!
//! `P(g | ξ_{S→U}) ∝ exp(−C(ξ_{S→U}) − V_g(U)) / exp(−V_g(S)) · P(g)`: a
//! goal is likely when the path so far plus the best way on to it costs
//! little more than the best way to it from the start. With `C = ∫‖ẋ‖² dt`
//! over a path of duration `T`, and `V_g` the optimal cost-to-go at the
//! operator's rms speed `s̄ = √(C/T)` (a straight line: `V_g(x) = s̄ ‖x − g‖`),
//! dividing by `s̄ ℓ` gives a dimensionless score
//!
//! ```text
//! score_g = (√(C·T) + ‖U − g‖ − ‖S − g‖) / ℓ,    b_g ∝ P(g) · exp(−score_g)
//! ```
//!
//! `√(C·T)` is at least the path length (equal at constant speed), so a
//! straight path at constant speed toward `g` scores 0 and every detour
//! scores its excess length in units of the length scale `ℓ`. Each update
//! is O(goals), in log space. The largest belief is capped (`cap`, 0.99 as
//! in ADA) so that assistance never becomes certain of a guess.

use crate::settings::{InvalidSetting, check, positive};

/// Settings of the goal posterior.
///
/// ```
/// # use tandem::arbitration::IntentSettings;
/// let s = IntentSettings::default();
/// assert_eq!((s.length_scale, s.cap), (0.05, 0.99));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntentSettings {
    /// Length scale ℓ of the score (m): a goal whose detour is ℓ longer is
    /// e times less likely.
    pub length_scale: f64,
    /// Cap of the largest belief.
    pub cap: f64,
}

impl Default for IntentSettings {
    fn default() -> Self {
        // A 5 cm detour makes a goal e times less likely; ADA's cap.
        IntentSettings { length_scale: 0.05, cap: 0.99 }
    }
}

impl IntentSettings {
    /// Checks every setting: a length scale above 0, a cap in (0, 1].
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        positive("length_scale", self.length_scale, "m")?;
        check("cap", self.cap, self.cap > 0.0 && self.cap <= 1.0, "in (0, 1]")
    }
}

/// The goal posterior over a fixed set of goal positions (world, m),
/// updated from gripper positions. Allocation-free after construction.
#[derive(Debug, Clone)]
pub struct IntentEstimator {
    settings: IntentSettings,
    goals: Vec<[f64; 3]>,
    log_prior: Vec<f64>,
    start: Option<[f64; 3]>,
    last: [f64; 3],
    /// ∫‖ẋ‖² dt (m²/s) and the elapsed time (s).
    cost: f64,
    elapsed: f64,
    beliefs: Vec<f64>,
}

impl IntentEstimator {
    /// An estimator over `goals` with a uniform prior.
    pub fn new(goals: &[[f64; 3]], settings: IntentSettings) -> Self {
        let k = goals.len();
        let uniform = if k == 0 { 0.0 } else { 1.0 / k as f64 };
        IntentEstimator {
            settings,
            goals: goals.to_vec(),
            log_prior: vec![uniform.ln(); k],
            start: None,
            last: [0.0; 3],
            cost: 0.0,
            elapsed: 0.0,
            beliefs: vec![uniform; k],
        }
    }

    /// Sets the prior (non-negative weights, normalised here).
    pub fn set_prior(&mut self, prior: &[f64]) {
        let total: f64 = prior.iter().sum();
        for (l, p) in self.log_prior.iter_mut().zip(prior) {
            *l = (p / total).ln();
        }
        self.reset();
    }

    /// Forgets the path (a new episode starts at the next observation).
    pub fn reset(&mut self) {
        self.start = None;
        self.cost = 0.0;
        self.elapsed = 0.0;
        let prior = &self.log_prior;
        for (b, l) in self.beliefs.iter_mut().zip(prior) {
            *b = l.exp();
        }
    }

    /// Observes the gripper at `position` (m, world), `dt` seconds after
    /// the previous observation; returns the updated beliefs. Non-finite
    /// input is ignored (the beliefs stay).
    pub fn observe(&mut self, position: [f64; 3], dt: f64) -> &[f64] {
        if !(position.iter().all(|x| x.is_finite()) && dt.is_finite() && dt > 0.0) {
            return &self.beliefs;
        }
        match self.start {
            None => {
                self.start = Some(position);
            }
            Some(_) => {
                let step2: f64 = (0..3).map(|i| (position[i] - self.last[i]).powi(2)).sum();
                self.cost += step2 / dt;
                self.elapsed += dt;
            }
        }
        self.last = position;
        self.update();
        &self.beliefs
    }

    /// The current beliefs, one per goal.
    pub fn beliefs(&self) -> &[f64] {
        &self.beliefs
    }

    fn update(&mut self) {
        let Some(start) = self.start else { return };
        let length = (self.cost * self.elapsed).sqrt();
        let distance = |a: &[f64; 3], b: &[f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt();
        let scale = self.settings.length_scale.max(1e-9);
        let mut top = f64::NEG_INFINITY;
        for (g, goal) in self.goals.iter().enumerate() {
            let score = (length + distance(&self.last, goal) - distance(&start, goal)) / scale;
            self.beliefs[g] = self.log_prior[g] - score;
            top = top.max(self.beliefs[g]);
        }
        let mut total = 0.0;
        for b in &mut self.beliefs {
            *b = (*b - top).exp();
            total += *b;
        }
        self.beliefs.iter_mut().for_each(|b| *b /= total);
        cap_beliefs(&mut self.beliefs, self.settings.cap);
    }
}

/// Caps the largest belief at `cap`, sharing the excess among the others in
/// proportion (evenly when they are all zero).
pub(crate) fn cap_beliefs(beliefs: &mut [f64], cap: f64) {
    let k = beliefs.len();
    if k < 2 {
        return;
    }
    let (top, &max) = beliefs.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).expect("two or more goals");
    if max <= cap {
        return;
    }
    // The others' total, summed (1 − max loses digits when max is near 1).
    let rest: f64 = beliefs.iter().enumerate().filter(|(g, _)| *g != top).map(|(_, b)| b).sum();
    let share = max + rest - cap;
    for (g, b) in beliefs.iter_mut().enumerate() {
        if g == top {
            *b = cap;
        } else if rest > 0.0 {
            *b *= share / rest;
        } else {
            *b = share / (k - 1) as f64;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_path_toward_a_goal_makes_it_likely() {
        let goals = [[0.5, 0.2, 0.0], [0.5, -0.2, 0.0]];
        let mut intent = IntentEstimator::new(&goals, IntentSettings::default());
        assert_eq!(intent.beliefs(), &[0.5, 0.5]);
        for k in 0..=20 {
            let t = k as f64 / 20.0 * 0.6;
            intent.observe([t * 0.5, t * 0.2, 0.0], 0.1);
        }
        let b = intent.beliefs();
        assert!(b[0] > 0.9 && (b[0] + b[1] - 1.0).abs() < 1e-12, "{b:?}");
        // Straight at constant speed toward goal 0: its score is 0, so
        // b₀/b₁ = exp(score₁).
        let start = [0.0, 0.0, 0.0];
        let here = [0.3, 0.12, 0.0];
        let d = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt();
        let length = d(start, here);
        let score1 = (length + d(here, goals[1]) - d(start, goals[1])) / 0.05;
        let want = 1.0 / (1.0 + (-score1).exp());
        assert!((b[0] - want.min(0.99)).abs() < 1e-9, "{} vs {want}", b[0]);
    }

    #[test]
    fn beliefs_are_capped_and_bad_input_is_ignored() {
        let goals = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let mut intent = IntentEstimator::new(&goals, IntentSettings::default());
        for k in 0..30 {
            intent.observe([0.03 * k as f64, 0.0, 0.0], 0.05);
        }
        let b = intent.beliefs().to_vec();
        assert!((b[0] - 0.99).abs() < 1e-12 && (b.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{b:?}");
        intent.observe([f64::NAN, 0.0, 0.0], 0.05);
        assert_eq!(intent.beliefs(), &b[..]);
        intent.reset();
        assert!((intent.beliefs()[0] - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn capping_shares_the_excess() {
        let mut b = [0.999, 0.001, 0.0];
        cap_beliefs(&mut b, 0.99);
        assert!((b[0] - 0.99).abs() < 1e-15 && (b[1] - 0.01).abs() < 1e-12 && b[2] == 0.0);
        let mut b = [1.0, 0.0, 0.0];
        cap_beliefs(&mut b, 0.9);
        assert!((b[1] - 0.05).abs() < 1e-15 && (b[2] - 0.05).abs() < 1e-15);
    }
}
