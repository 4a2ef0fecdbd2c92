//! The traded-control loop (§7.3.1 of the dissertation): the operator
//! demonstrates a reach for each of the three objects in an order of their
//! choosing; the intent predictor labels every tracker frame; the robot plans
//! and executes the grasp and retrieval of the predicted object.
//!
//! A prediction is *committed* when it has been the same for
//! [`TradedSettings::commit_steps`] consecutive frames, counting from frame
//! [`TradedSettings::discard_steps`] (the dissertation's 80 and 300; earlier
//! frames say little); a demonstration that never settles commits to its last
//! frame's prediction when it ends. The planning modes:
//!
//! * **Early**: plan the committed grasp at once (during the demonstration);
//!   execution starts when the plan is ready.
//! * **Late**: plan the committed grasp after the demonstration ends.
//! * **Continuous**: from the discard window on, (re)plan whenever the
//!   prediction changes and move as soon as a plan is ready; a change undoes
//!   the motion made so far (the robot backs along its path, as long as it
//!   moved), and changes after the robot has closed the gripper are ignored.
//!   The grasp is the prediction in force at the end.
//!
//! A pick cycle ends when both the demonstration and the retrieval are done;
//! the next demonstration starts then. Times are seconds from the start of
//! the demonstration.
//!
//! ```no_run
//! use tandem::experiments::traded::{IntentPredictor, PlanningMode, TradedScene, TradedSettings, run_traded_episode, HandUser};
//! use tandem::arbitration::IntentSettings;
//! let settings = TradedSettings { planning_latency: Some(0.05), ..TradedSettings::default() };
//! let scene = TradedScene::new(&settings.objects)?;
//! let predictor = IntentPredictor::Posterior(IntentSettings::default());
//! let e = run_traded_episode(&scene, &predictor, HandUser::Normal, &PlanningMode::ALL, &settings, 0)?;
//! println!("{:?}", e[0].episode_seconds);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::hand::{GraspDirection, HAND_RATE, HandUser, synthesize_reach};
use super::intent::IntentPredictor;
use super::robot::{PlannedGrasp, TradedError, TradedScene};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;

/// When the robot plans (§7.3.1 of the dissertation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum PlanningMode {
    /// Plan as soon as the prediction is committed.
    Early,
    /// Plan after the demonstration ends.
    Late,
    /// Re-plan whenever the prediction changes.
    Continuous,
}

impl PlanningMode {
    /// The three modes, in table order.
    pub const ALL: [PlanningMode; 3] = [PlanningMode::Early, PlanningMode::Late, PlanningMode::Continuous];

    /// Name as in the tables.
    pub fn as_str(self) -> &'static str {
        match self {
            PlanningMode::Early => "Early",
            PlanningMode::Late => "Late",
            PlanningMode::Continuous => "Continuous",
        }
    }
}

/// Settings of the traded-control loop.
#[derive(Debug, Clone, PartialEq)]
pub struct TradedSettings {
    /// Object centres on the table (world, m): three boxes.
    pub objects: Vec<[f64; 3]>,
    /// Consecutive equal predictions that commit a target (80 in the dissertation).
    pub commit_steps: usize,
    /// Frames at the start of a demonstration whose predictions are ignored
    /// (300 in the dissertation).
    pub discard_steps: usize,
    /// Planning time charged per plan (s): `None` charges the measured
    /// wall-clock time (then episode times vary slightly run to run);
    /// `Some` makes the timeline exactly reproducible.
    pub planning_latency: Option<f64>,
}

impl Default for TradedSettings {
    fn default() -> Self {
        TradedSettings {
            objects: vec![[0.5, -0.2, 0.06], [0.6, 0.0, 0.06], [0.5, 0.2, 0.06]],
            commit_steps: 80,
            discard_steps: 300,
            planning_latency: None,
        }
    }
}

/// One pick of one object.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PickRecord {
    /// The object the operator reached for.
    pub object: usize,
    /// How they grasped it.
    pub direction: GraspDirection,
    /// The object and direction the robot grasped.
    pub grasped: (usize, GraspDirection),
    /// Seconds from the demonstration's start to the robot's start.
    pub time_until_execution: f64,
    /// Seconds of the whole pick cycle.
    pub cycle_seconds: f64,
    /// Demonstration length (s).
    pub demonstration_seconds: f64,
    /// Plans made.
    pub plans: usize,
    /// Whether every plan found a path.
    pub solved: bool,
}

/// One episode (three picks) in one planning mode.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TradedEpisode {
    /// The planning mode.
    pub mode: PlanningMode,
    /// The picks, in the operator's order.
    pub picks: Vec<PickRecord>,
    /// Sum of the pick cycles (s).
    pub episode_seconds: f64,
    /// Measured wall-clock planning time of each plan made (s).
    pub planning_seconds: Vec<f64>,
}

/// The frame at which the prediction is committed and the prediction.
pub fn commit(predictions: &[(usize, GraspDirection)], settings: &TradedSettings) -> (usize, (usize, GraspDirection)) {
    let mut run = 0;
    for k in settings.discard_steps.min(predictions.len())..predictions.len() {
        run = if k > settings.discard_steps && predictions[k] == predictions[k - 1] { run + 1 } else { 1 };
        if run >= settings.commit_steps {
            return (k, predictions[k]);
        }
    }
    let last = predictions.len().saturating_sub(1);
    (last, predictions.get(last).copied().unwrap_or((0, GraspDirection::Top)))
}

/// Plans memoised per episode (same seed, same path); the measured time of
/// the first plan is charged every time.
struct Planner<'a> {
    scene: &'a TradedScene,
    cache: HashMap<(Vec<bool>, usize, GraspDirection), PlannedGrasp>,
    seed: u64,
    measured: Vec<f64>,
    latency: Option<f64>,
}

impl Planner<'_> {
    /// Plans; returns (charged seconds, execution seconds, solved).
    fn plan(&mut self, present: &[bool], target: (usize, GraspDirection)) -> Result<(f64, f64, bool), TradedError> {
        let key = (present.to_vec(), target.0, target.1);
        let planned = match self.cache.get(&key) {
            Some(p) => p.clone(),
            None => {
                let p = self.scene.plan(
                    present,
                    target.0,
                    target.1,
                    self.seed ^ (target.0 as u64 * 2 + target.1.index() as u64),
                )?;
                self.cache.insert(key, p.clone());
                p
            }
        };
        self.measured.push(planned.planning_seconds);
        let charged = self.latency.unwrap_or(planned.planning_seconds);
        // An unsolved plan: the robot waits for the operator to grasp, so the
        // pick costs a second plan's time and no motion.
        let execution = if planned.solved { planned.execution_seconds } else { 0.0 };
        Ok((charged, execution, planned.solved))
    }
}

/// Runs one episode of `user` with every mode in `modes` on the same
/// demonstrations (seeded by `seed`): operator order and directions drawn
/// uniformly.
///
/// # Errors
/// Planner setup or classifier errors; objects other than three.
pub fn run_traded_episode(
    scene: &TradedScene,
    predictor: &IntentPredictor,
    user: HandUser,
    modes: &[PlanningMode],
    settings: &TradedSettings,
    seed: u64,
) -> Result<Vec<TradedEpisode>, TradedError> {
    let n = settings.objects.len();
    if n == 0 || scene.objects() != settings.objects.as_slice() {
        return Err(TradedError::Placement("the scene's objects differ from the settings'".into()));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        order.swap(i, rng.random_range(0..=i));
    }
    let directions: Vec<GraspDirection> = (0..n).map(|_| GraspDirection::ALL[rng.random_range(0..2)]).collect();
    let demo_seeds: Vec<u64> = (0..n).map(|_| rng.random()).collect();
    let mut planner = Planner {
        scene,
        cache: HashMap::new(),
        seed: rng.random(),
        measured: vec![],
        latency: settings.planning_latency,
    };
    let mut episodes: Vec<TradedEpisode> = modes
        .iter()
        .map(|&mode| TradedEpisode { mode, picks: vec![], episode_seconds: 0.0, planning_seconds: vec![] })
        .collect();
    let mut present = vec![true; n];
    for (i, &object) in order.iter().enumerate() {
        let demo = synthesize_reach(&settings.objects, object, directions[i], user, demo_seeds[i]);
        let predictions = predictor.predict(&demo, &settings.objects, &present)?;
        let demo_end = demo.samples.len() as f64 / HAND_RATE;
        for episode in &mut episodes {
            planner.measured.clear();
            let pick = match episode.mode {
                PlanningMode::Early | PlanningMode::Late => {
                    let (k, target) = commit(&predictions, settings);
                    let t_commit = (k + 1) as f64 / HAND_RATE;
                    let (plan_s, exec_s, solved) = planner.plan(&present, target)?;
                    let begin = if episode.mode == PlanningMode::Early { t_commit } else { demo_end.max(t_commit) };
                    let start = begin + plan_s;
                    pick_record(object, directions[i], target, start, start + exec_s, demo_end, 1, solved)
                }
                PlanningMode::Continuous => {
                    continuous(&predictions, &present, &mut planner, settings, demo_end, (object, directions[i]))?
                }
            };
            episode.planning_seconds.extend_from_slice(&planner.measured);
            episode.episode_seconds += pick.cycle_seconds;
            episode.picks.push(pick);
        }
        present[object] = false;
    }
    Ok(episodes)
}

#[allow(clippy::too_many_arguments)]
fn pick_record(
    object: usize,
    direction: GraspDirection,
    grasped: (usize, GraspDirection),
    start: f64,
    done: f64,
    demo_end: f64,
    plans: usize,
    solved: bool,
) -> PickRecord {
    PickRecord {
        object,
        direction,
        grasped,
        time_until_execution: start,
        cycle_seconds: done.max(demo_end),
        demonstration_seconds: demo_end,
        plans,
        solved,
    }
}

/// The Continuous mode of one pick.
fn continuous(
    predictions: &[(usize, GraspDirection)],
    present: &[bool],
    planner: &mut Planner,
    settings: &TradedSettings,
    demo_end: f64,
    truth: (usize, GraspDirection),
) -> Result<PickRecord, TradedError> {
    let first = settings.discard_steps.min(predictions.len().saturating_sub(1));
    let mut target = predictions[first];
    let (mut plan_s, mut exec_s, mut solved) = planner.plan(present, target)?;
    let mut start = (first + 1) as f64 / HAND_RATE + plan_s;
    let mut plans = 1;
    for (k, &prediction) in predictions.iter().enumerate().skip(first + 1) {
        let now = (k + 1) as f64 / HAND_RATE;
        // Grasped once half the execution (there) is done.
        if now >= start + exec_s / 2.0 {
            break;
        }
        if prediction != target {
            let moved = (now - start).max(0.0);
            target = prediction;
            let ok;
            (plan_s, exec_s, ok) = planner.plan(present, target)?;
            solved &= ok;
            plans += 1;
            start = now + moved.max(plan_s);
        }
    }
    Ok(pick_record(truth.0, truth.1, target, start, start + exec_s, demo_end, plans, solved))
}
