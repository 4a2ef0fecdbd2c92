//! Following a policy alone: kinematic steps `q ← q + Δt·π(q)` from a
//! task's start, a collision check at every step, and the grasp judged
//! by [`GraspJudge`] — the dissertation's "success rate when following the
//! inferred action at each state" (§3.3.3).

use super::LearnError;
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::control::RobotPolicy;
use crate::problem::{Goal, GraspCriteria, GraspJudge, Problem};
use crate::robot::{FrameId, KinematicsWorkspace};
use crate::sim::Reason;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::Arc;

/// How a rollout steps and when it ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RolloutSettings {
    /// Step (s; default 1/15, the arbiter's period).
    pub period: f64,
    /// Timeout (s of simulated time; default 20, five times the reference duration).
    pub max_time: f64,
    /// Largest tilt (rad) of the gripper from the grasp's approach axis
    /// (default 0.1).
    pub max_tilt: f64,
    /// The judge is consulted within this distance (m) of the grasp point
    /// (default 0.05).
    pub judge_radius: f64,
}

impl Default for RolloutSettings {
    fn default() -> Self {
        RolloutSettings { period: 1.0 / 15.0, max_time: 20.0, max_tilt: 0.1, judge_radius: 0.05 }
    }
}

/// How a rollout ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RolloutOutcome {
    /// The grasp judge accepted a visited configuration.
    Success,
    /// A visited configuration collided (the finger pads may touch the target).
    Collision,
    /// Neither within the time limit.
    Timeout,
    /// No policy for the task (an LQR reference that could not be optimized).
    NoPolicy,
}

impl RolloutOutcome {
    /// `success`, `collision`, `timeout` or `no_policy`.
    pub fn as_str(&self) -> &'static str {
        match self {
            RolloutOutcome::Success => "success",
            RolloutOutcome::Collision => "collision",
            RolloutOutcome::Timeout => "timeout",
            RolloutOutcome::NoPolicy => "no_policy",
        }
    }
}

/// What a rollout did.
#[derive(Debug, Clone, PartialEq)]
pub struct Rollout {
    /// How it ended.
    pub outcome: RolloutOutcome,
    /// Steps taken.
    pub steps: usize,
    /// Steps whose command was clamped to the joint position or velocity limits.
    pub clamped: usize,
    /// Visited configurations, the start first (the colliding one last on a collision).
    pub path: Vec<Vec<f64>>,
    /// Why it ended: success, the colliding pair, or for a timeout the
    /// grasp judge's objection at the last configuration when the gripper
    /// is within the judge's radius of the grasp point
    /// ([`Reason::Timeout`] with the distance otherwise); `None` without
    /// a policy.
    pub reason: Option<Reason>,
    /// The gripper's distance from the grasp point (m) at the last
    /// configuration (the colliding one on a collision).
    pub distance: f64,
}

/// A reach-and-grasp task: the problem, its collision model (the pads may
/// touch the target), the judge and its criteria.
#[derive(Debug)]
pub struct Task {
    /// The grasp problem (its start is the rollout's default start).
    pub problem: Problem,
    collision: Arc<CollisionModel>,
    judge: GraspJudge,
    criteria: GraspCriteria,
    gripper: FrameId,
    gripper_name: String,
    target: [f64; 3],
    object: String,
}

impl Task {
    /// The task of a grasp `problem`, judged with `max_tilt` (rad).
    ///
    /// # Errors
    /// Not a grasp goal, or one without a gripper; collision or grasp model errors.
    pub fn new(problem: Problem, max_tilt: f64) -> Result<Task, LearnError> {
        let not_grasp = || LearnError::Mismatch {
            what: "task".into(),
            expected: "a grasp goal with a gripper".into(),
            got: format!("{:?}", problem.goal),
        };
        let Goal::Grasp { object, .. } = &problem.goal else { return Err(not_grasp()) };
        let object = object.clone();
        let gripper_name = problem.robot_spec.gripper.clone().ok_or_else(not_grasp)?;
        let gripper = problem.robot.frame_id(&gripper_name)?;
        let criteria = GraspCriteria::for_goal(&problem, max_tilt, 1e-4).ok_or_else(not_grasp)?;
        let target = problem.grasp_target().ok_or_else(not_grasp)?.translation.vector.into();
        let collision = Arc::new(problem.collision_model_grasping(&[object.as_str()], 0.0)?);
        let judge = GraspJudge::new(&problem)?;
        Ok(Task { problem, collision, judge, criteria, gripper, gripper_name, target, object })
    }

    /// The target object's name.
    pub fn object(&self) -> &str {
        &self.object
    }

    /// The gripper frame's name.
    pub fn gripper_name(&self) -> &str {
        &self.gripper_name
    }

    /// The collision model of the checks (the pads may touch the target).
    pub fn collision_model(&self) -> &Arc<CollisionModel> {
        &self.collision
    }

    /// The gripper's distance (m) from the grasp point at `q`.
    fn distance(&self, kin: &mut KinematicsWorkspace, q: &[f64]) -> Result<f64, LearnError> {
        let robot = &self.problem.robot;
        robot.forward_kinematics(kin, q)?;
        let p = robot.frame_position(kin, self.gripper);
        Ok(crate::sim::distance(p.into(), self.target))
    }

    /// Whether `q` grasps the target (the gripper within `radius` (m) of
    /// the grasp point first, to spare the judge).
    ///
    /// # Errors
    /// Robot or grasp model errors.
    pub fn grasped(&self, kin: &mut KinematicsWorkspace, q: &[f64], radius: f64) -> Result<bool, LearnError> {
        Ok(self.judged(kin, q, radius)? == Some(Reason::Success))
    }

    /// The grasp judge's verdict at `q` ([`Reason::Success`] or the first
    /// criterion it fails), or `None` when the gripper is farther than
    /// `radius` (m) from the grasp point.
    fn judged(&self, kin: &mut KinematicsWorkspace, q: &[f64], radius: f64) -> Result<Option<Reason>, LearnError> {
        if self.distance(kin, q)? > radius {
            return Ok(None);
        }
        let Some(object) = self.problem.scene.object(&self.object) else { return Ok(None) };
        let report = self.judge.judge(kin, q, object, &self.criteria)?;
        Ok(Some(if report.success(&self.criteria) {
            Reason::Success
        } else {
            Reason::of_grasp(&report, &self.criteria)
        }))
    }

    /// Follows `policy` alone from `start`.
    ///
    /// # Errors
    /// A start of the wrong length; robot errors.
    pub fn rollout(&self, policy: &dyn RobotPolicy, start: &[f64], s: &RolloutSettings) -> Result<Rollout, LearnError> {
        let robot = &self.problem.robot;
        let n = robot.nq();
        robot.check_configuration(start)?;
        let mut kin = KinematicsWorkspace::new(robot);
        let mut cws = CollisionWorkspace::new(&self.collision);
        let mut state = policy.new_workspace();
        let (mut q, mut velocity, mut action) = (start.to_vec(), vec![0.0; n], vec![0.0; n]);
        let mut rollout = Rollout {
            outcome: RolloutOutcome::Timeout,
            steps: 0,
            clamped: 0,
            path: vec![q.clone()],
            reason: None,
            distance: f64::NAN,
        };
        let steps = (s.max_time / s.period).ceil() as usize;
        for step_index in 0..=steps {
            if !self.collision.collision_free(&mut cws, &q)? {
                return self.ended(rollout, RolloutOutcome::Collision, &mut kin, &mut cws, s);
            }
            if self.grasped(&mut kin, &q, s.judge_radius)? {
                return self.ended(rollout, RolloutOutcome::Success, &mut kin, &mut cws, s);
            }
            if step_index == steps {
                break;
            }
            if policy.act(&mut state, &q, &velocity, &mut action).is_err() {
                // A policy that cannot answer leaves the arm where it is.
                action.fill(0.0);
            }
            rollout.clamped += usize::from(step(robot.limits(), &mut q, &action, &mut velocity, s.period));
            rollout.steps += 1;
            rollout.path.push(q.clone());
        }
        self.ended(rollout, RolloutOutcome::Timeout, &mut kin, &mut cws, s)
    }

    /// `rollout` ended in `outcome` at its last configuration: its reason and distance.
    fn ended(
        &self,
        mut rollout: Rollout,
        outcome: RolloutOutcome,
        kin: &mut KinematicsWorkspace,
        cws: &mut CollisionWorkspace,
        s: &RolloutSettings,
    ) -> Result<Rollout, LearnError> {
        let q = rollout.path.last().map_or_else(|| self.problem.start.clone(), Clone::clone);
        let distance = self.distance(kin, &q)?;
        rollout.reason = Some(match outcome {
            RolloutOutcome::Success => Reason::Success,
            RolloutOutcome::Collision => {
                let pair = match self.collision.min_distance(cws, &q)? {
                    Some(d) => {
                        let (a, b) = self.collision.pair_names(d.pair);
                        [a.to_string(), b.to_string()]
                    }
                    None => ["the arm".into(), "something".into()],
                };
                Reason::Collision { pair }
            }
            _ => match self.judged(kin, &q, s.judge_radius)? {
                Some(reason) if reason != Reason::Success => reason,
                _ => Reason::Timeout { distance },
            },
        });
        rollout.outcome = outcome;
        rollout.distance = distance;
        Ok(rollout)
    }
}

/// One step of a velocity-controlled arm: `action` scaled down to the
/// velocity limits (direction kept), integrated over `dt`, positions
/// clamped to the limits. The executed velocity goes to `velocity`;
/// returns whether a limit changed the step.
fn step(limits: &[crate::robot::JointLimits], q: &mut [f64], action: &[f64], velocity: &mut [f64], dt: f64) -> bool {
    let ratio = limits
        .iter()
        .zip(action)
        .map(|(l, a)| if l.velocity.is_finite() && l.velocity > 0.0 { a.abs() / l.velocity } else { 0.0 })
        .fold(0.0, f64::max);
    let scale = if ratio > 1.0 { 1.0 / ratio } else { 1.0 };
    let mut clamped = ratio > 1.0;
    for ((x, v), (l, a)) in q.iter_mut().zip(velocity.iter_mut()).zip(limits.iter().zip(action)) {
        let next = (*x + dt * a * scale).clamp(l.lower, l.upper);
        clamped |= next != *x + dt * a * scale;
        *v = (next - *x) / dt;
        *x = next;
    }
    clamped
}

/// Counts of outcomes, of rollouts or of shared-control episodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct OutcomeCounts {
    /// Grasped.
    pub success: usize,
    /// Touched something.
    pub collision: usize,
    /// Time ran out.
    pub timeout: usize,
    /// No policy for the task (its reference could not be optimized).
    pub no_policy: usize,
    /// A shared-control operator stopped where the task was not done.
    pub failed: usize,
}

impl OutcomeCounts {
    /// Counts one rollout's `outcome`.
    pub fn add(&mut self, outcome: RolloutOutcome) {
        match outcome {
            RolloutOutcome::Success => self.success += 1,
            RolloutOutcome::Collision => self.collision += 1,
            RolloutOutcome::Timeout => self.timeout += 1,
            RolloutOutcome::NoPolicy => self.no_policy += 1,
        }
    }

    /// Episodes counted.
    pub fn total(&self) -> usize {
        self.success + self.collision + self.timeout + self.no_policy + self.failed
    }

    /// Share of successes (0 without episodes).
    pub fn success_rate(&self) -> f64 {
        self.success as f64 / self.total().max(1) as f64
    }

    /// Counts of rollout `outcomes`.
    pub fn from_outcomes(outcomes: impl IntoIterator<Item = RolloutOutcome>) -> OutcomeCounts {
        let mut counts = OutcomeCounts::default();
        outcomes.into_iter().for_each(|o| counts.add(o));
        counts
    }
}

/// Two policies' rollouts on the same tasks, counted by task: where both
/// succeeded, only one did, or neither.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct PairedOutcomes {
    /// Tasks both policies succeeded on.
    pub both: usize,
    /// Tasks only the first succeeded on.
    pub first_only: usize,
    /// Tasks only the second succeeded on.
    pub second_only: usize,
    /// Tasks neither succeeded on.
    pub neither: usize,
}

impl PairedOutcomes {
    /// Counts `first[i]` against `second[i]`, task by task (the shorter
    /// length of the two).
    pub fn of(first: &[Rollout], second: &[Rollout]) -> PairedOutcomes {
        let mut p = PairedOutcomes::default();
        for (a, b) in first.iter().zip(second) {
            match (a.outcome == RolloutOutcome::Success, b.outcome == RolloutOutcome::Success) {
                (true, true) => p.both += 1,
                (true, false) => p.first_only += 1,
                (false, true) => p.second_only += 1,
                (false, false) => p.neither += 1,
            }
        }
        p
    }
}

/// Gripper distance from the grasp point (m) beyond which a collision
/// happened on the approach.
pub const APPROACH_DISTANCE: f64 = 0.10;
/// Gripper distance from the grasp point (m) within which a collision
/// happened in the last centimetres, between the pads; between this and
/// [`APPROACH_DISTANCE`] it happened on the descent.
pub const BETWEEN_PADS_DISTANCE: f64 = 0.02;

impl Rollout {
    /// A collision's phase, by the gripper's distance from the grasp point
    /// when it touched: `approach` (beyond [`APPROACH_DISTANCE`]),
    /// `descent`, or `between_pads` (within [`BETWEEN_PADS_DISTANCE`]);
    /// `None` for a rollout that did not collide.
    pub fn collision_phase(&self) -> Option<&'static str> {
        if !matches!(self.reason, Some(Reason::Collision { .. })) {
            return None;
        }
        Some(if self.distance > APPROACH_DISTANCE {
            "approach"
        } else if self.distance > BETWEEN_PADS_DISTANCE {
            "descent"
        } else {
            "between_pads"
        })
    }
}

/// Why rollouts ended, counted: by reason, and the collisions by phase
/// (the gripper's distance from the grasp point when it touched) and by
/// colliding pair.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize)]
pub struct FailureBreakdown {
    /// Rollouts by [`Reason::as_str`] (`no_policy` for a task without a policy).
    pub reasons: BTreeMap<String, usize>,
    /// Collisions by phase: `approach` (gripper farther than 10 cm from
    /// the grasp point), `descent` (2–10 cm), `between_pads` (within 2 cm).
    pub collision_phases: BTreeMap<String, usize>,
    /// Collisions by pair, `link–body`.
    pub collision_pairs: BTreeMap<String, usize>,
}

impl FailureBreakdown {
    /// The breakdown of `rollouts`.
    pub fn of(rollouts: &[Rollout]) -> FailureBreakdown {
        let mut b = FailureBreakdown::default();
        for r in rollouts {
            let name = r.reason.as_ref().map_or("no_policy", Reason::as_str);
            *b.reasons.entry(name.to_string()).or_default() += 1;
            if let (Some(phase), Some(Reason::Collision { pair: [a, c] })) = (r.collision_phase(), &r.reason) {
                *b.collision_phases.entry(phase.to_string()).or_default() += 1;
                *b.collision_pairs.entry(format!("{a}–{c}")).or_default() += 1;
            }
        }
        b
    }
}

/// For each configuration of `queries`, the joint-space (Euclidean)
/// distance to the closest of `data` (rad; +∞ when `data` is empty).
pub fn nearest_distances(queries: &[Vec<f64>], data: &[Vec<f64>]) -> Vec<f64> {
    queries
        .par_iter()
        .map(|q| {
            data.iter()
                .map(|d| d.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum::<f64>())
                .fold(f64::INFINITY, f64::min)
                .sqrt()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ended(outcome: RolloutOutcome, reason: Option<Reason>, distance: f64) -> Rollout {
        Rollout { outcome, steps: 1, clamped: 0, path: vec![], reason, distance }
    }

    #[test]
    fn collisions_are_phased_by_the_grippers_distance_and_tasks_paired() {
        let hit = |d| ended(RolloutOutcome::Collision, Some(Reason::Collision { pair: ["a".into(), "b".into()] }), d);
        let phases: Vec<_> = [0.5, 0.10, 0.05, 0.02, 0.0].map(|d| hit(d).collision_phase()).to_vec();
        let expected = ["approach", "descent", "descent", "between_pads", "between_pads"].map(Some);
        assert_eq!(phases, expected, "10 cm and 2 cm belong to the nearer phase");
        let success = || ended(RolloutOutcome::Success, Some(Reason::Success), 0.01);
        assert_eq!(success().collision_phase(), None);
        let none = ended(RolloutOutcome::NoPolicy, None, f64::NAN);
        let first = [success(), success(), hit(0.5), hit(0.5), success()];
        let second = [success(), none.clone(), success(), none, success()];
        let paired = PairedOutcomes::of(&first, &second);
        assert_eq!(paired, PairedOutcomes { both: 2, first_only: 1, second_only: 1, neither: 1 });
    }

    #[test]
    fn steps_respect_limits() {
        let limits = vec![crate::robot::JointLimits { lower: -1.0, upper: 1.0, velocity: 2.0, effort: 1.0 }; 2];
        let (mut q, mut v) = (vec![0.95, 0.0], vec![0.0; 2]);
        assert!(step(&limits, &mut q, &[4.0, 1.0], &mut v, 0.1), "4 rad/s is over the 2 rad/s limit");
        // Scaled to [2, 0.5] rad/s: joint 0 would reach 1.15, clamped at 1.
        assert!((q[0] - 1.0).abs() < 1e-12 && (q[1] - 0.05).abs() < 1e-12, "{q:?}");
        assert!((v[0] - 0.5).abs() < 1e-9 && (v[1] - 0.5).abs() < 1e-9, "{v:?}");
        assert!(!step(&limits, &mut q, &[-1.0, 0.0], &mut v, 0.1));
        assert!((q[0] - 0.9).abs() < 1e-12);
    }

    #[test]
    fn nearest_distance_is_the_closest_point() {
        let data = vec![vec![0.0, 0.0], vec![1.0, 1.0], vec![3.0, 0.0]];
        let d = nearest_distances(&[vec![1.0, 0.0], vec![3.0, 4.0]], &data);
        assert!((d[0] - 1.0).abs() < 1e-12 && (d[1] - 13f64.sqrt()).abs() < 1e-12, "{d:?}");
        assert_eq!(nearest_distances(&[vec![0.0]], &[]), vec![f64::INFINITY]);
    }
}
