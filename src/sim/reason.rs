//! Why an episode ended: a closed set of reasons, each carrying what a
//! person needs to see what went wrong (the colliding pair, how far short,
//! how tilted).

use crate::problem::{GraspCriteria, GraspReport};

/// Why an episode ended. Its [`Outcome`](super::Outcome) follows from it
/// ([`Reason::outcome`]); new reasons may be added (match with a wildcard).
///
/// ```
/// use tandem::sim::{Outcome, Reason};
/// let r = Reason::OrientationOff { angle: 0.31, max_tilt: 0.2 };
/// assert_eq!((r.outcome(), r.as_str()), (Outcome::Failed, "orientation_off"));
/// assert_eq!(r.to_string(), "the gripper is tilted 0.31 rad from the grasp's approach axis (at most 0.2)");
/// ```
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Reason {
    /// The task's judge agreed.
    Success,
    /// The arm touched something: the two bodies (a robot link, and an
    /// obstacle, an object or another link).
    Collision {
        /// The pair's names.
        pair: [String; 2],
    },
    /// Time ran out with the gripper this far from the goal (m).
    Timeout {
        /// Distance of the gripper from the goal's grasp point (m).
        distance: f64,
    },
    /// The operator stopped, believing it had arrived, this far from the
    /// goal (m).
    StoppedShort {
        /// Distance of the gripper from the goal's grasp point (m).
        distance: f64,
        /// The distance within which a stop counts as arrived (m).
        tolerance: f64,
    },
    /// At the object, but the gripper's approach axis is this far from the
    /// grasp's (rad).
    OrientationOff {
        /// Angle between the axes (rad).
        angle: f64,
        /// The largest angle a grasp may have (rad).
        max_tilt: f64,
    },
    /// At the object, but the object is not between the finger pads.
    NotBetweenPads,
    /// At the object, but the fingertip centre is outside the object's
    /// footprint seen along the approach.
    OutsideFootprint,
    /// At the object, but the palm or a finger's outer side touches it.
    TouchingObject {
        /// Smallest clearance of the palm and the fingers' outer sides (m;
        /// negative inside).
        clearance: f64,
    },
    /// The operator stopped at the goal, and a judge that gives no reason
    /// (a closure) said the task was not done.
    JudgeDeclined,
    /// Physics: the arm pushed the object this far (m) before the fingers
    /// closed (the dissertation's "has not deviated", §5.5.3).
    Pushed {
        /// How far the object's centre moved (m).
        distance: f64,
        /// How far it may move (m; `PhysicsSettings::push_tolerance`).
        limit: f64,
    },
    /// Physics: the fingers closed and the arm lifted, but the object rose
    /// only this much (m).
    Slipped {
        /// The object's rise when the lift ended (m).
        lifted: f64,
        /// The rise a grasp must reach (m; `PhysicsSettings::lifted`).
        needed: f64,
    },
    /// Physics: the object was lifted, then fell below the rise a grasp
    /// must hold during the hold.
    Dropped {
        /// The object's rise when the hold ended (m).
        lifted: f64,
        /// The rise a grasp must hold (m; `PhysicsSettings::lifted`).
        needed: f64,
    },
}

impl Reason {
    /// The first grasp criterion `report` fails, in the judge's order
    /// (`JudgeDeclined` when it fails none).
    pub fn of_grasp(report: &GraspReport, criteria: &GraspCriteria) -> Reason {
        if !report.between_pads {
            Reason::NotBetweenPads
        } else if !report.in_footprint {
            Reason::OutsideFootprint
        } else if report.tilt > criteria.max_tilt {
            Reason::OrientationOff { angle: report.tilt, max_tilt: criteria.max_tilt }
        } else if report.palm_clearance < criteria.margin || report.finger_clearance < criteria.margin {
            Reason::TouchingObject { clearance: report.palm_clearance.min(report.finger_clearance) }
        } else {
            Reason::JudgeDeclined
        }
    }

    /// The outcome this reason is one of.
    pub fn outcome(&self) -> super::Outcome {
        use super::Outcome;
        match self {
            Reason::Success => Outcome::Success,
            Reason::Collision { .. } | Reason::Pushed { .. } => Outcome::Collision,
            Reason::Timeout { .. } => Outcome::Timeout,
            _ => Outcome::Failed,
        }
    }

    /// The reason in snake case (`success`, `collision`, `timeout`,
    /// `stopped_short`, `orientation_off`, `not_between_pads`,
    /// `outside_footprint`, `touching_object`, `judge_declined`, and in
    /// physics `pushed`, `slipped`, `dropped`).
    pub fn as_str(&self) -> &'static str {
        match self {
            Reason::Success => "success",
            Reason::Collision { .. } => "collision",
            Reason::Timeout { .. } => "timeout",
            Reason::StoppedShort { .. } => "stopped_short",
            Reason::OrientationOff { .. } => "orientation_off",
            Reason::NotBetweenPads => "not_between_pads",
            Reason::OutsideFootprint => "outside_footprint",
            Reason::TouchingObject { .. } => "touching_object",
            Reason::JudgeDeclined => "judge_declined",
            Reason::Pushed { .. } => "pushed",
            Reason::Slipped { .. } => "slipped",
            Reason::Dropped { .. } => "dropped",
        }
    }

    /// Every reason's name, as [`as_str`](Self::as_str) gives them.
    pub const NAMES: [&'static str; 12] = [
        "success",
        "collision",
        "timeout",
        "stopped_short",
        "orientation_off",
        "not_between_pads",
        "outside_footprint",
        "touching_object",
        "judge_declined",
        "pushed",
        "slipped",
        "dropped",
    ];
}

impl std::fmt::Display for Reason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let cm = |d: f64| 100.0 * d;
        match self {
            Reason::Success => write!(f, "the task is done"),
            Reason::Collision { pair: [a, b] } => write!(f, "{a} touched {b}"),
            Reason::Timeout { distance } => {
                write!(f, "time ran out {:.1} cm from the goal", cm(*distance))
            }
            Reason::StoppedShort { distance, tolerance } => write!(
                f,
                "the operator stopped {:.1} cm from the goal (within {} cm counts)",
                cm(*distance),
                bound(cm(*tolerance))
            ),
            Reason::OrientationOff { angle, max_tilt } => write!(
                f,
                "the gripper is tilted {angle:.2} rad from the grasp's approach axis (at most {})",
                bound(*max_tilt)
            ),
            Reason::NotBetweenPads => write!(f, "the object is not between the finger pads"),
            Reason::OutsideFootprint => write!(f, "the fingertip centre is outside the object's footprint"),
            Reason::TouchingObject { clearance } => {
                write!(f, "the palm or a finger's outer side touches the object ({:.1} mm)", 1e3 * clearance)
            }
            Reason::JudgeDeclined => write!(f, "the operator stopped at the goal, but the task is not done"),
            Reason::Pushed { distance, limit } => write!(
                f,
                "the arm pushed the object {:.1} cm before the fingers closed (under {} cm counts)",
                cm(*distance),
                bound(cm(*limit))
            ),
            Reason::Slipped { lifted, needed } => write!(
                f,
                "the object slipped from the fingers: lifted {:.1} cm (at least {} cm counts)",
                cm(*lifted),
                bound(cm(*needed))
            ),
            Reason::Dropped { lifted, needed } => write!(
                f,
                "the object was lifted, then dropped: {:.1} cm at the end of the hold (at least {} cm counts)",
                cm(*lifted),
                bound(cm(*needed))
            ),
        }
    }
}

/// A threshold as a person writes it: at most three decimals, no trailing
/// zeros (0.2, 1, 1.5; not 1.0000000000000002).
fn bound(value: f64) -> String {
    let text = format!("{value:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::Reason;

    #[test]
    fn a_failure_states_the_bound_it_was_judged_by() {
        let stopped = Reason::StoppedShort { distance: 0.123, tolerance: 0.01 };
        assert_eq!(stopped.to_string(), "the operator stopped 12.3 cm from the goal (within 1 cm counts)");
        let tilted = Reason::OrientationOff { angle: 0.31, max_tilt: 0.15 };
        assert!(tilted.to_string().ends_with("(at most 0.15)"), "{tilted}");
        // Settings other than the defaults show as set, not as the defaults.
        let pushed = Reason::Pushed { distance: 0.031, limit: 0.015 };
        assert_eq!(
            pushed.to_string(),
            "the arm pushed the object 3.1 cm before the fingers closed (under 1.5 cm counts)"
        );
        let slipped = Reason::Slipped { lifted: 0.012, needed: 0.03 };
        assert!(slipped.to_string().ends_with("lifted 1.2 cm (at least 3 cm counts)"), "{slipped}");
        let dropped = Reason::Dropped { lifted: 0.01, needed: 0.07 };
        assert!(dropped.to_string().ends_with("(at least 7 cm counts)"), "{dropped}");
    }
}
