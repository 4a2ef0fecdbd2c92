//! The augmented-Lagrangian / Levenberg-Marquardt solver.

use super::{LeastSquaresProblem, Residuals, RowBlock};
use crate::banded::SymmetricBand;
use std::time::{Duration, Instant};
use thiserror::Error;

mod step;

/// Settings of [`AugmentedLagrangian`], with documented defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverSettings {
    /// Outer (multiplier update) iterations at most. Default 30.
    pub max_outer_iterations: usize,
    /// Accepted Gauss-Newton steps per outer iteration at most. Default 100.
    pub max_inner_steps: usize,
    /// Problem evaluations in all at most. Default 2000.
    pub max_evaluations: usize,
    /// The inner loop has converged when the next step is below this in
    /// ∞-norm (variable units). Default 1e-6.
    pub step_tolerance: f64,
    /// ... or when it decreases (or is predicted to decrease) the augmented
    /// Lagrangian by less than this fraction of `1 + Σ r²`. Default 1e-10.
    pub cost_tolerance: f64,
    /// Largest `|h|` of a converged solution. Default 1e-5.
    pub equality_tolerance: f64,
    /// Largest `g` of a converged solution. Default 1e-5.
    pub inequality_tolerance: f64,
    /// First penalty `μ`, relative to the ratio of the largest diagonal
    /// entries of the cost's and the constraints' `JᵀJ` at the start (so
    /// that constraints weigh about this much more than the cost whatever
    /// their units). Default 10.
    pub initial_penalty: f64,
    /// Factor on `μ` when the violation shrank less than 4×. Default 10.
    pub penalty_increase: f64,
    /// Largest `μ`; a problem still infeasible there is reported
    /// [`Termination::Infeasible`]. Default 1e9.
    pub max_penalty: f64,
    /// First Levenberg-Marquardt damping of each inner loop, relative to
    /// the largest diagonal entry of the cost rows' `JᵀJ` (of all rows'
    /// when there are no cost rows; the constraint rows' grow with the
    /// penalty, the curvature the damping competes with does not).
    /// Default 1e-6.
    pub initial_damping: f64,
    /// Largest step in ∞-norm (a trust bound; variable units). Default ∞.
    pub max_step: f64,
    /// Wall-clock budget. Default none.
    pub time_limit: Option<Duration>,
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            max_outer_iterations: 30,
            max_inner_steps: 100,
            max_evaluations: 2000,
            step_tolerance: 1e-6,
            cost_tolerance: 1e-10,
            equality_tolerance: 1e-5,
            inequality_tolerance: 1e-5,
            initial_penalty: 10.0,
            penalty_increase: 10.0,
            max_penalty: 1e9,
            initial_damping: 1e-6,
            max_step: f64::INFINITY,
            time_limit: None,
        }
    }
}

/// Why a solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// The inner loop converged and the constraints hold within tolerance.
    Converged,
    /// The constraints still do not hold at the largest penalty, or their
    /// violation stopped shrinking well above tolerance while the penalty
    /// grew: the problem is (locally) infeasible, e.g. an unreachable
    /// target.
    Infeasible,
    /// `max_outer_iterations` outer iterations were not enough.
    IterationLimit,
    /// `max_evaluations` evaluations were not enough.
    EvaluationLimit,
    /// The wall-clock budget ran out.
    TimeLimit,
}

impl Termination {
    /// Lower-case name for reports (`converged`, `infeasible`, …).
    pub fn as_str(self) -> &'static str {
        match self {
            Termination::Converged => "converged",
            Termination::Infeasible => "infeasible",
            Termination::IterationLimit => "iteration_limit",
            Termination::EvaluationLimit => "evaluation_limit",
            Termination::TimeLimit => "time_limit",
        }
    }
}

/// What a solve did and where it ended.
#[derive(Debug, Clone, PartialEq)]
pub struct SolveReport {
    pub termination: Termination,
    /// Outer (multiplier update) iterations run.
    pub outer_iterations: usize,
    /// Accepted Gauss-Newton steps.
    pub inner_steps: usize,
    /// Problem evaluations, rejected trial points included.
    pub evaluations: usize,
    /// `Σ r²` of the cost rows at the solution.
    pub cost: f64,
    /// `max |h|` at the solution.
    pub equality_violation: f64,
    /// `max(0, max g)` at the solution.
    pub inequality_violation: f64,
    /// The final penalty `μ`.
    pub penalty: f64,
    pub time: Duration,
}

/// Why a solve could not run.
#[derive(Debug, Error)]
pub enum SolveError<E> {
    /// The problem's evaluation failed.
    #[error("evaluation failed: {0}")]
    Evaluation(E),
    /// Dimensions of the problem, solver or start disagree.
    #[error("dimension mismatch: {what} is {got}, expected {expected}")]
    Dimension { what: &'static str, expected: usize, got: usize },
    /// A row touches variables outside the problem or wider than its band.
    #[error("a row spans {width} variables ending at {end}; the problem has {dimension} with band {bandwidth}")]
    RowOutsideBand { width: usize, end: usize, dimension: usize, bandwidth: usize },
    /// The start point evaluates to NaN or infinity.
    #[error("the problem is not finite at the start point")]
    NotFiniteAtStart,
}

/// An outer iteration whose violation (above 10× tolerance) is above this
/// fraction of the one two iterations before, with evaluations spent in
/// between and the penalty raised, ends the solve infeasible.
const STALLED: f64 = 0.9;

/// Most re-solves of one step with newly activated inequality rows.
const ACTIVATION_ROUNDS: usize = 8;

/// How an inner minimisation ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum InnerEnd {
    Converged,
    Budget(Termination),
}

/// Sorted (key, multiplier) pairs.
#[derive(Debug, Clone, Default)]
struct Multipliers {
    pairs: Vec<(u64, f64)>,
    next: Vec<(u64, f64)>,
}

impl Multipliers {
    fn get(&self, key: u64) -> f64 {
        self.pairs.binary_search_by_key(&key, |p| p.0).map_or(0.0, |i| self.pairs[i].1)
    }

    /// `λ ← update(λ, value)` for every row; rows whose new multiplier is
    /// zero are dropped.
    fn update(&mut self, rows: &RowBlock, update: impl Fn(f64, f64) -> f64) {
        self.next.clear();
        for r in 0..rows.len() {
            let l = update(self.get(rows.key(r)), rows.value(r));
            if l != 0.0 {
                self.next.push((rows.key(r), l));
            }
        }
        self.next.sort_unstable_by_key(|p| p.0);
        std::mem::swap(&mut self.pairs, &mut self.next);
    }
}

/// An augmented-Lagrangian solver for [`LeastSquaresProblem`]s of one size;
/// it keeps every buffer, so repeated solves allocate nothing once the row
/// counts have been seen.
#[derive(Debug, Clone)]
pub struct AugmentedLagrangian {
    settings: SolverSettings,
    dimension: usize,
    current: Residuals,
    trial: Residuals,
    normal: SymmetricBand,
    /// `JᵀJ` before damping and factorisation, reused after a rejected step.
    undamped: SymmetricBand,
    /// `undamped` with the inequality rows of the step's active set.
    augmented: SymmetricBand,
    gradient: Vec<f64>,
    /// `gradient` plus the activated rows' terms.
    rhs: Vec<f64>,
    /// Which inequality rows the step's model holds active.
    active: Vec<bool>,
    step: Vec<f64>,
    x_trial: Vec<f64>,
    equality: Multipliers,
    inequality: Multipliers,
    penalty: f64,
    damping: f64,
    damping_growth: f64,
    evaluations: usize,
    inner_steps: usize,
}

/// Counters and limits shared by the loops of one solve.
struct Budget {
    start: Instant,
    time_limit: Option<Duration>,
    max_evaluations: usize,
}

impl AugmentedLagrangian {
    /// A solver for problems with `dimension` variables and half bandwidth
    /// `bandwidth`.
    pub fn new(dimension: usize, bandwidth: usize, settings: SolverSettings) -> AugmentedLagrangian {
        AugmentedLagrangian {
            settings,
            dimension,
            current: Residuals::default(),
            trial: Residuals::default(),
            normal: SymmetricBand::zeros(dimension, bandwidth),
            undamped: SymmetricBand::zeros(dimension, bandwidth),
            augmented: SymmetricBand::zeros(dimension, bandwidth),
            rhs: vec![0.0; dimension],
            active: Vec::new(),
            gradient: vec![0.0; dimension],
            step: vec![0.0; dimension],
            x_trial: vec![0.0; dimension],
            equality: Multipliers::default(),
            inequality: Multipliers::default(),
            penalty: 0.0,
            damping: 0.0,
            damping_growth: 2.0,
            evaluations: 0,
            inner_steps: 0,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &SolverSettings {
        &self.settings
    }

    /// Mutable settings (take effect at the next solve).
    pub fn settings_mut(&mut self) -> &mut SolverSettings {
        &mut self.settings
    }

    /// The rows at the solution of the last solve.
    pub fn residuals(&self) -> &Residuals {
        &self.current
    }

    /// Minimises from `x`, which holds the solution on return (also when
    /// the report says it did not converge). Multipliers and penalty start
    /// afresh.
    ///
    /// # Errors
    /// [`SolveError`] when the problem cannot be evaluated, its dimensions
    /// disagree, or it is not finite at `x`.
    pub fn solve<P: LeastSquaresProblem>(
        &mut self,
        problem: &mut P,
        x: &mut [f64],
    ) -> Result<SolveReport, SolveError<P::Error>> {
        self.run(problem, x, false)
    }

    /// As [`solve`](Self::solve), but starting from the multipliers and
    /// penalty the last solve ended with: from that solve's solution (or a
    /// nearby problem's) it converges in a few steps. Without a previous
    /// solve it is a plain solve.
    ///
    /// # Errors
    /// As [`solve`](Self::solve).
    pub fn solve_warm<P: LeastSquaresProblem>(
        &mut self,
        problem: &mut P,
        x: &mut [f64],
    ) -> Result<SolveReport, SolveError<P::Error>> {
        self.run(problem, x, self.penalty > 0.0)
    }

    fn run<P: LeastSquaresProblem>(
        &mut self,
        problem: &mut P,
        x: &mut [f64],
        warm: bool,
    ) -> Result<SolveReport, SolveError<P::Error>> {
        let budget = Budget {
            start: Instant::now(),
            time_limit: self.settings.time_limit,
            max_evaluations: self.settings.max_evaluations,
        };
        self.check_dimensions(problem, x)?;
        self.evaluations = 0;
        self.inner_steps = 0;
        if !warm {
            self.equality.pairs.clear();
            self.inequality.pairs.clear();
        }
        self.damping = 0.0;
        if !self.evaluate_into_current(problem, x)? {
            return Err(SolveError::NotFiniteAtStart);
        }
        if !warm {
            self.penalty = (self.settings.initial_penalty * self.curvature_ratio()).min(self.settings.max_penalty);
        }
        // Violations and evaluation counts after the last two outer
        // iterations (most recent first).
        let mut previous = [f64::INFINITY; 2];
        let mut evaluated = [0; 2];
        let mut outer = 0;
        let termination = loop {
            outer += 1;
            let inner = self.minimize(problem, x, &budget)?;
            let (eq, ineq) = (self.current.equality_violation(), self.current.inequality_violation());
            let feasible = eq <= self.settings.equality_tolerance && ineq <= self.settings.inequality_tolerance;
            let violation = eq.max(ineq);
            // Two outer iterations of real work (evaluations), the penalty
            // raised, that moved a violation well above tolerance by less
            // than 10 %: it has settled where the constraints cannot hold (a
            // local infeasibility); the penalties left would only stiffen
            // the problem around it. (Near tolerance, violations often sit
            // still for a few iterations before the penalty pushes them in.)
            let tolerance = self.settings.equality_tolerance.max(self.settings.inequality_tolerance);
            let stalled = violation > STALLED * previous[1]
                && violation > 10.0 * tolerance
                && self.evaluations >= evaluated[1] + 2;
            match inner {
                InnerEnd::Budget(t) => break t,
                InnerEnd::Converged if feasible => break Termination::Converged,
                InnerEnd::Converged if self.penalty >= self.settings.max_penalty || stalled => {
                    break Termination::Infeasible;
                }
                InnerEnd::Converged if outer >= self.settings.max_outer_iterations => {
                    break Termination::IterationLimit;
                }
                InnerEnd::Converged => {}
            }
            self.update_multipliers();
            if violation > 0.25 * previous[0] {
                self.penalty = (self.penalty * self.settings.penalty_increase).min(self.settings.max_penalty);
            } else {
                // Progress: the stall test restarts.
                previous[0] = f64::INFINITY;
            }
            previous = [violation, previous[0]];
            evaluated = [self.evaluations, evaluated[0]];
        };
        Ok(SolveReport {
            termination,
            outer_iterations: outer,
            inner_steps: self.inner_steps,
            evaluations: self.evaluations,
            cost: self.current.cost_value(),
            equality_violation: self.current.equality_violation(),
            inequality_violation: self.current.inequality_violation(),
            penalty: self.penalty,
            time: budget.start.elapsed(),
        })
    }

    fn check_dimensions<P: LeastSquaresProblem>(&self, problem: &P, x: &[f64]) -> Result<(), SolveError<P::Error>> {
        let expected = self.dimension;
        for (what, got) in [("the problem's dimension", problem.dimension()), ("x", x.len())] {
            if got != expected {
                return Err(SolveError::Dimension { what, expected, got });
            }
        }
        if problem.bandwidth() > self.normal.bandwidth() {
            let (expected, got) = (self.normal.bandwidth(), problem.bandwidth());
            return Err(SolveError::Dimension { what: "the problem's bandwidth", expected, got });
        }
        Ok(())
    }

    /// Evaluates into `trial`; `Ok(false)` when it is not finite.
    fn evaluate_trial<P: LeastSquaresProblem>(
        &mut self,
        problem: &mut P,
        x: &[f64],
    ) -> Result<bool, SolveError<P::Error>> {
        self.evaluations += 1;
        self.trial.clear();
        problem.evaluate(x, &mut self.trial).map_err(SolveError::Evaluation)?;
        let (dimension, bandwidth) = (self.dimension, self.normal.bandwidth());
        for block in self.trial.blocks() {
            let (width, end) = block.extent();
            if width > bandwidth + 1 || end > dimension {
                return Err(SolveError::RowOutsideBand { width, end, dimension, bandwidth });
            }
        }
        Ok(!self.trial.blocks().iter().any(|b| b.has_non_finite()))
    }

    fn evaluate_into_current<P: LeastSquaresProblem>(
        &mut self,
        problem: &mut P,
        x: &[f64],
    ) -> Result<bool, SolveError<P::Error>> {
        let finite = self.evaluate_trial(problem, x)?;
        std::mem::swap(&mut self.current, &mut self.trial);
        Ok(finite)
    }

    /// Levenberg-Marquardt on the augmented Lagrangian at fixed multipliers
    /// and penalty, from `x` (whose rows are in `current`).
    fn minimize<P: LeastSquaresProblem>(
        &mut self,
        problem: &mut P,
        x: &mut [f64],
        budget: &Budget,
    ) -> Result<InnerEnd, SolveError<P::Error>> {
        let mut merit = self.merit(&self.current);
        let mut accepted = 0;
        let mut assembled = false;
        // Damping carried over from the last inner loop would be tuned to a
        // different penalty; start afresh (relative to the cost's curvature,
        // which the penalty does not scale).
        self.damping = 0.0;
        self.damping_growth = 2.0;
        loop {
            if self.evaluations >= budget.max_evaluations {
                return Ok(InnerEnd::Budget(Termination::EvaluationLimit));
            }
            if budget.time_limit.is_some_and(|t| budget.start.elapsed() > t) {
                return Ok(InnerEnd::Budget(Termination::TimeLimit));
            }
            if accepted >= self.settings.max_inner_steps {
                return Ok(InnerEnd::Converged);
            }
            if !assembled {
                self.assemble();
                assembled = true;
                if self.gradient.iter().all(|g| g.abs() <= 1e-14 * (1.0 + merit)) {
                    return Ok(InnerEnd::Converged);
                }
            }
            if self.damping == 0.0 {
                self.damping = self.initial_damping();
            }
            let Some(predicted) = self.damped_step(merit) else {
                if self.reject_step() {
                    return Ok(InnerEnd::Converged);
                }
                continue;
            };
            // Converged when the step is negligible, or would not decrease the
            // merit noticeably (relative to the cost: the merit's multiplier
            // terms carry a constant offset).
            let decrease_scale = self.settings.cost_tolerance * (1.0 + self.current.cost_value());
            // While the constraints are violated by v, polishing steps much
            // below v is wasted: the multipliers are about to change.
            let violation = self.current.equality_violation().max(self.current.inequality_violation());
            let step_scale = self.settings.step_tolerance.max(0.1 * violation);
            if self.step_norm() <= step_scale || (0.0..=decrease_scale).contains(&predicted) {
                return Ok(InnerEnd::Converged);
            }
            if predicted <= 0.0 {
                // The model's active set did not settle: a shorter step.
                if self.reject_step() {
                    return Ok(InnerEnd::Converged);
                }
                continue;
            }
            for ((t, xi), s) in self.x_trial.iter_mut().zip(x.iter()).zip(&self.step) {
                *t = xi + s;
            }
            let x_trial = std::mem::take(&mut self.x_trial);
            let finite = self.evaluate_trial(problem, &x_trial);
            self.x_trial = x_trial;
            let trial_merit = if finite? { self.merit(&self.trial) } else { f64::INFINITY };
            let actual = merit - trial_merit;
            let rho = actual / predicted;
            if rho > 1e-4 && actual > 0.0 {
                x.copy_from_slice(&self.x_trial);
                std::mem::swap(&mut self.current, &mut self.trial);
                assembled = false;
                self.inner_steps += 1;
                accepted += 1;
                self.damping *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                self.damping_growth = 2.0;
                merit = trial_merit;
                if actual <= self.settings.cost_tolerance * (1.0 + self.current.cost_value()) {
                    return Ok(InnerEnd::Converged);
                }
            } else if self.reject_step() {
                return Ok(InnerEnd::Converged);
            }
        }
    }

    /// Raises the damping after a rejected step; true when it has grown so
    /// large that no step can decrease the merit any more.
    fn reject_step(&mut self) -> bool {
        self.damping *= self.damping_growth;
        self.damping_growth *= 2.0;
        self.damping > 1e20 * self.undamped.max_diagonal().max(1.0)
    }

    /// `max diag(J_rᵀJ_r) / max diag(J_cᵀJ_c)` of the cost rows `r` and
    /// constraint rows `c` at the current point (at least 1).
    fn curvature_ratio(&mut self) -> f64 {
        let cost = largest_diagonal(&[&self.current.cost], &mut self.gradient);
        let constraints = largest_diagonal(&[&self.current.equality, &self.current.inequality], &mut self.gradient);
        if constraints > 0.0 { (cost / constraints).max(1.0) } else { 1.0 }
    }

    /// The first damping of an inner loop: `initial_damping` times the
    /// largest diagonal entry of the cost rows' `JᵀJ` (of every row's
    /// without cost rows), at least `initial_damping`.
    fn initial_damping(&mut self) -> f64 {
        let cost = largest_diagonal(&[&self.current.cost], &mut self.step);
        let scale = if cost > 0.0 { cost } else { self.undamped.max_diagonal() };
        self.settings.initial_damping * scale.max(1.0)
    }

    fn step_norm(&self) -> f64 {
        self.step.iter().fold(0.0f64, |m, s| m.max(s.abs()))
    }

    /// Each row as the augmented Lagrangian sees it: block, index, weight²,
    /// shifted value, and whether it enters through a hinge `max(0, ·)`.
    fn rows<'a>(&'a self, res: &'a Residuals) -> impl Iterator<Item = (&'a RowBlock, usize, f64, f64, bool)> + 'a {
        let mu = self.penalty;
        let cost = (0..res.cost.len()).map(move |r| (&res.cost, r, 1.0, res.cost.value(r), false));
        let eq = (0..res.equality.len()).map(move |r| {
            let h = res.equality.value(r) + self.equality.get(res.equality.key(r)) / (2.0 * mu);
            (&res.equality, r, mu, h, false)
        });
        let ineq = (0..res.inequality.len()).map(move |r| {
            let g = res.inequality.value(r) + self.inequality.get(res.inequality.key(r)) / (2.0 * mu);
            (&res.inequality, r, mu, g, true)
        });
        cost.chain(eq).chain(ineq)
    }

    /// The augmented Lagrangian (up to a constant in the multipliers).
    fn merit(&self, res: &Residuals) -> f64 {
        self.rows(res).map(|(_, _, w, v, hinge)| if hinge && v <= 0.0 { 0.0 } else { w * v * v }).sum()
    }

    /// `JᵀJ` (into `undamped`) and `Jᵀφ` of the current rows.
    fn assemble(&mut self) {
        let mut normal = std::mem::replace(&mut self.undamped, SymmetricBand::zeros(0, 0));
        let mut gradient = std::mem::take(&mut self.gradient);
        normal.clear();
        gradient.fill(0.0);
        for (block, r, w, v, hinge) in self.rows(&self.current) {
            if hinge && v <= 0.0 {
                continue;
            }
            let (first, jac) = block.gradient(r);
            normal.add_outer(first, jac, w);
            for (g, j) in gradient[first..first + jac.len()].iter_mut().zip(jac) {
                *g += w * v * j;
            }
        }
        self.undamped = normal;
        self.gradient = gradient;
    }

    fn update_multipliers(&mut self) {
        let mu = self.penalty;
        self.equality.update(&self.current.equality, |l, h| l + 2.0 * mu * h);
        self.inequality.update(&self.current.inequality, |l, g| (l + 2.0 * mu * g).max(0.0));
    }
}

/// The largest diagonal entry of `Σ JᵀJ` over the rows of `blocks`;
/// `scratch` (one entry per variable) is overwritten.
fn largest_diagonal(blocks: &[&RowBlock], scratch: &mut [f64]) -> f64 {
    scratch.fill(0.0);
    for block in blocks {
        for r in 0..block.len() {
            let (first, jac) = block.gradient(r);
            for (d, j) in scratch[first..first + jac.len()].iter_mut().zip(jac) {
                *d += j * j;
            }
        }
    }
    scratch.iter().fold(0.0, |m, &d| m.max(d))
}
