//! What goes into a tick (the operator's command, the state) and what comes
//! out (the joint velocity, a status from a closed set, diagnostics).

use super::ArbitrationMode;

/// The operator's command for one tick. Task-space commands are velocities
/// of the arbiter's gripper frame: its origin's linear velocity and the
/// frame's angular velocity, both in world axes (the robot's root frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HumanCommand<'a> {
    /// Linear velocity of the gripper origin (m/s, world axes): 3 values.
    /// The arbiter chooses the orientation (§5.3 of the dissertation, eq. 5.7).
    Linear(&'a [f64]),
    /// Twist of the gripper: linear velocity (m/s) then angular velocity
    /// (rad/s), world axes: 6 values (eq. 5.9).
    Twist(&'a [f64]),
    /// Joint velocities (rad/s or m/s), one per active joint.
    Joint(&'a [f64]),
}

impl HumanCommand<'_> {
    /// The values of the command.
    pub fn values(&self) -> &[f64] {
        match self {
            HumanCommand::Linear(v) | HumanCommand::Twist(v) | HumanCommand::Joint(v) => v,
        }
    }

    /// How many values the command must have for a robot of `n` joints.
    pub fn expected_len(&self, n: usize) -> usize {
        match self {
            HumanCommand::Linear(_) => 3,
            HumanCommand::Twist(_) => 6,
            HumanCommand::Joint(_) => n,
        }
    }
}

/// `linear` scaled down to `max_speed` (m/s) when faster, its direction
/// kept; NaN stays NaN. The norm is taken of the vector divided by its
/// largest component, so that 1e308 m/s (whose squares overflow to
/// infinity, and whose plain scaling made it zero) becomes `max_speed` along
/// the same direction; an infinite component points along its axes.
pub fn limit_speed(linear: [f64; 3], max_speed: f64) -> [f64; 3] {
    if linear.iter().any(|v| v.is_nan()) {
        return linear;
    }
    let largest = linear.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if largest == 0.0 {
        return linear;
    }
    let unit = if largest.is_infinite() {
        linear.map(|v| if v.is_infinite() { v.signum() } else { 0.0 })
    } else {
        linear.map(|v| v / largest)
    };
    let norm = largest * unit.iter().map(|u| u * u).sum::<f64>().sqrt();
    if norm <= max_speed {
        return linear;
    }
    let unit_norm = unit.iter().map(|u| u * u).sum::<f64>().sqrt();
    unit.map(|u| u / unit_norm * max_speed)
}

/// Everything one tick reads.
#[derive(Debug, Clone, Copy)]
pub struct TickInput<'a> {
    /// The configuration (rad or m, one per active joint).
    pub q: &'a [f64],
    /// The current joint velocity (e.g. the last command executed); zero
    /// when `None`. The robot policies read it (their state is `[q, q̇]`).
    pub velocity: Option<&'a [f64]>,
    /// The operator's command.
    pub command: HumanCommand<'a>,
    /// Beliefs over the goals (non-negative, summing to 1) that replace the
    /// arbiter's own intent estimate this tick; `None` to use the estimate.
    pub beliefs: Option<&'a [f64]>,
}

impl<'a> TickInput<'a> {
    /// A tick at `q` from rest with command `command` and estimated beliefs.
    pub fn new(q: &'a [f64], command: HumanCommand<'a>) -> Self {
        TickInput { q, velocity: None, command, beliefs: None }
    }
}

/// How a tick went: a closed set, like MoveIt Servo's status codes. Every
/// status comes with a command that is safe to execute. New statuses may
/// be added: match with a wildcard arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum TickStatus {
    /// The mode's command, no hard constraint binding.
    #[default]
    Nominal,
    /// The mode's command, no hard constraint binding, but a task command
    /// near a singularity: damped least squares slowed the directions
    /// losing rank (the arm keeps moving in the others; see
    /// [`DampingSettings`](super::DampingSettings)).
    SingularityDamped,
    /// A hard constraint (joint position or velocity limit, distance
    /// margin, or an acceleration, deceleration or jerk limit — the
    /// command then ramps toward the mode's) shaped the command: the
    /// closest safe one was executed.
    Constrained,
    /// The certified check of the step found it unsafe (linearised distances
    /// are only first order); a shorter step was executed.
    StepShortened,
    /// No safe step was found: hold.
    Halted,
    /// The operator's command had the wrong length or a NaN or infinite
    /// value: hold.
    InvalidCommand,
    /// The configuration or velocity had the wrong length or a NaN or
    /// infinite value: hold.
    InvalidState,
    /// The beliefs given had the wrong length, a negative or non-finite
    /// value, or did not sum to 1: hold.
    InvalidBeliefs,
    /// The hard constraints admit no command: hold. (With the state within
    /// its limits this cannot happen: `u = 0` meets every row.)
    Infeasible,
    /// The solver failed (iteration limit, numerical trouble): hold.
    SolverFailed,
    /// A robot policy could not answer: assistance was dropped this tick
    /// and the operator's command executed under the hard constraints.
    PolicyFailed,
    /// The arm is in collision at this configuration: only motions that do
    /// not deepen a contact are executed (without certification).
    InCollision,
}

impl TickStatus {
    /// True when the tick held: the executed command is the braking step, a
    /// controlled stop within the motion limits that is exactly zero once
    /// the arm is at rest (zero at once without the limits, see
    /// [`SafetySettings::motion_limits`](super::SafetySettings::motion_limits)).
    pub fn is_hold(&self) -> bool {
        matches!(
            self,
            TickStatus::Halted
                | TickStatus::InvalidCommand
                | TickStatus::InvalidState
                | TickStatus::InvalidBeliefs
                | TickStatus::Infeasible
                | TickStatus::SolverFailed
        )
    }

    /// The status in snake case (`nominal`, `step_shortened`, …).
    pub fn as_str(&self) -> &'static str {
        match self {
            TickStatus::Nominal => "nominal",
            TickStatus::SingularityDamped => "singularity_damped",
            TickStatus::Constrained => "constrained",
            TickStatus::StepShortened => "step_shortened",
            TickStatus::Halted => "halted",
            TickStatus::InvalidCommand => "invalid_command",
            TickStatus::InvalidState => "invalid_state",
            TickStatus::InvalidBeliefs => "invalid_beliefs",
            TickStatus::Infeasible => "infeasible",
            TickStatus::SolverFailed => "solver_failed",
            TickStatus::PolicyFailed => "policy_failed",
            TickStatus::InCollision => "in_collision",
        }
    }
}

/// What a tick did, for logs and plots.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Diagnostics {
    /// The mode that ran.
    pub mode: ArbitrationMode,
    /// The most likely goal and its belief.
    pub goal: Option<usize>,
    /// The belief of the most likely goal.
    pub confidence: f64,
    /// Linear blending's `α` (0 in other modes).
    pub alpha: f64,
    /// Hard-constraint rows built this tick (joint bounds with finite
    /// limits count two per joint, plus one per pair within reach).
    pub rows: usize,
    /// Pairs within reach of the margin this tick.
    pub distance_pairs: usize,
    /// Rows binding at the executed command.
    pub active_rows: usize,
    /// Smallest signed distance among the pairs within reach (m; +∞ when none).
    pub min_distance: f64,
    /// Solver calls this tick (0 when the closed form was feasible) and
    /// their iterations.
    pub solves: u32,
    /// Their iterations, summed.
    pub solver_iterations: u32,
    /// Fraction of the solved step executed after certification (1 unless shortened).
    pub step_fraction: f64,
    /// Condition number of the metric used (1 for the identity).
    pub metric_condition: f64,
}

/// The result of a tick: the joint velocity to execute for one control
/// period (rad/s or m/s), why, and how.
#[derive(Debug, Clone, Copy)]
pub struct Command<'w> {
    /// The joint velocity to execute for one period (rad/s or m/s).
    pub qdot: &'w [f64],
    /// What happened, from a closed set.
    pub status: TickStatus,
    /// How it happened.
    pub diagnostics: Diagnostics,
}
