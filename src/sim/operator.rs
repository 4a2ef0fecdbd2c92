//! Simulated operators (§5.5.2 and §6.5 of the dissertation): policies that
//! give the arbiter the commands a person would, from what they see of the
//! scene. Every operator commands the gripper's linear velocity (m/s, world
//! axes), the dissertation's 3-D interface, and says when it believes it has
//! arrived.
//!
//! Base behaviours aim at a point: [`Straightline`] straight at it,
//! [`Approach`] via a point above it, [`PolicyFollower`] along the robot's
//! own optimal policy toward it (the planar users of §6.5). Wrappers
//! disturb a base behaviour: [`Noisy`] (uniform joint noise of size `k`,
//! mapped through the Jacobian), [`Biased`] (aims at a point up to 5 cm off),
//! [`Laggy`] (acts on what it saw `m` steps ago). All randomness comes from
//! a seed.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;

/// What an operator sees each tick.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    /// The configuration (rad or m).
    pub q: &'a [f64],
    /// Gripper position (m, world).
    pub gripper: [f64; 3],
    /// The point the operator means to reach (m, world): the true goal's
    /// grasp point.
    pub goal: [f64; 3],
    /// Linear rows of the gripper Jacobian, row-major `3 × n`.
    pub jacobian: &'a [f64],
    /// The robot's optimal action toward the true goal (rad/s), for
    /// operators that follow it; empty when not provided.
    pub policy_action: &'a [f64],
    /// Seconds since the episode started.
    pub time: f64,
}

/// What an operator does this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OperatorAction {
    /// Command this linear velocity of the gripper (m/s, world axes).
    Move([f64; 3]),
    /// Believes the gripper is where it should be: grasp (or stop).
    Done,
}

/// A simulated operator.
pub trait Operator: Send {
    /// This tick's action.
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction;
    /// The operator's name (`straightline`, `noisy-0.1`, …).
    fn name(&self) -> String;
    /// Whether it reads [`Observation::policy_action`].
    fn needs_policy(&self) -> bool {
        false
    }
}

/// Speed and arrival settings shared by the base behaviours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pace {
    /// Cruise speed (m/s; default 0.1).
    pub speed: f64,
    /// Distance over which the speed ramps down to the target (m; default 0.05).
    pub slow_down: f64,
    /// Distance at which the operator believes it has arrived (m; default 0.01).
    pub arrive: f64,
}

impl Default for Pace {
    fn default() -> Self {
        Pace { speed: 0.1, slow_down: 0.05, arrive: 0.01 }
    }
}

/// Heads straight for the goal (the dissertation: "actions that point
/// directly toward the object").
#[derive(Debug, Clone, Copy, Default)]
pub struct Straightline {
    /// Speed and arrival.
    pub pace: Pace,
}

impl Operator for Straightline {
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction {
        move_to(seen.gripper, seen.goal, &self.pace)
    }

    fn name(&self) -> String {
        "straightline".into()
    }
}

/// Reaches a pre-grasp point `height` above the goal, then descends (the
/// dissertation: "actions to reach a pre-grasp position above the object
/// and descend to grab the object").
#[derive(Debug, Clone, Copy)]
pub struct Approach {
    /// Speed and arrival.
    pub pace: Pace,
    /// Height of the pre-grasp point above the goal (m; default 0.1).
    pub height: f64,
    descending: bool,
}

impl Approach {
    /// An approach at `speed` (m/s) with the default height and pace.
    pub fn at_speed(speed: f64) -> Self {
        Approach { pace: Pace { speed, ..Pace::default() }, ..Approach::default() }
    }
}

impl Default for Approach {
    fn default() -> Self {
        Approach { pace: Pace::default(), height: 0.1, descending: false }
    }
}

impl Operator for Approach {
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction {
        let above = [seen.goal[0], seen.goal[1], seen.goal[2] + self.height];
        if !self.descending && distance(seen.gripper, above) < self.pace.arrive {
            self.descending = true;
        }
        if self.descending {
            return move_to(seen.gripper, seen.goal, &self.pace);
        }
        match move_to(seen.gripper, above, &self.pace) {
            // The pre-grasp point is a waypoint, not the end.
            OperatorAction::Done => OperatorAction::Move([0.0; 3]),
            action => action,
        }
    }

    fn name(&self) -> String {
        "approach".into()
    }
}

/// Follows the robot's own policy toward the goal at the operator's speed
/// (the direction of `J π(q)`), switching to a straight line over the last
/// `slow_down` metres: the dissertation's planar users, who knew the way (§6.5).
#[derive(Debug, Clone, Copy, Default)]
pub struct PolicyFollower {
    /// Speed and arrival.
    pub pace: Pace,
}

impl Operator for PolicyFollower {
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction {
        let d = distance(seen.gripper, seen.goal);
        if d < self.pace.slow_down || seen.policy_action.is_empty() {
            return move_to(seen.gripper, seen.goal, &self.pace);
        }
        let mut v = [0.0; 3];
        let n = seen.policy_action.len();
        for (r, vr) in v.iter_mut().enumerate() {
            *vr = (0..n).map(|c| seen.jacobian[r * n + c] * seen.policy_action[c]).sum();
        }
        let norm = norm3(v);
        if norm < 1e-9 {
            return move_to(seen.gripper, seen.goal, &self.pace);
        }
        OperatorAction::Move(v.map(|x| x * self.pace.speed / norm))
    }

    fn name(&self) -> String {
        "policy".into()
    }

    fn needs_policy(&self) -> bool {
        true
    }
}

/// Adds uniform noise of size `k` on the joints each tick (rad/s, mapped to
/// the gripper through the Jacobian): the dissertation's Noisy-k, k = 0.1, 0.2.
pub struct Noisy<O> {
    /// The disturbed behaviour.
    pub inner: O,
    /// Noise size (rad/s per joint).
    pub k: f64,
    rng: ChaCha8Rng,
    noise: Vec<f64>,
}

impl<O: Operator> Noisy<O> {
    /// `inner` with joint noise of size `k`, seeded.
    pub fn new(inner: O, k: f64, seed: u64) -> Self {
        Noisy { inner, k, rng: ChaCha8Rng::seed_from_u64(seed), noise: vec![] }
    }
}

impl<O: Operator> Operator for Noisy<O> {
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction {
        let n = seen.q.len();
        self.noise.resize(n, 0.0);
        for x in &mut self.noise {
            *x = self.rng.random_range(-self.k..=self.k);
        }
        match self.inner.act(seen) {
            OperatorAction::Move(mut v) => {
                for (r, vr) in v.iter_mut().enumerate() {
                    *vr += (0..n).map(|c| seen.jacobian[r * n + c] * self.noise[c]).sum::<f64>();
                }
                OperatorAction::Move(v)
            }
            done => done,
        }
    }

    fn name(&self) -> String {
        format!("noisy-{}", self.k)
    }

    fn needs_policy(&self) -> bool {
        self.inner.needs_policy()
    }
}

/// Aims at the goal plus a constant offset drawn once, uniformly in a ball
/// of radius `radius` (the dissertation: "reaching the incorrect object
/// location with max. 5 cm error radius").
pub struct Biased<O> {
    /// The disturbed behaviour.
    pub inner: O,
    /// The offset of the aimed point (m, world).
    pub offset: [f64; 3],
}

impl<O: Operator> Biased<O> {
    /// `inner` with an offset uniform in the ball of `radius` (m), seeded.
    pub fn new(inner: O, radius: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let offset = loop {
            let p = [0; 3].map(|_| rng.random_range(-1.0..=1.0));
            if norm3(p) <= 1.0 {
                break p.map(|x| x * radius);
            }
        };
        Biased { inner, offset }
    }
}

impl<O: Operator> Operator for Biased<O> {
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction {
        let goal = [0, 1, 2].map(|i| seen.goal[i] + self.offset[i]);
        self.inner.act(&Observation { goal, ..*seen })
    }

    fn name(&self) -> String {
        "biased".into()
    }

    fn needs_policy(&self) -> bool {
        self.inner.needs_policy()
    }
}

/// What a laggy operator remembers of one tick.
struct Seen {
    q: Vec<f64>,
    gripper: [f64; 3],
    jacobian: Vec<f64>,
    policy_action: Vec<f64>,
}

/// Acts on the state it observed `m` ticks ago (the dissertation's Laggy-m, m = 5, 10).
pub struct Laggy<O> {
    /// The disturbed behaviour.
    pub inner: O,
    /// Lag in ticks.
    pub m: usize,
    history: VecDeque<Seen>,
}

impl<O: Operator> Laggy<O> {
    /// `inner` acting on observations `m` ticks old.
    pub fn new(inner: O, m: usize) -> Self {
        Laggy { inner, m, history: VecDeque::with_capacity(m + 1) }
    }
}

impl<O: Operator> Operator for Laggy<O> {
    fn act(&mut self, seen: &Observation<'_>) -> OperatorAction {
        self.history.push_back(Seen {
            q: seen.q.to_vec(),
            gripper: seen.gripper,
            jacobian: seen.jacobian.to_vec(),
            policy_action: seen.policy_action.to_vec(),
        });
        if self.history.len() > self.m + 1 {
            self.history.pop_front();
        }
        let old = &self.history[0];
        let stale = Observation {
            q: &old.q,
            gripper: old.gripper,
            jacobian: &old.jacobian,
            policy_action: &old.policy_action,
            ..*seen
        };
        self.inner.act(&stale)
    }

    fn name(&self) -> String {
        format!("laggy-{}", self.m)
    }

    fn needs_policy(&self) -> bool {
        self.inner.needs_policy()
    }
}

/// `speed` toward `to`, ramped down linearly over the last `slow_down`;
/// `Done` within `arrive`.
pub(crate) fn move_to(from: [f64; 3], to: [f64; 3], pace: &Pace) -> OperatorAction {
    let d = distance(from, to);
    if d < pace.arrive {
        return OperatorAction::Done;
    }
    // At least a fifth of the cruise speed, so the ramp does not stall.
    let s = pace.speed * (d / pace.slow_down.max(1e-9)).clamp(0.2, 1.0);
    OperatorAction::Move([0, 1, 2].map(|i| s * (to[i] - from[i]) / d))
}

pub(crate) fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm3([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
}

pub(crate) fn norm3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seen<'a>(q: &'a [f64], jac: &'a [f64], gripper: [f64; 3]) -> Observation<'a> {
        Observation { q, gripper, goal: [0.5, 0.0, 0.1], jacobian: jac, policy_action: &[], time: 0.0 }
    }

    const JAC: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

    #[test]
    fn straightline_heads_for_the_goal_and_arrives() {
        let mut op = Straightline::default();
        let OperatorAction::Move(v) = op.act(&seen(&[0.0; 3], &JAC, [0.0, 0.0, 0.1])) else { panic!() };
        assert!((v[0] - 0.1).abs() < 1e-12 && v[1].abs() < 1e-12);
        assert_eq!(op.act(&seen(&[0.0; 3], &JAC, [0.495, 0.0, 0.1])), OperatorAction::Done);
    }

    #[test]
    fn approach_goes_over_the_goal_first() {
        let mut op = Approach::default();
        let OperatorAction::Move(v) = op.act(&seen(&[0.0; 3], &JAC, [0.5, 0.0, 0.5])) else { panic!() };
        assert!(v[2] < 0.0 && v[0].abs() < 1e-12);
        // At the pre-grasp point it turns down, and stops only at the goal.
        let OperatorAction::Move(v) = op.act(&seen(&[0.0; 3], &JAC, [0.5, 0.0, 0.2])) else { panic!() };
        assert!(v[2] < -0.05 && v[0].abs() < 1e-12);
        let OperatorAction::Move(v) = op.act(&seen(&[0.0; 3], &JAC, [0.5, 0.0, 0.15])) else { panic!() };
        assert!(v[2] < -0.05);
        assert_eq!(op.act(&seen(&[0.0; 3], &JAC, [0.5, 0.0, 0.105])), OperatorAction::Done);
    }

    #[test]
    fn wrappers_are_seeded_and_do_what_they_say() {
        let q = [0.0; 3];
        let a = Noisy::new(Straightline::default(), 0.2, 7).act(&seen(&q, &JAC, [0.0, 0.0, 0.1]));
        let b = Noisy::new(Straightline::default(), 0.2, 7).act(&seen(&q, &JAC, [0.0, 0.0, 0.1]));
        assert_eq!(a, b);
        let OperatorAction::Move(v) = a else { panic!() };
        assert!((v[0] - 0.1).abs() <= 0.2 && v[1].abs() <= 0.2 && v[1] != 0.0);
        let biased = Biased::new(Straightline::default(), 0.05, 3);
        assert!(norm3(biased.offset) <= 0.05 && norm3(biased.offset) > 0.0);
        let mut laggy = Laggy::new(Straightline::default(), 2);
        laggy.act(&seen(&q, &JAC, [0.0, 0.0, 0.1]));
        laggy.act(&seen(&q, &JAC, [0.1, 0.0, 0.1]));
        // Sees the first observation still: full speed from x = 0.
        let OperatorAction::Move(v) = laggy.act(&seen(&q, &JAC, [0.49, 0.0, 0.1])) else { panic!() };
        assert!((v[0] - 0.1).abs() < 1e-12);
    }
}

/// A simulated operator by name and parameters, as the experiments and
/// `tandem arbitrate --operator` choose them (§5.5.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OperatorKind {
    /// Straight at the grasp point.
    Straightline,
    /// Via a point 10 cm above the grasp point.
    Approach,
    /// Approach with joint noise of this size (rad/s).
    Noisy(f64),
    /// Approach aiming up to 5 cm off.
    Biased,
    /// Approach acting on what it saw this many ticks ago.
    Laggy(usize),
}

impl OperatorKind {
    /// The seven operators of Table 5.1, in its order.
    pub const TABLE_5_1: [OperatorKind; 7] = [
        OperatorKind::Straightline,
        OperatorKind::Approach,
        OperatorKind::Noisy(0.1),
        OperatorKind::Noisy(0.2),
        OperatorKind::Biased,
        OperatorKind::Laggy(5),
        OperatorKind::Laggy(10),
    ];

    /// The name in tables and JSON (`noisy-0.1`, …).
    pub fn name(&self) -> String {
        match self {
            OperatorKind::Straightline => "straightline".into(),
            OperatorKind::Approach => "approach".into(),
            OperatorKind::Noisy(k) => format!("noisy-{k}"),
            OperatorKind::Biased => "biased".into(),
            OperatorKind::Laggy(m) => format!("laggy-{m}"),
        }
    }

    /// The operator at `speed` (m/s), its randomness from `seed`.
    pub fn build(&self, speed: f64, seed: u64) -> Box<dyn Operator> {
        let approach = Approach::at_speed(speed);
        match *self {
            OperatorKind::Straightline => Box::new(Straightline { pace: Pace { speed, ..Pace::default() } }),
            OperatorKind::Approach => Box::new(approach),
            OperatorKind::Noisy(k) => Box::new(Noisy::new(approach, k, seed)),
            OperatorKind::Biased => Box::new(Biased::new(approach, 0.05, seed)),
            OperatorKind::Laggy(m) => Box::new(Laggy::new(approach, m)),
        }
    }
}

/// A simulated user of the planar task (§6.5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlanarUser {
    /// Straight at the goal.
    Straight,
    /// The optimal policy plus uniform noise of this many times the speed.
    Noisy(f64),
    /// Aims up to 5 cm off.
    Biased,
}

impl PlanarUser {
    /// The users of Table 6.1.
    pub const ALL: [PlanarUser; 4] =
        [PlanarUser::Noisy(0.5), PlanarUser::Noisy(1.0), PlanarUser::Straight, PlanarUser::Biased];

    /// `straight`, `noisy-0.5`, …
    pub fn name(&self) -> String {
        match self {
            PlanarUser::Straight => "straight".into(),
            PlanarUser::Noisy(s) => format!("noisy-{s}"),
            PlanarUser::Biased => "biased".into(),
        }
    }

    /// The user at `speed` (m/s), its randomness from `seed`.
    pub fn build(&self, speed: f64, seed: u64) -> Box<dyn Operator> {
        let pace = Pace { speed, slow_down: 0.03, arrive: 0.005 };
        let follower = PolicyFollower { pace };
        match *self {
            PlanarUser::Straight => Box::new(Straightline { pace }),
            PlanarUser::Noisy(s) => Box::new(Noisy::new(follower, s * speed, seed)),
            PlanarUser::Biased => Box::new(Biased::new(follower, 0.05, seed)),
        }
    }
}
