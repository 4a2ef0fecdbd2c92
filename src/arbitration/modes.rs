//! The arbitration modes and their objectives: each mode turns the
//! operator's command, the robot actions, the beliefs and a metric into a
//! QP (or, for `Constrained`, an SOCP) over the joint velocity `u`, whose
//! unconstrained solution is the mode's closed form from the dissertation.

use crate::settings::{InvalidSetting, check, positive};
use std::fmt;
use std::str::FromStr;

/// How linear blending sets its `α` from the goal confidence (Dragan &
/// Srinivasa 2013).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BlendingStyle {
    /// `α` grows with the confidence but never reaches 1 (the dissertation's LB).
    Timid,
    /// `α = 1` once the confidence passes a threshold, 0 before.
    Aggressive,
}

/// Where the natural gradient's Fisher metric lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MetricSpace {
    /// Gripper positions: the operator's linear velocity is shaped by a
    /// 3 × 3 metric of the robot policy mapped to task space (§4.3).
    Task,
    /// Joint space: the operator's command, mapped to joints, is shaped by
    /// an n × n metric.
    Joint,
}

/// How the operator's command and the robot policy are blended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ArbitrationMode {
    /// The operator's command, made safe (closest command that meets the
    /// hard constraints; task commands through a damped pseudo-inverse).
    #[default]
    DirectControl,
    /// `u = α a_R + (1 − α) a_H` (§4.1), `a_R` the most likely goal's action.
    LinearBlending(BlendingStyle),
    /// Minimal intervention: the command closest to the operator's whose
    /// distances to everything shrink no faster than a rate proportional to
    /// the distance left above the margin (a control barrier function).
    ObstacleAvoidance,
    /// `u = F⁻¹ a_H` (§4.3, eq. 4.5) with the Fisher metric of the robot
    /// policies (Algorithm 3, belief-weighted by Algorithm 2), at the
    /// operator's speed.
    NaturalGradient(MetricSpace),
    /// `max ⟨J† v_H, u⟩ s.t. ‖u − κ ā_R‖²_W ≤ ε` (§5.3.1, eq. 5.2–5.3, 5.7–5.9):
    /// the operator's command mapped by `J†` and shaped by `W⁻¹`, the trust
    /// region a second-order cone whose radius keeps the operator's speed.
    Constrained,
    /// `min ‖J u − v_H‖²_C + ‖u‖²_W`, `C⁻¹ = εI` (§5.3.2, eq. 5.4 linearised).
    SumOfSquares,
    /// A learned arbitration policy (§6.4: the DDPG actor trained with the
    /// disagreement reward) maps the arbitration state to the gripper
    /// velocity, executed as direct control under the hard constraints.
    /// Needs a policy ([`Arbiter::with_arbitration_policy`](super::Arbiter::with_arbitration_policy));
    /// not in [`ArbitrationMode::ALL`], which lists the modes every arbiter runs.
    Learned,
}

impl ArbitrationMode {
    /// Every mode, in the order of the dissertation's chapters.
    pub const ALL: [ArbitrationMode; 8] = [
        ArbitrationMode::DirectControl,
        ArbitrationMode::LinearBlending(BlendingStyle::Timid),
        ArbitrationMode::LinearBlending(BlendingStyle::Aggressive),
        ArbitrationMode::ObstacleAvoidance,
        ArbitrationMode::NaturalGradient(MetricSpace::Task),
        ArbitrationMode::NaturalGradient(MetricSpace::Joint),
        ArbitrationMode::Constrained,
        ArbitrationMode::SumOfSquares,
    ];

    /// The name used on the command line and in JSON.
    pub fn as_str(&self) -> &'static str {
        match self {
            ArbitrationMode::DirectControl => "direct",
            ArbitrationMode::LinearBlending(BlendingStyle::Timid) => "blend-timid",
            ArbitrationMode::LinearBlending(BlendingStyle::Aggressive) => "blend-aggressive",
            ArbitrationMode::ObstacleAvoidance => "avoid",
            ArbitrationMode::NaturalGradient(MetricSpace::Task) => "natural-gradient",
            ArbitrationMode::NaturalGradient(MetricSpace::Joint) => "natural-gradient-joint",
            ArbitrationMode::Constrained => "constrained",
            ArbitrationMode::SumOfSquares => "sos",
            ArbitrationMode::Learned => "learned",
        }
    }

    /// True for the mode posed as an SOCP (the others are QPs).
    pub fn is_conic(&self) -> bool {
        matches!(self, ArbitrationMode::Constrained)
    }

    /// True when the mode reads a metric of the robot policies.
    pub(crate) fn metric(&self) -> Option<MetricKind> {
        match self {
            ArbitrationMode::Constrained | ArbitrationMode::SumOfSquares => Some(MetricKind::Hessian),
            ArbitrationMode::NaturalGradient(MetricSpace::Joint) => Some(MetricKind::Fisher),
            ArbitrationMode::NaturalGradient(MetricSpace::Task) => Some(MetricKind::TaskFisher),
            _ => None,
        }
    }
}

/// Which metric a mode reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MetricKind {
    Hessian,
    Fisher,
    TaskFisher,
}

impl fmt::Display for ArbitrationMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A mode name that is not one of [`ArbitrationMode::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown arbitration mode '{0}' (have: direct, blend-timid, blend-aggressive, avoid, natural-gradient, natural-gradient-joint, constrained, sos, learned)"
)]
pub struct UnknownMode(pub String);

impl FromStr for ArbitrationMode {
    type Err = UnknownMode;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ArbitrationMode::ALL
            .iter()
            .copied()
            .chain([ArbitrationMode::Learned])
            .find(|m| m.as_str() == s)
            .ok_or_else(|| UnknownMode(s.to_string()))
    }
}

/// Settings of the modes.
///
/// ```
/// # use tandem::arbitration::ModeSettings;
/// let s = ModeSettings::default();
/// assert_eq!((s.timid_max_alpha, s.aggressive_threshold, s.sum_of_squares_epsilon), (0.8, 0.6, 0.01));
/// assert_eq!((s.sum_of_squares_center, s.constrained_center, s.keep_speed), (0.0, 0.0, true));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeSettings {
    /// Timid blending: `α = timid_max_alpha · c`, `c` the confidence
    /// rescaled so that uniform beliefs give 0 and certainty 1.
    pub timid_max_alpha: f64,
    /// Aggressive blending: `α = 1` once `c` reaches this.
    pub aggressive_threshold: f64,
    /// `ε = C⁻¹` of sum-of-squares.
    pub sum_of_squares_epsilon: f64,
    /// `κ` of sum-of-squares' preferred step: `min ‖J u − v‖²_C + ‖u −
    /// κ ā_R‖²_W`.
    pub sum_of_squares_center: f64,
    /// `κ` of the constrained trust region's centre `κ ā_R` (`ā_R` the
    /// belief-weighted robot action).
    pub constrained_center: f64,
    /// Natural gradient and constrained: scale the shaped command to the
    /// operator's speed (task speed for task commands).
    pub keep_speed: bool,
}

impl Default for ModeSettings {
    fn default() -> Self {
        ModeSettings {
            timid_max_alpha: 0.8,
            aggressive_threshold: 0.6,
            // The task velocity met to about 1 %, the metric normalised to
            // mean eigenvalue 1.
            sum_of_squares_epsilon: 0.01,
            // The dissertation's eq. 5.4 (which prefers no motion) and 5.3.
            sum_of_squares_center: 0.0,
            constrained_center: 0.0,
            // §5.7 found the normalised 6-D mode slower than the operator asked.
            keep_speed: true,
        }
    }
}

impl ModeSettings {
    /// Checks every setting: blending factors in [0, 1], ε above 0, the
    /// centres finite.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        let unit = |v: f64| (0.0..=1.0).contains(&v);
        check("timid_max_alpha", self.timid_max_alpha, unit(self.timid_max_alpha), "in [0, 1]")?;
        check("aggressive_threshold", self.aggressive_threshold, unit(self.aggressive_threshold), "in [0, 1]")?;
        positive("sum_of_squares_epsilon", self.sum_of_squares_epsilon, "")?;
        let finite = |v: f64| v.is_finite();
        check("sum_of_squares_center", self.sum_of_squares_center, finite(self.sum_of_squares_center), "finite")?;
        check("constrained_center", self.constrained_center, finite(self.constrained_center), "finite")
    }
}

impl ModeSettings {
    /// Linear blending's `α` for `style` given the largest belief among
    /// `goals` goals.
    pub fn blending_alpha(&self, style: BlendingStyle, confidence: f64, goals: usize) -> f64 {
        if goals == 0 {
            return 0.0;
        }
        let uniform = 1.0 / goals as f64;
        let c = if goals == 1 { 1.0 } else { ((confidence - uniform) / (1.0 - uniform)).clamp(0.0, 1.0) };
        match style {
            BlendingStyle::Timid => self.timid_max_alpha.clamp(0.0, 1.0) * c,
            BlendingStyle::Aggressive => f64::from(c >= self.aggressive_threshold),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for m in ArbitrationMode::ALL {
            assert_eq!(m.as_str().parse::<ArbitrationMode>().unwrap(), m);
        }
        assert!("telepathy".parse::<ArbitrationMode>().unwrap_err().to_string().contains("constrained"));
    }

    #[test]
    fn blending_alpha_follows_the_confidence() {
        let s = ModeSettings::default();
        assert_eq!(s.blending_alpha(BlendingStyle::Timid, 0.5, 2), 0.0);
        assert!((s.blending_alpha(BlendingStyle::Timid, 1.0, 2) - 0.8).abs() < 1e-15);
        assert!((s.blending_alpha(BlendingStyle::Timid, 0.75, 2) - 0.4).abs() < 1e-15);
        assert_eq!(s.blending_alpha(BlendingStyle::Aggressive, 0.75, 2), 0.0);
        assert_eq!(s.blending_alpha(BlendingStyle::Aggressive, 0.85, 2), 1.0);
        assert_eq!(s.blending_alpha(BlendingStyle::Timid, 0.3, 0), 0.0);
    }
}
