//! Why an episode ended: a closed set of reasons, each carrying what a
//! person needs to see what went wrong (the colliding pair, how far short,
//! how tilted).

use crate::problem::{GraspCriteria, GraspReport};

// The thresholds the judge applies live here: they bound `StoppedShort` and
// `OrientationOff`, whose messages state them.

/// Largest tilt of a successful teleoperated grasp (rad).
pub const GRASP_MAX_TILT: f64 = 0.2;
/// Distance to the goal position of a successful reach (m).
pub const REACH_TOLERANCE: f64 = 0.01;

/// Why an episode ended. Its [`Outcome`](super::Outcome) follows from it
/// ([`Reason::outcome`]); new reasons may be added (match with a wildcard).
///
/// ```
/// use tandem::sim::{Outcome, Reason};
/// let r = Reason::OrientationOff { angle: 0.31 };
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
    },
    /// At the object, but the gripper's approach axis is this far from the
    /// grasp's (rad).
    OrientationOff {
        /// Angle between the axes (rad).
        angle: f64,
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
    /// closed (the dissertation's "has not deviated", §5.5.3; 2 cm).
    Pushed {
        /// How far the object's centre moved (m).
        distance: f64,
    },
    /// Physics: the fingers closed and the arm lifted, but the object rose
    /// only this much (m; at least 5 cm counts).
    Slipped {
        /// The object's rise when the lift ended (m).
        lifted: f64,
    },
    /// Physics: the object was lifted, then fell below 5 cm during the hold.
    Dropped {
        /// The object's rise when the hold ended (m).
        lifted: f64,
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
            Reason::OrientationOff { angle: report.tilt }
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
            Reason::StoppedShort { distance } => write!(
                f,
                "the operator stopped {:.1} cm from the goal (within {:.0} cm counts)",
                cm(*distance),
                cm(REACH_TOLERANCE)
            ),
            Reason::OrientationOff { angle } => write!(
                f,
                "the gripper is tilted {angle:.2} rad from the grasp's approach axis (at most {GRASP_MAX_TILT})"
            ),
            Reason::NotBetweenPads => write!(f, "the object is not between the finger pads"),
            Reason::OutsideFootprint => write!(f, "the fingertip centre is outside the object's footprint"),
            Reason::TouchingObject { clearance } => {
                write!(f, "the palm or a finger's outer side touches the object ({:.1} mm)", 1e3 * clearance)
            }
            Reason::JudgeDeclined => write!(f, "the operator stopped at the goal, but the task is not done"),
            Reason::Pushed { distance } => {
                write!(
                    f,
                    "the arm pushed the object {:.1} cm before the fingers closed (under 2 cm counts)",
                    cm(*distance)
                )
            }
            Reason::Slipped { lifted } => {
                write!(f, "the object slipped from the fingers: lifted {:.1} cm (at least 5 cm counts)", cm(*lifted))
            }
            Reason::Dropped { lifted } => {
                write!(f, "the object was lifted, then dropped: {:.1} cm at the end of the hold", cm(*lifted))
            }
        }
    }
}
