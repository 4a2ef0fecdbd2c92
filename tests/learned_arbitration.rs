//! Learned arbitration (the dissertation's chapter 6): the arbitration state,
//! the observe / act split against the tick, `ArbitrationMode::Learned` inside
//! the arbiter (same command as direct control for a policy that copies the
//! user, allocation-free, typed errors), the actor file format, the
//! environment and Algorithm 5's reward, and DDPG (deterministic per seed)
//! feeding the Table 6.1 experiment.

mod common;

#[global_allocator]
static GLOBAL: common::alloc::CountingAllocator = common::alloc::CountingAllocator;

use common::alloc::allocations;
use std::path::Path;
use std::sync::Arc;
use tandem::arbitration::decision::DecisionSettings;
use tandem::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationError, ArbitrationMode, ArbitrationPolicy, HumanCommand, StateLayout,
    TickInput, TickStatus,
};
use tandem::experiments::learned::{LearnedExperimentSettings, LearnedMethod, run_learned_experiment};
use tandem::learn::{
    ARBITRATION_FORMAT, ARBITRATION_FORMAT_VERSION, ArbitrationActor, ArbitrationMeta, DdpgSettings, LearnError,
    train_arbitration,
};
use tandem::problem::Problem;
use tandem::sim::{
    ArbitrationEnv, ArbitrationEnvSettings, EnvOutcome, PlanarUser, RewardKind, reward, sample_planar_task,
};

/// A policy that returns the user's command: the learned mode must then
/// act exactly as direct control.
#[derive(Debug)]
struct CopyUser(StateLayout);

impl ArbitrationPolicy for CopyUser {
    fn layout(&self) -> StateLayout {
        self.0
    }
    fn scratch_len(&self) -> usize {
        0
    }
    fn act(&self, state: &[f64], _: &mut [f32], command: &mut [f64]) {
        let h = self.0.human_offset();
        command.copy_from_slice(&state[h..h + self.0.task_dims]);
    }
}

fn planar_arbiter() -> (Arbiter, Vec<f64>, [f64; 3]) {
    let base = Problem::builtin("planar_pick").unwrap();
    let task = sample_planar_task(&base, 3, 0).unwrap();
    let settings = ArbiterSettings { period: 1.0 / 30.0, ..ArbiterSettings::default() };
    let arbiter = Arbiter::for_problem(&task.reach[0].problem, &task.reach, settings).unwrap();
    let goal = task.reach[task.target].position;
    (arbiter, task.reach[0].problem.start.clone(), goal)
}

#[test]
fn the_learned_mode_with_a_copying_policy_acts_as_direct_control() {
    let (arbiter, start, goal) = planar_arbiter();
    // Planar layouts carry x and y only: command in the plane.
    let toward = [goal[0] - start[0], goal[1] - start[1], 0.0];
    let n = toward[0].hypot(toward[1]);
    let v = [0.05 * toward[0] / n, 0.05 * toward[1] / n, 0.0];
    let policy = Arc::new(CopyUser(StateLayout::planar(2)));
    let learned = arbiter
        .with_arbitration_policy(policy)
        .unwrap()
        .with_settings(ArbiterSettings { mode: ArbitrationMode::Learned, ..*arbiter.settings() })
        .unwrap();
    let (mut a, mut b) = (arbiter.workspace(), learned.workspace());
    let mut q = start.clone();
    for _ in 0..60 {
        let input = TickInput::new(&q, HumanCommand::Linear(&v));
        let direct = arbiter.tick(&mut a, &input);
        let (dq, ds) = (direct.qdot.to_vec(), direct.status);
        let mine = learned.tick(&mut b, &input);
        assert_eq!(mine.status, ds);
        for (x, y) in mine.qdot.iter().zip(&dq) {
            assert!((x - y).abs() <= 1e-12, "learned {x} vs direct {y}");
        }
        for (qi, d) in q.iter_mut().zip(&dq) {
            *qi += d / 30.0;
        }
    }
}

#[test]
fn observe_then_act_matches_the_tick() {
    let (arbiter, start, _) = planar_arbiter();
    let layout = StateLayout::planar(2);
    let v = [0.0, 0.05, 0.0];
    let mut ws = arbiter.workspace();
    let input = TickInput::new(&start, HumanCommand::Linear(&v));
    let state = arbiter.observe(&mut ws, &input, &layout).unwrap().to_vec();
    assert_eq!(state.len(), 17);
    // The user's command, in units of the speed scale, comes last.
    assert!((state[15] - 0.0).abs() < 1e-12 && (state[16] - 1.0).abs() < 1e-12);
    // Beliefs sum to 1; the gripper position is the start's x, y over 0.1 m.
    assert!((state[layout.belief_offset()] + state[layout.belief_offset() + 1] - 1.0).abs() < 1e-9);
    assert!((state[0] - start[0] / 0.1).abs() < 1e-9);
    let acted = arbiter.act_observed(&mut ws, &input, &[0.0, 0.05]).qdot.to_vec();
    let mut fresh = arbiter.workspace();
    let ticked = arbiter.tick(&mut fresh, &input).qdot.to_vec();
    for (x, y) in acted.iter().zip(&ticked) {
        assert!((x - y).abs() <= 1e-12);
    }
    // Acting twice on one observation holds.
    let again = arbiter.act_observed(&mut ws, &input, &[0.0, 0.05]);
    assert_eq!(again.status, TickStatus::InvalidState);
    assert!(again.qdot.iter().all(|x| *x == 0.0));
    // A wrong layout is refused, a NaN command holds.
    assert!(arbiter.observe(&mut ws, &input, &StateLayout::planar(3)).is_err());
    arbiter.observe(&mut ws, &input, &layout).unwrap();
    let bad = arbiter.act_observed(&mut ws, &input, &[f64::NAN, 0.0]);
    assert_eq!(bad.status, TickStatus::InvalidCommand);
}

#[test]
fn the_learned_mode_needs_a_fitting_policy() {
    let (arbiter, _, _) = planar_arbiter();
    let learned = ArbiterSettings { mode: ArbitrationMode::Learned, ..*arbiter.settings() };
    assert!(matches!(arbiter.with_settings(learned), Err(ArbitrationError::NoArbitrationPolicy)));
    let three_goals = Arc::new(CopyUser(StateLayout::planar(3)));
    let err = arbiter.with_arbitration_policy(three_goals).unwrap_err();
    assert!(err.to_string().contains("3 goals"), "{err}");
    assert_eq!("learned".parse::<ArbitrationMode>().unwrap(), ArbitrationMode::Learned);
    assert!(!ArbitrationMode::ALL.contains(&ArbitrationMode::Learned));
}

fn small_actor(seed: u64) -> ArbitrationActor {
    let meta = ArbitrationMeta {
        format: ARBITRATION_FORMAT.into(),
        version: ARBITRATION_FORMAT_VERSION,
        layout: StateLayout::planar(2),
        head: vec![8, 2],
        tail: vec![4],
        max_command: 2.0,
        reward: "combined".into(),
        seed,
        episodes: 0,
    };
    let (head, tail) = meta.layer_shapes();
    let mut x = seed as f32 + 0.5;
    let mut next = || {
        x = (x * 1.618_034 + 0.31).fract();
        x - 0.5
    };
    let layers: Vec<(Vec<f32>, Vec<f32>)> =
        head.iter().chain(&tail).map(|(i, o)| ((0..i * o).map(|_| next()).collect(), vec![0.01; *o])).collect();
    ArbitrationActor::from_parts(meta, &layers).unwrap()
}

#[test]
fn actor_files_round_trip_and_bad_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("actor.safetensors");
    let actor = small_actor(1);
    actor.save(&path).unwrap();
    let loaded = ArbitrationActor::load(&path).unwrap();
    assert_eq!(loaded, actor);
    assert_eq!(loaded.to_bytes().unwrap(), std::fs::read(&path).unwrap());
    let garbage = dir.path().join("garbage.safetensors");
    std::fs::write(&garbage, b"not a tensor file").unwrap();
    assert!(matches!(ArbitrationActor::load(&garbage), Err(LearnError::NotSafetensors { .. })));
    let missing = ArbitrationActor::load(Path::new("/nonexistent/actor.safetensors")).unwrap_err();
    assert!(missing.to_string().contains("/nonexistent/actor.safetensors"));
    let bytes = std::fs::read(&path).unwrap();
    let truncated = dir.path().join("truncated.safetensors");
    std::fs::write(&truncated, &bytes[..bytes.len() - 40]).unwrap();
    assert!(ArbitrationActor::load(&truncated).is_err());
}

#[test]
fn learned_ticks_allocate_nothing_and_stay_within_limits() {
    let (arbiter, start, _) = planar_arbiter();
    let learned = arbiter
        .with_arbitration_policy(Arc::new(small_actor(2)))
        .unwrap()
        .with_settings(ArbiterSettings { mode: ArbitrationMode::Learned, ..*arbiter.settings() })
        .unwrap();
    let mut ws = learned.workspace();
    let v = [0.03, 0.04, 0.0];
    let mut q = start.clone();
    let mut qdot = vec![0.0; q.len()];
    let before = allocations();
    for _ in 0..200 {
        let command = learned.tick(&mut ws, &TickInput::new(&q, HumanCommand::Linear(&v)));
        assert!(command.status != TickStatus::PolicyFailed);
        qdot.copy_from_slice(command.qdot);
        for (x, d) in q.iter_mut().zip(&qdot) {
            *x += d / 30.0;
        }
    }
    assert_eq!(allocations() - before, 0, "learned ticks allocate");
    let model = learned.collision_model();
    let mut cws = tandem::collision::CollisionWorkspace::new(model);
    assert!(model.collision_free(&mut cws, &q).unwrap());
    for (l, x) in learned.robot().limits().iter().zip(&q) {
        assert!(*x >= l.lower - 1e-9 && *x <= l.upper + 1e-9);
    }
}

#[test]
fn the_environment_is_seeded_and_scores_algorithm_5() {
    let settings = ArbitrationEnvSettings { users: vec![PlanarUser::Straight], ..ArbitrationEnvSettings::default() };
    let mut env = ArbitrationEnv::new(settings.clone()).unwrap();
    let first = env.reset(11).unwrap().to_vec();
    let mut again = ArbitrationEnv::new(settings).unwrap();
    assert_eq!(again.reset(11).unwrap(), &first[..]);
    let layout = env.layout();
    // Following the user straight: the episode ends (success or a stop at
    // the margin of the pole) with no collision under the hard constraints.
    let mut state = first.clone();
    let mut outcome = EnvOutcome::Running;
    for _ in 0..2000 {
        let h = layout.human_offset();
        let action = [state[h], state[h + 1]];
        let step = env.step(&action).unwrap();
        outcome = step.outcome;
        state.copy_from_slice(step.state);
        if step.done() {
            break;
        }
    }
    assert_ne!(outcome, EnvOutcome::Collision);
    assert_ne!(outcome, EnvOutcome::Running);
    // Algorithm 5 on hand-made states: sub-policies pointing apart with
    // equal beliefs (a decision point) reward following the user; one
    // dominant belief rewards following the true goal's sub-policy.
    let decision = DecisionSettings::default();
    let mut s = vec![0.0; layout.width()];
    let (a0, a1, b, h) =
        (layout.action_offset(0), layout.action_offset(1), layout.belief_offset(), layout.human_offset());
    s[a0] = -1.0;
    s[a1 + 1] = 1.0;
    s[a1] = 0.0;
    s[a0 + 1] = 0.0;
    s[h] = 1.0;
    s[b] = 0.5;
    s[b + 1] = 0.5;
    let follow_user = reward(&layout, &s, &[1.0, 0.0], 1, 0.0, RewardKind::Combined, &decision);
    let follow_robot = reward(&layout, &s, &[0.0, 1.0], 1, 0.0, RewardKind::Combined, &decision);
    assert!(follow_user > follow_robot, "at a decision point the user leads: {follow_user} vs {follow_robot}");
    s[b] = 0.01;
    s[b + 1] = 0.99;
    let follow_user = reward(&layout, &s, &[1.0, 0.0], 1, 0.0, RewardKind::Combined, &decision);
    let follow_robot = reward(&layout, &s, &[0.0, 1.0], 1, 0.0, RewardKind::Combined, &decision);
    assert!(follow_robot > follow_user, "with one goal certain the robot leads: {follow_robot} vs {follow_user}");
    assert_eq!(reward(&layout, &s, &[0.0, 1.0], 1, -2.0, RewardKind::Environment, &decision), -2.0);
    // Steps before a reset and bad actions are errors, not panics.
    let mut fresh = ArbitrationEnv::new(ArbitrationEnvSettings::default()).unwrap();
    assert!(fresh.step(&[0.0, 0.0]).is_err());
    fresh.reset(1).unwrap();
    assert!(fresh.step(&[f64::NAN, 0.0]).is_err());
    assert!(fresh.step(&[0.0]).is_err());
}

#[test]
fn ddpg_is_deterministic_per_seed_and_feeds_the_table() {
    let settings = |seed| DdpgSettings {
        episodes: 3,
        warmup_episodes: 1,
        batch: 16,
        seed,
        env: ArbitrationEnvSettings { max_time: 4.0, ..ArbitrationEnvSettings::default() },
        ..DdpgSettings::default()
    };
    let mut seen = 0;
    let a = train_arbitration(&settings(4), &mut |_| seen += 1).unwrap();
    assert_eq!(seen, 3);
    let b = train_arbitration(&settings(4), &mut |_| {}).unwrap();
    assert_eq!(a.actor.to_bytes().unwrap(), b.actor.to_bytes().unwrap());
    assert_eq!(a.episodes, b.episodes);
    let c = train_arbitration(&settings(5), &mut |_| {}).unwrap();
    assert_ne!(a.actor.to_bytes().unwrap(), c.actor.to_bytes().unwrap());
    assert_eq!(a.actor.meta().layout.width(), 17);
    // The trained actor runs in the table's episodes under the hard constraints.
    let methods = vec![
        LearnedMethod { name: "combined".into(), actor: Some(Arc::new(a.actor)) },
        LearnedMethod { name: "direct".into(), actor: None },
    ];
    let experiment = LearnedExperimentSettings {
        episodes: 2,
        users: vec![PlanarUser::Straight, PlanarUser::Biased],
        max_time: 10.0,
        ..LearnedExperimentSettings::default()
    };
    let results = run_learned_experiment(&experiment, &methods, &|| {}).unwrap();
    assert_eq!(results.cells.len(), 4);
    for cell in &results.cells {
        assert_eq!(cell.episodes, 2);
        if cell.method == "combined" {
            assert_eq!(cell.collision, 0.0, "the learned arbiter runs under the hard constraints");
        }
    }
    assert_eq!(results.curves.len(), 2);
}

#[test]
fn the_cli_trains_an_arbiter_and_runs_table_6_1() {
    let dir = tempfile::tempdir().unwrap();
    let actor = dir.path().join("arbiter.safetensors");
    let tandem = env!("CARGO_BIN_EXE_tandem");
    let train = std::process::Command::new(tandem)
        .args(["learn", "arbitration", "--episodes", "2", "--seed", "3", "--json", "--out"])
        .arg(&actor)
        .output()
        .unwrap();
    assert!(train.status.success(), "{}", String::from_utf8_lossy(&train.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&train.stdout).unwrap();
    assert_eq!(summary["episodes"], 2);
    for extension in ["safetensors", "json", "svg"] {
        assert!(actor.with_extension(extension).is_file(), "{extension} missing");
    }
    let out = dir.path().join("results");
    let table = std::process::Command::new(tandem)
        .args(["experiment", "learned", "--episodes", "1", "--json", "--combined"])
        .arg(&actor)
        .arg("--environment")
        .arg(&actor)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(table.status.success(), "{}", String::from_utf8_lossy(&table.stderr));
    let json: serde_json::Value = serde_json::from_slice(&table.stdout).unwrap();
    let results = json["results"].as_array().unwrap();
    assert_eq!(results.len(), 4 * 3, "four users × combined, environment, direct");
    for key in ["user", "method", "success", "collision", "travel_cm"] {
        assert!(results[0].get(key).is_some(), "{key} missing");
    }
    for file in ["training_curves.svg", "authority.svg", "learned.json"] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    // A robot policy file is not an arbitration actor: a clear error, exit 1.
    let bad = std::process::Command::new(tandem)
        .args(["arbitrate", "builtin:planar_pick", "--mode", "learned", "--arbiter"])
        .arg(actor.with_extension("json"))
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("not a safetensors file"));
}

/// `tandem serve --mode learned --arbiter FILE` starts in the learned mode
/// (the session was built in that mode before the actor was attached, and
/// refused to start); an actor for another goal count says why.
#[test]
fn a_teleop_session_starts_in_the_learned_mode_with_its_actor() {
    use tandem::teleop::{SessionSettings, TeleopSession, TeleopTask};
    let settings = SessionSettings {
        mode: ArbitrationMode::Learned,
        actor: Some(Arc::new(small_actor(3))),
        record_dir: None,
        ..SessionSettings::default()
    };
    let session = TeleopSession::prepare(&settings, TeleopTask::Planar, 0).expect("starts in the learned mode");
    assert!(session.scene().modes.contains(&"learned"));
    let three = {
        let mut meta = small_actor(4).meta().clone();
        meta.layout = StateLayout::planar(3);
        let (head, tail) = meta.layer_shapes();
        let layers: Vec<(Vec<f32>, Vec<f32>)> =
            head.iter().chain(&tail).map(|(i, o)| (vec![0.01; i * o], vec![0.0; *o])).collect();
        ArbitrationActor::from_parts(meta, &layers).unwrap()
    };
    let settings = SessionSettings { actor: Some(Arc::new(three)), ..settings };
    let err = TeleopSession::prepare(&settings, TeleopTask::Planar, 0).err().expect("a 3-goal actor on 2 goals");
    assert!(err.to_string().contains("3 goals"), "{err}");
}

/// An actor trained on the planar task's x-y plane, with as many goals as
/// the Panda's task, is refused for the Panda (it ran to a timeout): when
/// the session starts in the learned mode, and when the page asks for it.
#[test]
fn a_planar_actor_is_refused_for_the_panda() {
    use tandem::teleop::{SessionSettings, TeleopSession, TeleopTask};
    let panda_goals = 1;
    let planar = {
        let mut meta = small_actor(5).meta().clone();
        meta.layout = StateLayout::planar(panda_goals);
        let (head, tail) = meta.layer_shapes();
        let layers: Vec<(Vec<f32>, Vec<f32>)> =
            head.iter().chain(&tail).map(|(i, o)| (vec![0.01; i * o], vec![0.0; *o])).collect();
        ArbitrationActor::from_parts(meta, &layers).unwrap()
    };
    let settings = SessionSettings {
        mode: ArbitrationMode::Learned,
        actor: Some(Arc::new(planar)),
        record_dir: None,
        ..SessionSettings::default()
    };
    let err = TeleopSession::prepare(&settings, TeleopTask::ReachGrasp, 0).err().expect("a planar actor on the Panda");
    assert!(err.to_string().contains("in 2 task dimensions") && err.to_string().contains("in 3"), "{err}");
    let settings = SessionSettings { mode: ArbitrationMode::SumOfSquares, ..settings };
    let mut session = TeleopSession::prepare(&settings, TeleopTask::ReachGrasp, 0).expect("other modes run");
    assert!(!session.scene().modes.contains(&"learned"));
    let err = session.set_mode("learned").unwrap_err();
    assert!(err.contains("task dimensions"), "{err}");
}
