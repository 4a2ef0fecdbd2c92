//! Closing the blind spots (beyond the dissertation, which could not cover the
//! joint-limit boundaries with trajectory data): DAgger-style rounds with
//! the optimizer as the expert. A round follows the learned policy on fresh
//! tasks; where it fails, states along its path become starts of new
//! problems (same goal and obstacles, the arm at rest there), and the
//! fresh tasks whose starts lie farthest from the data are solved too;
//! the expert's trajectories join the data and the network trains on.

use super::Demonstration;
use super::evaluate::{Rollout, RolloutOutcome};
use crate::data::{GenerateSettings, SampleOutcome, run_problem};
use crate::problem::{Problem, sample_seed};
use rayon::prelude::*;

/// How DAgger rounds run.
#[derive(Debug, Clone, PartialEq)]
pub struct DaggerSettings {
    /// Rounds after the first training (default 0: none).
    pub rounds: usize,
    /// Fresh tasks the learned policy is followed on per round (default 200).
    pub tasks_per_round: usize,
    /// States taken along each failed path as new starts (default 4).
    pub states_per_failure: usize,
    /// Fresh tasks farthest from the data solved from their starts (default 50).
    pub thin_per_round: usize,
    /// Epochs of training per round, continuing from the last network (default 10).
    pub epochs: usize,
}

impl Default for DaggerSettings {
    fn default() -> Self {
        DaggerSettings { rounds: 0, tasks_per_round: 200, states_per_failure: 4, thin_per_round: 50, epochs: 10 }
    }
}

/// Steps before a collision (at 15 Hz, 2 s) that [`failure_states`] restarts from.
pub const COLLISION_WINDOW: usize = 30;

/// States of a failed `rollout` to restart the expert from, evenly spaced:
/// along its whole path (the start included) for a timeout; for a
/// collision, over the [`COLLISION_WINDOW`] states before the colliding
/// one (which is not a valid start), where the policy went wrong. None
/// for a success.
pub fn failure_states(rollout: &Rollout, count: usize) -> Vec<Vec<f64>> {
    let (first, usable) = match rollout.outcome {
        RolloutOutcome::Success | RolloutOutcome::NoPolicy => return vec![],
        RolloutOutcome::Collision => {
            let end = rollout.path.len().saturating_sub(1);
            (end.saturating_sub(COLLISION_WINDOW), end)
        }
        RolloutOutcome::Timeout => (0, rollout.path.len()),
    };
    let span = usable - first;
    if span == 0 || count == 0 {
        return vec![];
    }
    // `count` states evenly spaced from the first to the last usable one.
    let mut picks: Vec<usize> =
        (0..count).map(|k| first + if count == 1 { 0 } else { k * (span - 1) / (count - 1) }).collect();
    picks.dedup();
    picks.into_iter().map(|i| rollout.path[i].clone()).collect()
}

/// The expert's demonstrations for `problems`: each solved as sample
/// `first_id + k` of the run `settings` (seeded from the run seed and the id),
/// in parallel; rejected ones are left out. Returns the demonstrations and
/// the number rejected.
pub fn expert_demonstrations(
    problems: &[Problem],
    first_id: u64,
    settings: &GenerateSettings,
) -> (Vec<Demonstration>, usize) {
    let outcomes: Vec<SampleOutcome> = problems
        .par_iter()
        .enumerate()
        .map(|(k, problem)| {
            let id = first_id + k as u64;
            run_problem(problem, sample_seed(settings.seed, id), id, settings).0
        })
        .collect();
    let total = outcomes.len();
    let demos: Vec<Demonstration> = outcomes
        .iter()
        .filter_map(|o| match o {
            SampleOutcome::Accepted(record) => Demonstration::from_record(record),
            SampleOutcome::Rejected(_) => None,
        })
        .collect();
    let rejected = total - demos.len();
    (demos, rejected)
}

/// `problem` restarted at `start` (at rest).
pub fn restart(problem: &Problem, start: &[f64]) -> Problem {
    let mut p = problem.clone();
    p.start = start.to_vec();
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rollout(outcome: RolloutOutcome, len: usize) -> Rollout {
        Rollout {
            outcome,
            steps: len.saturating_sub(1),
            clamped: 0,
            path: (0..len).map(|i| vec![i as f64]).collect(),
            reason: None,
            distance: f64::NAN,
        }
    }

    #[test]
    fn failure_states_spread_along_the_path() {
        let states = failure_states(&rollout(RolloutOutcome::Timeout, 10), 4);
        assert_eq!(states, vec![vec![0.0], vec![3.0], vec![6.0], vec![9.0]]);
        // The colliding configuration is never a start.
        let states = failure_states(&rollout(RolloutOutcome::Collision, 10), 4);
        assert_eq!(states.last(), Some(&vec![8.0]));
        // A collision late in a long path: the states of the last 2 s before it.
        let states = failure_states(&rollout(RolloutOutcome::Collision, 100), 4);
        assert_eq!(states, vec![vec![69.0], vec![78.0], vec![88.0], vec![98.0]]);
        assert!(failure_states(&rollout(RolloutOutcome::Success, 10), 4).is_empty());
        assert_eq!(failure_states(&rollout(RolloutOutcome::Timeout, 1), 4), vec![vec![0.0]]);
    }
}
