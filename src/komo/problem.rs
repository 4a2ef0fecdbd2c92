//! The trajectory problem (model) and its per-thread workspace: decision
//! variables `q_1 … q_T` stacked into one vector, objectives evaluated
//! slice by slice into banded rows for the solver.

use super::KomoError;
use super::feature::{Feature, FeatureWorkspace};
use super::objective::Objective;
use crate::collision::{CollisionModel, CollisionWorkspace, PairDistance};
use crate::problem::ObjectiveKind;
use crate::robot::{KinematicsWorkspace, RobotError, RobotModel};
use crate::settings::InvalidSetting;
use std::sync::Arc;
use tandem_solvers::least_squares::{LeastSquaresProblem, Residuals, RowBlock};

/// Collision pairs farther than `margin + COLLISION_CUTOFF` (m) get no row:
/// their inequality is inactive unless a multiplier would reach across
/// that gap, which the penalty keeps from happening in practice.
pub const COLLISION_CUTOFF: f64 = 0.02;

/// An immutable k-order trajectory problem: robot, collision model,
/// objectives, horizon `T`, duration and start configuration. Slices
/// `t ≤ 0` (the `k` prefix configurations) are the start, at rest.
#[derive(Debug, Clone)]
pub struct TrajectoryProblem {
    pub(crate) robot: Arc<RobotModel>,
    pub(crate) collision: Option<CollisionModel>,
    pub(crate) objectives: Vec<Objective>,
    /// Resolved slices `first ..= last` of each objective.
    pub(crate) spans: Vec<(usize, usize)>,
    pub(crate) horizon: usize,
    pub(crate) order: usize,
    pub(crate) duration: f64,
    pub(crate) start: Vec<f64>,
    /// Extra collision checks between consecutive slices.
    pub(crate) collision_substeps: usize,
}

impl TrajectoryProblem {
    /// Validates and assembles a problem.
    ///
    /// # Errors
    /// [`KomoError`] for a horizon outside [`MIN_HORIZON`](crate::problem::MIN_HORIZON)
    /// ..= [`MAX_HORIZON`](crate::problem::MAX_HORIZON), order not 1 or 2, a
    /// non-positive duration, a bad start, an invalid objective, or a
    /// collision objective without a collision model.
    pub fn new(
        robot: Arc<RobotModel>,
        collision: Option<CollisionModel>,
        objectives: Vec<Objective>,
        horizon: usize,
        order: usize,
        duration: f64,
        start: Vec<f64>,
    ) -> Result<TrajectoryProblem, KomoError> {
        let (min, max) = (crate::problem::MIN_HORIZON, crate::problem::MAX_HORIZON);
        if !(min..=max).contains(&horizon) {
            return Err(InvalidSetting::new("horizon", horizon, format!("between {min} and {max}")).into());
        }
        if !(1..=2).contains(&order) {
            return Err(InvalidSetting::new("order", order, "1 or 2").into());
        }
        crate::settings::positive("duration", duration, "s")?;
        robot.check_configuration(&start)?;
        for objective in &objectives {
            objective.validate(&robot, horizon, order)?;
            if matches!(objective.feature, Feature::Collision { .. }) && collision.is_none() {
                let name = objective.name.clone();
                return Err(KomoError::Objective { name, message: "no collision model given".into() });
            }
        }
        let spans = objectives.iter().map(|o| o.time.slices(horizon)).collect();
        Ok(TrajectoryProblem {
            robot,
            collision,
            objectives,
            spans,
            horizon,
            order,
            duration,
            start,
            collision_substeps: 0,
        })
    }

    /// The same problem over `horizon` slices (objective time spans are
    /// fractions of the horizon, so they follow).
    ///
    /// # Errors
    /// As [`TrajectoryProblem::new`], e.g. a horizon below 2.
    pub fn with_horizon(self, horizon: usize) -> Result<TrajectoryProblem, KomoError> {
        let substeps = self.collision_substeps;
        let problem = TrajectoryProblem::new(
            self.robot,
            self.collision,
            self.objectives,
            horizon,
            self.order,
            self.duration,
            self.start,
        )?;
        Ok(problem.with_collision_substeps(substeps))
    }

    /// Also constrains collisions at `substeps` evenly spaced
    /// configurations on the straight motion between consecutive slices
    /// (default 0: at the slices only). Useful when slices are far apart
    /// and the motion between them cuts a corner.
    pub fn with_collision_substeps(mut self, substeps: usize) -> TrajectoryProblem {
        self.collision_substeps = substeps;
        self
    }

    /// Number of optimized configurations `T`.
    pub fn horizon(&self) -> usize {
        self.horizon
    }

    /// Seconds between slices, `τ = duration / T`.
    pub fn time_step(&self) -> f64 {
        self.duration / self.horizon as f64
    }

    /// Active joints per configuration.
    pub fn nq(&self) -> usize {
        self.robot.nq()
    }

    /// The robot model.
    pub fn robot(&self) -> &Arc<RobotModel> {
        &self.robot
    }

    /// The collision model, if the problem has one.
    pub fn collision_model(&self) -> Option<&CollisionModel> {
        self.collision.as_ref()
    }

    /// The objectives.
    pub fn objectives(&self) -> &[Objective] {
        &self.objectives
    }

    /// The start configuration q_0 (rad or m).
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// Half bandwidth of the normal equations: a row of order k couples
    /// k + 1 consecutive slices.
    pub fn bandwidth(&self) -> usize {
        let k = self.objectives.iter().map(|o| o.order).max().unwrap_or(0);
        (k + 1) * self.nq() - 1
    }

    /// Cost `Σ r²`, largest equality violation `max |h|` and largest
    /// inequality violation `max(0, g)` of a trajectory `q_1 … q_T` (e.g.
    /// one from another solver), as this problem defines them.
    ///
    /// # Errors
    /// [`KomoError::Initialization`] for a trajectory of the wrong shape;
    /// configurations the robot model rejects.
    pub fn measure(&self, trajectory: &[Vec<f64>]) -> Result<Measures, KomoError> {
        let n = self.nq();
        if trajectory.len() != self.horizon || trajectory.iter().any(|q| q.len() != n) {
            let message = format!("expected {} configurations of {n} joints", self.horizon);
            return Err(KomoError::Initialization(message));
        }
        let x: Vec<f64> = trajectory.concat();
        let mut ws = TrajectoryWorkspace::new(self);
        let mut rows = Residuals::default();
        self.evaluate(&mut ws, &x, &mut rows)?;
        Ok(Measures {
            cost: rows.cost_value(),
            equality_violation: rows.equality_violation(),
            inequality_violation: rows.inequality_violation(),
        })
    }

    /// The rows of every objective at the stacked trajectory `x` (`q_1 …
    /// q_T`, nq values each) as the solver sees them — cost, equality and
    /// inequality rows with their gradients over `x` — replacing the
    /// contents of `out`. For checking Jacobians (e.g. against finite
    /// differences of the whole problem) and for driving other solvers.
    ///
    /// # Errors
    /// [`KomoError::Initialization`] for an `x` of the wrong length,
    /// [`KomoError::ForeignWorkspace`] for a workspace whose shape does not fit
    /// the problem (make it with [`TrajectoryWorkspace::new`] of this
    /// problem), configurations the robot model rejects.
    pub fn residuals(&self, ws: &mut TrajectoryWorkspace, x: &[f64], out: &mut Residuals) -> Result<(), KomoError> {
        let n = self.nq();
        if x.len() != self.horizon * n {
            let message = format!("x has {} values, expected T·nq = {}", x.len(), self.horizon * n);
            return Err(KomoError::Initialization(message));
        }
        let fits = ws.kinematics.len() == self.horizon + 1
            && ws.features.len() == self.objectives.len()
            && ws.gradient.len() == n
            && ws.row.len() >= (self.order + 1) * n
            && ws.collision.as_ref().map(|c| c.poses.len()) == self.collision.as_ref().map(|m| m.object_count())
            && self.objectives.iter().zip(&ws.features).all(|(o, b)| {
                let dim = o.feature.dim(&self.robot);
                b.values.len() == (self.horizon + 1) * dim && b.jacobians.len() == (self.horizon + 1) * dim * n
            });
        if !fits {
            return Err(KomoError::ForeignWorkspace);
        }
        self.robot.forward_kinematics(&mut ws.kinematics[0], &self.start)?;
        out.clear();
        Ok(self.evaluate(ws, x, out)?)
    }

    /// Configuration of slice `t` (≤ 0: the start) within the stacked `x`.
    fn slice<'x>(&'x self, x: &'x [f64], t: usize) -> &'x [f64] {
        let n = self.nq();
        if t == 0 { &self.start } else { &x[(t - 1) * n..t * n] }
    }

    /// Rows of every objective at `x` into `out`.
    pub(crate) fn evaluate(
        &self,
        ws: &mut TrajectoryWorkspace,
        x: &[f64],
        out: &mut Residuals,
    ) -> Result<(), RobotError> {
        for t in 1..=self.horizon {
            self.robot.forward_kinematics(&mut ws.kinematics[t], self.slice(x, t))?;
        }
        for (index, objective) in self.objectives.iter().enumerate() {
            let block = match objective.kind {
                ObjectiveKind::SumOfSquares => &mut out.cost,
                ObjectiveKind::Equality => &mut out.equality,
                ObjectiveKind::Inequality => &mut out.inequality,
            };
            match objective.feature {
                Feature::Collision { margin, obstacle_margin } => {
                    self.collision_rows(ws, index, [margin, obstacle_margin], x, block)?
                }
                _ => self.feature_rows(ws, index, x, block)?,
            }
        }
        Ok(())
    }

    /// Rows of a fixed-size feature objective, differenced to its order.
    fn feature_rows(
        &self,
        ws: &mut TrajectoryWorkspace,
        index: usize,
        x: &[f64],
        block: &mut RowBlock,
    ) -> Result<(), RobotError> {
        let objective = &self.objectives[index];
        let (first, last) = self.spans[index];
        let (n, k, dim) = (self.nq(), objective.order, objective.feature.dim(&self.robot));
        let buffer = &mut ws.features[index];
        for s in first.saturating_sub(k)..=last {
            let (value, jac) = (&mut buffer.values[s * dim..(s + 1) * dim], &mut buffer.jacobians[s * dim * n..]);
            let q = if s == 0 { &self.start[..] } else { &x[(s - 1) * n..s * n] };
            objective.feature.evaluate(
                &self.robot,
                &ws.kinematics[s],
                q,
                &mut ws.scratch,
                value,
                &mut jac[..dim * n],
            )?;
        }
        let coefficients: &[f64] = [&[1.0][..], &[1.0, -1.0], &[1.0, -2.0, 1.0]][k];
        let weight = objective.scale / self.time_step().powi(k as i32);
        // Inequality rows this far inside their bound are left out.
        // (Only undifferenced: a difference of distances is no distance.)
        let skip_below = match (objective.kind, objective.feature.inactive_cutoff()) {
            (ObjectiveKind::Inequality, Some(cutoff)) if k == 0 => -cutoff * objective.scale.abs(),
            _ => f64::NEG_INFINITY,
        };
        for t in first..=last {
            let s0 = t.saturating_sub(k).max(1);
            let width = (t - s0 + 1) * n;
            for i in 0..dim {
                let differenced: f64 = coefficients
                    .iter()
                    .enumerate()
                    .map(|(j, c)| c * buffer.values[t.saturating_sub(j) * dim + i])
                    .sum();
                let target = objective.target.get(i).copied().unwrap_or(0.0);
                let value = objective.scale * (differenced / self.time_step().powi(k as i32) - target);
                if value < skip_below {
                    continue;
                }
                let row = &mut ws.row[..width];
                row.fill(0.0);
                for (j, c) in coefficients.iter().enumerate() {
                    let s = t.saturating_sub(j);
                    if s >= 1 {
                        let grad = &buffer.jacobians[(s * dim + i) * n..(s * dim + i + 1) * n];
                        for (r, g) in row[(s - s0) * n..(s - s0 + 1) * n].iter_mut().zip(grad) {
                            *r += weight * c * g;
                        }
                    }
                }
                push_trimmed(block, row_key(index, t, i), value, (s0 - 1) * n, row);
            }
        }
        Ok(())
    }

    /// One row `scale·(margin − d)` per collision pair closer than
    /// `margin + COLLISION_CUTOFF`, at every slice of the objective and at
    /// `collision_substeps` evenly spaced configurations on the straight
    /// motion into it (those rows couple the two slices); as a cost, only
    /// the pairs closer than the margin count. `margins` is
    /// `[margin, obstacle_margin]`: the second for pairs against a scene
    /// obstacle.
    fn collision_rows(
        &self,
        ws: &mut TrajectoryWorkspace,
        index: usize,
        margins: [f64; 2],
        x: &[f64],
        block: &mut RowBlock,
    ) -> Result<(), RobotError> {
        let (Some(model), Some(cws)) = (&self.collision, &mut ws.collision) else { return Ok(()) };
        let objective = &self.objectives[index];
        let (first, last) = self.spans[index];
        let (n, samples) = (self.nq(), self.collision_substeps + 1);
        let cost = objective.kind == ObjectiveKind::SumOfSquares;
        let cutoff = margins[0].max(margins[1]) + COLLISION_CUTOFF;
        for t in first..=last {
            for sample in 1..=samples {
                // Fraction s of the way from slice t − 1 to slice t.
                let s = sample as f64 / samples as f64;
                let pairs = if sample == samples && Arc::ptr_eq(&model.robot, &self.robot) {
                    // At slice t itself, whose kinematics are known.
                    model.distances_at(cws, &ws.kinematics[t], cutoff)
                } else {
                    let (before, at) = (self.slice(x, t - 1), self.slice(x, t));
                    for ((q, a), b) in ws.q.iter_mut().zip(before).zip(at) {
                        *q = a + s * (b - a);
                    }
                    model.distances(cws, &ws.q, cutoff)?
                };
                ws.pairs.clear();
                ws.pairs.extend_from_slice(pairs);
                // Rows between slices also move slice t − 1 (unless it is the start).
                let spans_two = sample < samples && t > 1;
                let first_col = if spans_two { (t - 2) * n } else { (t - 1) * n };
                for pair in &ws.pairs {
                    // Equal margins (the usual case) need no lookup.
                    let against_obstacle = margins[0] != margins[1]
                        && matches!(
                            model.object_source(model.pair_objects(pair.pair).1),
                            crate::collision::ObjectSource::Obstacle(_)
                        );
                    let g = margins[usize::from(against_obstacle)] - pair.signed.distance;
                    if cost && g <= 0.0 {
                        continue;
                    }
                    model.distance_gradient(cws, pair, &mut ws.gradient)?;
                    let row = &mut ws.row[..if spans_two { 2 * n } else { n }];
                    let (head, tail) = row.split_at_mut(if spans_two { n } else { 0 });
                    for (k, d) in ws.gradient.iter().enumerate() {
                        tail[k] = -objective.scale * s * d;
                        if spans_two {
                            head[k] = -objective.scale * (1.0 - s) * d;
                        }
                    }
                    let key = row_key(index, t * samples + sample - 1, pair.pair);
                    push_trimmed(block, key, objective.scale * g, first_col, row);
                }
            }
        }
        Ok(())
    }
}

/// A trajectory measured against a problem's objectives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measures {
    /// `Σ r²` over the sum-of-squares objectives.
    pub cost: f64,
    /// `max |h|` over the equality objectives.
    pub equality_violation: f64,
    /// `max(0, g)` over the inequality objectives.
    pub inequality_violation: f64,
}

/// Key of component `i` of objective `index` at slice `t`: stable across
/// evaluations, so multipliers follow their row.
fn row_key(index: usize, t: usize, i: usize) -> u64 {
    ((index as u64) << 48) | ((t as u64) << 32) | i as u64
}

/// Pushes a row whose gradient over `first ..` is `row`, without its
/// leading and trailing zeros (fewer entries to assemble).
fn push_trimmed(block: &mut RowBlock, key: u64, value: f64, first: usize, row: &[f64]) {
    let lo = row.iter().position(|v| *v != 0.0).unwrap_or(0);
    let hi = row.iter().rposition(|v| *v != 0.0).map_or(lo, |h| h + 1);
    block.push(key, value, first + lo, hi - lo).copy_from_slice(&row[lo..hi]);
}

/// Values and Jacobians of one objective's feature at every slice.
#[derive(Debug, Clone)]
pub(crate) struct FeatureBuffer {
    values: Vec<f64>,
    jacobians: Vec<f64>,
}

/// Mutable per-thread state of evaluating a [`TrajectoryProblem`]: one
/// kinematics workspace per slice, collision workspace, feature buffers.
#[derive(Debug, Clone)]
pub struct TrajectoryWorkspace {
    kinematics: Vec<KinematicsWorkspace>,
    collision: Option<CollisionWorkspace>,
    pairs: Vec<PairDistance>,
    gradient: Vec<f64>,
    /// A configuration between slices.
    q: Vec<f64>,
    scratch: FeatureWorkspace,
    features: Vec<FeatureBuffer>,
    row: Vec<f64>,
}

impl TrajectoryWorkspace {
    /// Allocates everything evaluating `problem` needs.
    pub fn new(problem: &TrajectoryProblem) -> TrajectoryWorkspace {
        let (robot, n, slices) = (&problem.robot, problem.nq(), problem.horizon + 1);
        let mut kinematics = vec![KinematicsWorkspace::new(robot); slices];
        // The prefix slices are the start; their kinematics never change.
        let _ = robot.forward_kinematics(&mut kinematics[0], &problem.start);
        let features = problem
            .objectives
            .iter()
            .map(|o| {
                let dim = o.feature.dim(robot);
                FeatureBuffer { values: vec![0.0; slices * dim], jacobians: vec![0.0; slices * dim * n] }
            })
            .collect();
        let collision = problem.collision.as_ref().map(CollisionWorkspace::new);
        let pair_count = problem.collision.as_ref().map_or(0, |m| m.pair_count());
        TrajectoryWorkspace {
            kinematics,
            collision,
            pairs: Vec::with_capacity(pair_count),
            gradient: vec![0.0; n],
            q: vec![0.0; n],
            scratch: FeatureWorkspace::new(robot),
            features,
            row: vec![0.0; (problem.order + 1) * n],
        }
    }
}

/// A problem and a workspace, as the solver sees them.
pub(crate) struct Evaluator<'a> {
    pub(crate) problem: &'a TrajectoryProblem,
    pub(crate) workspace: &'a mut TrajectoryWorkspace,
}

impl LeastSquaresProblem for Evaluator<'_> {
    type Error = RobotError;

    fn dimension(&self) -> usize {
        self.problem.horizon * self.problem.nq()
    }

    fn bandwidth(&self) -> usize {
        self.problem.bandwidth()
    }

    fn evaluate(&mut self, x: &[f64], out: &mut Residuals) -> Result<(), RobotError> {
        self.problem.evaluate(self.workspace, x, out)
    }
}
