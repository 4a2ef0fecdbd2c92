//! The policy experiment's rollouts: its tasks, the learned and the LQR
//! tracking policy followed alone, and shared control on either.

use crate::arbitration::{
    Arbiter, ArbiterGoal, ArbiterSettings, ArbitrationMode, GoalObjects, GoalSettings, ModeSettings, problem_goals,
};
use crate::control::RobotPolicy;
use crate::files::csv;
use crate::learn::evaluate::{Rollout, RolloutOutcome, RolloutSettings, Task};
use crate::learn::{LearnError, LearnedPolicy, PolicyNetwork};
use crate::problem::ProblemFamily;
use crate::robot::KinematicsWorkspace;
use crate::sim::{Approach, Episode, EpisodeSettings, Outcome, Reason};
use rayon::prelude::*;
use std::fmt::Write;
use std::sync::Arc;

/// Tasks `0 … count − 1` of `family` for run seed `seed`, judged with `max_tilt`.
///
/// # Errors
/// A family sample that cannot be drawn or is not a grasp task.
pub fn sample_tasks(family: &ProblemFamily, seed: u64, count: usize, max_tilt: f64) -> Result<Vec<Task>, LearnError> {
    (0..count as u64).into_par_iter().map(|id| Task::new(family.sample(seed, id)?.problem, max_tilt)).collect()
}

/// The learned policy followed alone on each task, in parallel (results in
/// task order, the same whatever the thread count).
///
/// # Errors
/// A task the network does not fit (joints, goal), robot errors.
pub fn follow_learned(
    network: &Arc<PolicyNetwork>,
    tasks: &[Task],
    settings: &RolloutSettings,
) -> Result<Vec<Rollout>, LearnError> {
    tasks
        .par_iter()
        .map(|task| {
            let policy = LearnedPolicy::for_problem(network.clone(), &task.problem)?;
            task.rollout(&policy, &task.problem.start, settings)
        })
        .collect()
}

/// The LQR tracking policy of a reference optimized from each task's start
/// (planner seed `seed`) followed alone; a task whose reference cannot be
/// optimized ends [`RolloutOutcome::NoPolicy`].
///
/// # Errors
/// Robot errors.
pub fn follow_lqr(tasks: &[Task], seed: u64, settings: &RolloutSettings) -> Result<Vec<Rollout>, LearnError> {
    tasks
        .par_iter()
        .map(|task| {
            let options = GoalSettings { seed: Some(seed), objects: GoalObjects::Goal, ..GoalSettings::default() };
            match problem_goals(&task.problem, &options) {
                Ok(goals) => task.rollout(goals[0].policy.as_ref(), &task.problem.start, settings),
                Err(_) => Ok(Rollout {
                    outcome: RolloutOutcome::NoPolicy,
                    steps: 0,
                    clamped: 0,
                    path: vec![task.problem.start.clone()],
                    reason: None,
                    distance: f64::NAN,
                }),
            }
        })
        .collect()
}

/// Every rollout as a CSV row, task by task and policy by policy in the
/// order given: `task` (the family sample id), `policy`, `outcome`
/// ([`RolloutOutcome::as_str`]), `reason` ([`Reason::as_str`](Reason::as_str);
/// empty without a policy), `phase` (a collision's, see
/// [`Rollout::collision_phase`]), `link` and `body` (a collision's pair),
/// `steps`, `clamped` (steps clamped to the joint limits) and `distance_m`
/// (the gripper's distance from the grasp point at the end, m; empty
/// without a policy).
pub fn rollouts_csv(followed: &[(&str, &[Rollout])]) -> String {
    let mut out = String::from("task,policy,outcome,reason,phase,link,body,steps,clamped,distance_m\n");
    let tasks = followed.iter().map(|(_, r)| r.len()).max().unwrap_or(0);
    for task in 0..tasks {
        for (policy, rollouts) in followed {
            let Some(r) = rollouts.get(task) else { continue };
            let reason = r.reason.as_ref().map_or("", Reason::as_str);
            let [link, body] = match &r.reason {
                Some(Reason::Collision { pair: [a, b] }) => [csv::field(a).into_owned(), csv::field(b).into_owned()],
                _ => [String::new(), String::new()],
            };
            let distance = if r.distance.is_finite() { format!("{:.6}", r.distance) } else { String::new() };
            let _ = writeln!(
                out,
                "{task},{policy},{},{reason},{},{link},{body},{},{},{distance}",
                r.outcome.as_str(),
                r.collision_phase().unwrap_or(""),
                r.steps,
                r.clamped
            );
        }
    }
    out
}

/// Which robot policy the arbiter blends with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GoalPolicy {
    /// The learned network conditioned on the task's goal.
    Learned,
    /// The LQR tracking policy of a reference optimized from the start.
    Lqr,
}

impl GoalPolicy {
    /// `learned` or `lqr`.
    pub fn as_str(&self) -> &'static str {
        match self {
            GoalPolicy::Learned => "learned",
            GoalPolicy::Lqr => "lqr",
        }
    }
}

/// An arbiter on `task` whose one goal, the grasp, is steered by
/// `network` (the learned policy of the task's goal and obstacles).
///
/// # Errors
/// A task the network does not fit (joints, goal), arbiter settings the
/// task's model refuses.
pub fn learned_arbiter(
    network: &Arc<PolicyNetwork>,
    task: &Task,
    settings: ArbiterSettings,
) -> Result<Arbiter, LearnError> {
    let problem = &task.problem;
    let policy: Arc<dyn RobotPolicy> = Arc::new(LearnedPolicy::for_problem(network.clone(), problem)?);
    let position = problem.grasp_target().map(|p| p.translation.vector.into()).unwrap_or([0.0; 3]);
    let goal = ArbiterGoal { name: task.object().to_string(), position, policy };
    Arbiter::new(task.collision_model().clone(), task.gripper_name(), vec![goal], settings)
        .map_err(|e| LearnError::Training(format!("arbiter: {e}")))
}

/// Outcomes of shared-control episodes: the [`Approach`] operator (to a
/// point above the grasp, then down) through an arbiter in `mode` (its
/// other settings from `modes`: the centres κ) whose goal policy is
/// `which`, on each task, in parallel. Success is the task's grasp judge
/// (as when a policy is followed alone), checked after every step; a task
/// whose LQR reference cannot be optimized counts as `Timeout`.
///
/// # Errors
/// Arbiter or robot errors.
pub fn shared_control(
    network: &Arc<PolicyNetwork>,
    tasks: &[Task],
    mode: ArbitrationMode,
    modes: &ModeSettings,
    which: GoalPolicy,
    seed: u64,
) -> Result<Vec<Outcome>, LearnError> {
    let episode = EpisodeSettings { record: false, ..EpisodeSettings::default() };
    let judge_radius = RolloutSettings::default().judge_radius;
    let arbitration = |e: crate::arbitration::ArbitrationError| LearnError::Training(format!("arbiter: {e}"));
    tasks
        .par_iter()
        .map(|task| {
            let problem = &task.problem;
            let settings = ArbiterSettings { mode, modes: *modes, ..ArbiterSettings::default() };
            let arbiter = match which {
                GoalPolicy::Learned => learned_arbiter(network, task, settings)?,
                GoalPolicy::Lqr => {
                    let options =
                        GoalSettings { seed: Some(seed), objects: GoalObjects::Goal, ..GoalSettings::default() };
                    let Ok(goals) = problem_goals(problem, &options) else { return Ok(Outcome::Timeout) };
                    Arbiter::for_problem(problem, &goals, settings).map_err(arbitration)?
                }
            };
            let Some(goal) = problem.grasp_target() else { return Ok(Outcome::Timeout) };
            let mut ws = arbiter.workspace();
            let mut kin = KinematicsWorkspace::new(&problem.robot);
            let run = Episode {
                arbiter: &arbiter,
                start: &problem.start,
                target: goal.translation.vector.into(),
                true_goal: 0,
                settings: episode,
            };
            // A judge error (a bad configuration) is not a grasp.
            let mut judge = |q: &[f64]| task.grasped(&mut kin, q, judge_radius).unwrap_or(false);
            let record = run.run(&mut ws, &mut Approach::default(), &mut judge)?;
            Ok(record.outcome)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rollouts_csv_quotes_names_and_leaves_missing_values_empty() {
        let hit = Rollout {
            outcome: RolloutOutcome::Collision,
            steps: 12,
            clamped: 1,
            path: vec![],
            reason: Some(Reason::Collision { pair: ["panda_link5".into(), "shelf, \"top\"".into()] }),
            distance: 0.25,
        };
        let none = Rollout {
            outcome: RolloutOutcome::NoPolicy,
            steps: 0,
            clamped: 0,
            path: vec![],
            reason: None,
            distance: f64::NAN,
        };
        let csv = rollouts_csv(&[("learned", &[hit][..]), ("lqr", &[none][..])]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3, "{csv}");
        assert_eq!(lines[1], "0,learned,collision,collision,approach,panda_link5,\"shelf, \"\"top\"\"\",12,1,0.250000");
        assert_eq!(lines[2], "0,lqr,no_policy,,,,,0,0,");
        let read = csv::records(&csv).unwrap();
        assert_eq!(read[1].fields[6], "shelf, \"top\"");
        assert!(read.iter().all(|r| r.fields.len() == 10));
    }
}
