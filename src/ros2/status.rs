//! The status topic's values (`std_msgs/Int8`): each tick's
//! [`TickStatus`] as the MoveIt Servo status code a Servo user's tools
//! already read, and tandem's own codes, from 10 up, where Servo has none.
//!
//! | value | MoveIt Servo (jazzy and later) | tandem |
//! | --- | --- | --- |
//! | −1 | `INVALID` | `invalid_command`, `invalid_state`, `invalid_beliefs` (hold) |
//! | 0 | `NO_WARNING` | `nominal` |
//! | 1 | `DECELERATE_FOR_APPROACHING_SINGULARITY` | `singularity_damped` |
//! | 4 | `DECELERATE_FOR_COLLISION` | `step_shortened` (the certified check cut the step) |
//! | 5 | `HALT_FOR_COLLISION` | `halted` (no safe step: hold) |
//! | 10 | — | `constrained`: a joint limit or distance shaped the command |
//! | 11 | — | `in_collision`: only motions out of the contact |
//! | 12 | — | `infeasible` (hold) |
//! | 13 | — | `solver_failed` (hold) |
//! | 14 | — | `policy_failed`: the operator's command under the hard constraints |
//!
//! Servo's 2, 3, 6 and 7 (halt for singularity, leaving a singularity,
//! joint bound, pose achieved) are not produced: the arbiter does not stop
//! at singularities and turns joint bounds into constraints. MoveIt Humble
//! numbered Servo's codes differently (collision 3 and 4, joint bound 5);
//! [`ServoCodes::Humble`] follows it.

use crate::arbitration::TickStatus;

/// Which release's numbering of MoveIt Servo's status codes to follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ServoCodes {
    /// MoveIt 2 Jazzy and later (`moveit_servo/utils/datatypes.hpp`).
    #[default]
    Jazzy,
    /// MoveIt 2 Humble (`moveit_servo/status_codes.h`).
    Humble,
}

/// The status topic's value for a tick's `status` (see the table above).
pub fn status_code(status: TickStatus, codes: ServoCodes) -> i8 {
    let (decelerate_for_collision, halt_for_collision) = match codes {
        ServoCodes::Jazzy => (4, 5),
        ServoCodes::Humble => (3, 4),
    };
    match status {
        TickStatus::Nominal => 0,
        TickStatus::SingularityDamped => 1,
        TickStatus::StepShortened => decelerate_for_collision,
        TickStatus::Halted => halt_for_collision,
        TickStatus::InvalidCommand | TickStatus::InvalidState | TickStatus::InvalidBeliefs => -1,
        TickStatus::Constrained => 10,
        TickStatus::InCollision => 11,
        TickStatus::Infeasible => 12,
        TickStatus::SolverFailed => 13,
        TickStatus::PolicyFailed => 14,
        // No wildcard: a new status must be given its code here.
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every status has its documented code; the holds that are not input
    /// errors get codes of their own, and Servo's collision codes follow
    /// the release asked for.
    #[test]
    fn statuses_map_to_the_documented_codes() {
        let table = [
            (TickStatus::Nominal, 0, 0),
            (TickStatus::SingularityDamped, 1, 1),
            (TickStatus::StepShortened, 4, 3),
            (TickStatus::Halted, 5, 4),
            (TickStatus::InvalidCommand, -1, -1),
            (TickStatus::InvalidState, -1, -1),
            (TickStatus::InvalidBeliefs, -1, -1),
            (TickStatus::Constrained, 10, 10),
            (TickStatus::InCollision, 11, 11),
            (TickStatus::Infeasible, 12, 12),
            (TickStatus::SolverFailed, 13, 13),
            (TickStatus::PolicyFailed, 14, 14),
        ];
        for (status, jazzy, humble) in table {
            assert_eq!(status_code(status, ServoCodes::Jazzy), jazzy, "{status:?}");
            assert_eq!(status_code(status, ServoCodes::Humble), humble, "{status:?}");
        }
    }
}
