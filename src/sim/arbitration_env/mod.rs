//! The arbitration-learning environment of the dissertation's §6.5, one step per
//! control tick. [`EnvTask::Planar`]: the planar gripper behind a pole, two
//! goal cylinders near the far edge (the tasks of [`sample_planar_task`],
//! phase 1), a simulated user ([`PlanarUser`]) heading for one of them.
//! [`EnvTask::PandaGrasp`]: the Panda reach-and-grasp task of Table 5.1
//! ([`sample_task`], right arm), a simulated operator ([`OperatorKind`])
//! heading for the box's grasp. The agent sees the arbitration state
//! ([`StateLayout`]: gripper, goals, distance to the nearest obstacle,
//! every sub-policy's action and belief, the user's command) and chooses
//! the arbitrated gripper velocity (x–y on the plane, 3-D for the Panda),
//! which the [`Arbiter`] executes under the hard constraints (joint limits
//! and velocities, and collisions unless
//! [`ArbitrationEnvSettings::hard_collisions`] is off).
//!
//! Rewards follow Algorithm 5: [`reward()`] adds the agreement term (toward
//! the user at decision points, where the sub-policies' von Mises mixture
//! is multimodal; toward the true goal's sub-policy elsewhere; minus the
//! speed difference) to the environment term of [`StepResult::env_reward`]
//! (−10 on touching an obstacle, which ends the episode; −2 at the
//! workspace border; +10 on reaching the user's cylinder).
//!
//! ```no_run
//! use tandem::sim::{ArbitrationEnv, ArbitrationEnvSettings, RewardKind, reward};
//! let mut env = ArbitrationEnv::new(ArbitrationEnvSettings::default())?;
//! let (layout, decision) = (env.layout(), env.settings().decision);
//! let mut state = env.reset(7)?.to_vec();
//! loop {
//!     let h = layout.human_offset();
//!     let action = [state[h], state[h + 1]]; // follow the user
//!     let goal = env.true_goal();
//!     let step = env.step(&action)?;
//!     let (r_env, done) = (step.env_reward, step.done());
//!     let next = step.state.to_vec();
//!     let r = reward(&layout, &state, &action, goal, r_env, RewardKind::Combined, &decision);
//!     println!("reward {r:.2}");
//!     state = next;
//!     if done { break; }
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod reward;

pub use reward::{RewardKind, reward};

use super::PhysicsSettings;
use super::judge::TaskJudge;
use super::operator::{Observation, Operator, OperatorAction};
use super::operator::{OperatorKind, PlanarUser};
use super::tasks::{Arm, sample_planar_task, sample_task};
use crate::arbitration::decision::DecisionSettings;
use crate::arbitration::{
    Arbiter, ArbiterSettings, ArbiterWorkspace, ArbitrationError, HumanCommand, ProblemGoal, StateLayout, TickInput,
};
use crate::control::{RobotPolicy, RobotPolicyWorkspace};
use crate::problem::Problem;
use crate::robot::{KinematicsWorkspace, ReferenceFrame};
use nalgebra::Matrix6xX;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The task of the environment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum EnvTask {
    /// The planar reach of §6.5 (two goals, x–y actions).
    #[default]
    Planar,
    /// The Panda reach-and-grasp of Table 5.1 (one goal, 3-D actions).
    PandaGrasp,
}

/// Settings of the environment.
#[derive(Debug, Clone, PartialEq)]
pub struct ArbitrationEnvSettings {
    /// The task.
    pub task: EnvTask,
    /// The planar task's users an episode draws from (uniformly, by the reset seed).
    pub users: Vec<PlanarUser>,
    /// The Panda task's operators an episode draws from.
    pub operators: Vec<OperatorKind>,
    /// User speed (m/s; default 0.05 — set 0.1 for the Panda, as Table 5.1).
    pub speed: f64,
    /// Episode timeout (s; default 20: the reach takes about 8 s at the
    /// user speed).
    pub max_time: f64,
    /// Largest action component, in units of the user speed (default 2).
    pub max_action: f64,
    /// Collision rows among the hard constraints (default true: the same
    /// constraints as the deployed [`ArbitrationMode::Learned`](crate::arbitration::ArbitrationMode::Learned)).
    pub hard_collisions: bool,
    /// Environment reward for touching an obstacle (default −10; ends the episode).
    pub obstacle_reward: f64,
    /// Environment reward per step at the workspace border (default −2).
    pub border_reward: f64,
    /// Environment reward for reaching the user's cylinder (default +10).
    pub goal_reward: f64,
    /// Distance from a joint limit that counts as the border (m or rad;
    /// default 0.002; the planar task's x and y limits are the table's edges).
    pub border_band: f64,
    /// The decision-point test of the agreement reward.
    pub decision: DecisionSettings,
    /// The arbiter's settings (its mode is ignored: actions are executed as given).
    pub arbiter: ArbiterSettings,
    /// MuJoCo moves the arm (the Panda task, a build with the `mujoco`
    /// feature; default `None`: the kinematic simulator). Touching an
    /// obstacle or pushing the box 2 cm is a collision; the goal counts
    /// once the judge agrees with the gripper within 1 cm of the grasp
    /// point *and* the fingers close, lift the box 10 cm and hold it 1 s
    /// (else the episode fails). See [`PhysicsSettings`].
    pub physics: Option<PhysicsSettings>,
}

impl Default for ArbitrationEnvSettings {
    fn default() -> Self {
        ArbitrationEnvSettings {
            task: EnvTask::Planar,
            users: PlanarUser::ALL.to_vec(),
            operators: OperatorKind::TABLE_5_1.to_vec(),
            speed: 0.05,
            max_time: 20.0,
            max_action: 2.0,
            hard_collisions: true,
            obstacle_reward: -10.0,
            border_reward: -2.0,
            goal_reward: 10.0,
            border_band: 0.002,
            decision: DecisionSettings::default(),
            arbiter: ArbiterSettings { period: 1.0 / 30.0, ..ArbiterSettings::default() },
            physics: None,
        }
    }
}

/// How an episode stands after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EnvOutcome {
    /// Still going.
    Running,
    /// The gripper reached the user's goal.
    Success,
    /// The gripper touched an obstacle.
    Collision,
    /// The user stopped, believing it had arrived, where the task is not done.
    Failed,
    /// Time ran out.
    Timeout,
}

impl EnvOutcome {
    /// `running`, `success`, `collision`, `failed` or `timeout`.
    pub fn as_str(&self) -> &'static str {
        match self {
            EnvOutcome::Running => "running",
            EnvOutcome::Success => "success",
            EnvOutcome::Collision => "collision",
            EnvOutcome::Failed => "failed",
            EnvOutcome::Timeout => "timeout",
        }
    }
}

/// What a step returns.
#[derive(Debug)]
pub struct StepResult<'a> {
    /// The next state (the last one when the episode ended).
    pub state: &'a [f64],
    /// The environment reward `r_env` of this step.
    pub env_reward: f64,
    /// How the episode stands.
    pub outcome: EnvOutcome,
    /// The executed gripper velocity (m/s, world).
    pub executed: [f64; 3],
}

impl StepResult<'_> {
    /// Whether the episode ended.
    pub fn done(&self) -> bool {
        self.outcome != EnvOutcome::Running
    }
}

/// The running episode.
struct Running {
    goals: Vec<ProblemGoal>,
    target: usize,
    user: String,
    arbiter: Arbiter,
    ws: ArbiterWorkspace,
    operator: Box<dyn Operator>,
    judge: TaskJudge,
    q: Vec<f64>,
    velocity: Vec<f64>,
    human: [f64; 3],
    policy_state: RobotPolicyWorkspace,
    policy_action: Vec<f64>,
    kin: KinematicsWorkspace,
    jac: Matrix6xX<f64>,
    linear: Vec<f64>,
    gripper: [f64; 3],
    steps: usize,
    travel: f64,
    /// MuJoCo's world, when physics moves the arm.
    #[cfg(feature = "mujoco")]
    physics: Option<Box<crate::sim::mujoco::EnvPhysics>>,
}

/// The arbitration-learning environment (see the module docs).
pub struct ArbitrationEnv {
    settings: ArbitrationEnvSettings,
    base: Problem,
    layout: StateLayout,
    state: Vec<f64>,
    running: Option<Running>,
}

/// Errors of the arbitration environment.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EnvError {
    /// Settings with no user or no operator.
    #[error("the arbitration environment needs at least one user")]
    NoUsers,
    /// [`ArbitrationEnv::step`] before the first [`ArbitrationEnv::reset`].
    #[error("step before reset")]
    NotReset,
    /// An action of the wrong size or with a non-finite value.
    #[error("an action is {dims} finite values, got {action:?}")]
    Action {
        /// The task's dimensions.
        dims: usize,
        /// The action given.
        action: Vec<f64>,
    },
    /// A setting out of range, a task or an arbiter that cannot be set up.
    #[error(transparent)]
    Arbitration(#[from] ArbitrationError),
    /// Physics asked of the planar task or of a build without MuJoCo, or
    /// MuJoCo refusing the scene.
    #[error("physics: {0}")]
    Physics(String),
}

impl ArbitrationEnv {
    /// An environment on `settings.task`.
    ///
    /// # Errors
    /// Invalid settings, no users.
    pub fn new(settings: ArbitrationEnvSettings) -> Result<ArbitrationEnv, EnvError> {
        if settings.users.is_empty() || settings.operators.is_empty() {
            return Err(EnvError::NoUsers);
        }
        let units = [
            ("speed", settings.speed, "m/s"),
            ("max_time", settings.max_time, "s"),
            ("max_action", settings.max_action, ""),
        ];
        for (field, value, unit) in units {
            crate::settings::positive(field, value, unit).map_err(ArbitrationError::from)?;
        }
        let (name, layout) = match settings.task {
            EnvTask::Planar => ("planar_pick", StateLayout { speed_scale: settings.speed, ..StateLayout::planar(2) }),
            EnvTask::PandaGrasp => (
                "panda_grasp_box",
                StateLayout { task_dims: 3, goals: 1, length_scale: 0.1, speed_scale: settings.speed },
            ),
        };
        if settings.physics.is_some() && settings.task != EnvTask::PandaGrasp {
            return Err(EnvError::Physics("physics runs the Panda task only".into()));
        }
        if settings.physics.is_some() && !cfg!(feature = "mujoco") {
            return Err(EnvError::Physics(
                "this tandem was built without MuJoCo: build with the `mujoco` feature (see docs/physics.md)".into(),
            ));
        }
        let base = Problem::builtin(name).map_err(ArbitrationError::from)?;
        Ok(ArbitrationEnv { base, layout, state: vec![0.0; layout.width()], running: None, settings })
    }

    /// The settings.
    pub fn settings(&self) -> &ArbitrationEnvSettings {
        &self.settings
    }

    /// The state layout (17 values on the planar task, 14 on the Panda's;
    /// actions are `task_dims` values in units of the user speed).
    pub fn layout(&self) -> StateLayout {
        self.layout
    }

    /// The true goal (the user's) of the running episode.
    pub fn true_goal(&self) -> usize {
        self.running.as_ref().map_or(0, |r| r.target)
    }

    /// The running episode's user (`straight`, `noisy-0.5`, …).
    pub fn user(&self) -> Option<&str> {
        self.running.as_ref().map(|r| r.user.as_str())
    }

    /// Gripper path length so far (m).
    pub fn travel(&self) -> f64 {
        self.running.as_ref().map_or(0.0, |r| r.travel)
    }

    /// Steps taken in the running episode.
    pub fn steps(&self) -> usize {
        self.running.as_ref().map_or(0, |r| r.steps)
    }

    /// The gripper position (m, world).
    pub fn gripper(&self) -> [f64; 3] {
        self.running.as_ref().map_or([0.0; 3], |r| r.gripper)
    }

    /// Starts episode `seed`: its task and user are drawn from the seed
    /// alone. Returns the first state.
    ///
    /// # Errors
    /// A task that cannot be set up.
    pub fn reset(&mut self, seed: u64) -> Result<&[f64], EnvError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_A4B1);
        let (goals, target, user, operator) = self.sample(&mut rng)?;
        let mut arbiter_settings = self.settings.arbiter;
        arbiter_settings.mode = crate::arbitration::ArbitrationMode::DirectControl;
        arbiter_settings.safety.collisions = self.settings.hard_collisions;
        let arbiter = Arbiter::for_problem(&goals[0].problem, &goals, arbiter_settings)?;
        let goal = &goals[target];
        let robot = arbiter.robot().clone();
        let n = robot.nq();
        let policy = goal.policy.clone();
        let mut running = Running {
            user,
            ws: arbiter.workspace(),
            operator,
            judge: TaskJudge::new(goal),
            q: goal.problem.start.clone(),
            velocity: vec![0.0; n],
            human: [0.0; 3],
            policy_state: policy.new_workspace(),
            policy_action: vec![0.0; n],
            kin: KinematicsWorkspace::new(&robot),
            jac: Matrix6xX::zeros(n),
            linear: vec![0.0; 3 * n],
            gripper: [0.0; 3],
            steps: 0,
            travel: 0.0,
            #[cfg(feature = "mujoco")]
            physics: match &self.settings.physics {
                Some(p) => Some(Box::new(
                    crate::sim::mujoco::EnvPhysics::new(&goal.problem, &arbiter, p, &goal.problem.start)
                        .map_err(|e| EnvError::Physics(e.to_string()))?,
                )),
                None => None,
            },
            arbiter,
            goals,
            target,
        };
        arbiter_reset(&mut running);
        running.gripper = gripper_state(&mut running)?;
        let outcome = self.advance(&mut running)?;
        self.running = Some(running);
        if outcome != EnvOutcome::Running {
            // Done before the first step (the user believes it has arrived): a state of zeros.
            self.state.fill(0.0);
        }
        Ok(&self.state)
    }

    /// A task, its user's goal, the user's name and the user.
    #[allow(clippy::type_complexity)]
    fn sample(
        &self,
        rng: &mut ChaCha8Rng,
    ) -> Result<(Vec<ProblemGoal>, usize, String, Box<dyn Operator>), ArbitrationError> {
        let s = &self.settings;
        match s.task {
            EnvTask::Planar => {
                let user = s.users[rng.random_range(0..s.users.len())];
                let task = sample_planar_task(&self.base, rng.random(), rng.random_range(0..1 << 20))?;
                Ok((task.reach, task.target, user.name(), user.build(s.speed, rng.random())))
            }
            EnvTask::PandaGrasp => {
                let kind = s.operators[rng.random_range(0..s.operators.len())];
                let task = sample_task(&self.base, Arm::Right, rng.random(), rng.random_range(0..1 << 20))?;
                Ok((vec![task.goal], 0, kind.name(), kind.build(s.speed, rng.random())))
            }
        }
    }

    /// Executes `action` (the arbitrated gripper velocity in units of the
    /// user speed, `task_dims` values, clipped to `max_action`) for one tick.
    ///
    /// # Errors
    /// No running episode ([`ArbitrationEnv::reset`] first), an action of
    /// another length or not finite.
    pub fn step(&mut self, action: &[f64]) -> Result<StepResult<'_>, EnvError> {
        let mut running = self.running.take().ok_or(EnvError::NotReset)?;
        let d = self.layout.task_dims;
        if action.len() != d || action.iter().any(|a| !a.is_finite()) {
            self.running = Some(running);
            return Err(EnvError::Action { dims: d, action: action.to_vec() });
        }
        let result = self.execute(&mut running, action);
        self.running = Some(running);
        let (env_reward, outcome, executed) = result?;
        Ok(StepResult { state: &self.state, env_reward, outcome, executed })
    }

    fn execute(&mut self, r: &mut Running, action: &[f64]) -> Result<(f64, EnvOutcome, [f64; 3]), ArbitrationError> {
        let s = &self.settings;
        let command: Vec<f64> = action.iter().map(|a| a.clamp(-s.max_action, s.max_action) * s.speed).collect();
        let dt = r.arbiter.settings().period;
        let input =
            TickInput { q: &r.q, velocity: Some(&r.velocity), command: HumanCommand::Linear(&r.human), beliefs: None };
        let qdot = r.arbiter.act_observed(&mut r.ws, &input, &command).qdot.to_vec();
        r.velocity.copy_from_slice(&qdot);
        if move_arm(r, &qdot) {
            return Ok((s.obstacle_reward, EnvOutcome::Collision, [0.0; 3]));
        }
        r.steps += 1;
        let before = r.gripper;
        r.gripper = gripper_state(r)?;
        r.travel += super::operator::distance(before, r.gripper);
        let executed = [0, 1, 2].map(|i| (r.gripper[i] - before[i]) / dt);
        let mut reward = 0.0;
        let model = r.arbiter.collision_model().clone();
        let mut cws = crate::collision::CollisionWorkspace::new(&model);
        // With physics, MuJoCo's contacts decide (in `move_arm`).
        if s.physics.is_none() && !model.collision_free(&mut cws, &r.q)? {
            return Ok((s.obstacle_reward, EnvOutcome::Collision, executed));
        }
        let bounded = if s.task == EnvTask::Planar { 2 } else { r.q.len() };
        let at_border = r
            .arbiter
            .robot()
            .limits()
            .iter()
            .zip(&r.q)
            .take(bounded)
            .any(|(l, x)| *x <= l.lower + s.border_band || *x >= l.upper - s.border_band);
        if at_border {
            reward += s.border_reward;
        }
        if s.physics.is_none() && r.judge.succeeded(&r.q) {
            return Ok((reward + s.goal_reward, EnvOutcome::Success, executed));
        }
        let at_grasp = super::operator::distance(r.gripper, r.goals[r.target].position) <= super::REACH_TOLERANCE;
        if s.physics.is_some() && at_grasp && r.judge.succeeded(&r.q) {
            return Ok(match grasp(r)? {
                true => (reward + s.goal_reward, EnvOutcome::Success, executed),
                false => (reward, EnvOutcome::Failed, executed),
            });
        }
        if r.steps as f64 * dt >= s.max_time {
            return Ok((reward, EnvOutcome::Timeout, executed));
        }
        let outcome = self.advance(r)?;
        Ok((reward, outcome, executed))
    }

    /// The user acts at the current configuration and the arbiter observes
    /// the new state into `self.state`.
    fn advance(&mut self, r: &mut Running) -> Result<EnvOutcome, ArbitrationError> {
        let policy = r.goals[r.target].policy.clone();
        if policy.act(&mut r.policy_state, &r.q, &r.velocity, &mut r.policy_action).is_err() {
            r.policy_action.fill(0.0);
        }
        let dt = r.arbiter.settings().period;
        let seen = Observation {
            q: &r.q,
            gripper: r.gripper,
            goal: r.goals[r.target].position,
            jacobian: &r.linear,
            policy_action: &r.policy_action,
            time: r.steps as f64 * dt,
        };
        r.human = match r.operator.act(&seen) {
            OperatorAction::Done => return Ok(EnvOutcome::Failed),
            OperatorAction::Move(v) => v,
        };
        let input =
            TickInput { q: &r.q, velocity: Some(&r.velocity), command: HumanCommand::Linear(&r.human), beliefs: None };
        match r.arbiter.observe(&mut r.ws, &input, &self.layout) {
            Ok(state) => {
                self.state.copy_from_slice(state);
                Ok(EnvOutcome::Running)
            }
            // A state the arbiter refuses (a failed sub-policy): the episode cannot go on.
            Err(_) => Ok(EnvOutcome::Failed),
        }
    }
}

/// Moves the arm by `qdot` for a period: integrated, or by MuJoCo. True
/// when physics saw a collision (an obstacle touched, the box pushed).
fn move_arm(r: &mut Running, qdot: &[f64]) -> bool {
    #[cfg(feature = "mujoco")]
    if let Some(physics) = r.physics.as_mut() {
        return physics.step(&r.arbiter, qdot, &mut r.q).is_some();
    }
    let dt = r.arbiter.settings().period;
    for (q, v) in r.q.iter_mut().zip(qdot) {
        *q += dt * v;
    }
    false
}

/// Closes, lifts and holds (physics only): whether the box stayed lifted.
fn grasp(r: &mut Running) -> Result<bool, ArbitrationError> {
    #[cfg(feature = "mujoco")]
    if let Some(physics) = r.physics.as_mut() {
        let reason = physics
            .grasp(&r.arbiter, &r.ws, &mut r.q, &mut r.velocity)
            .map_err(|e| crate::settings::InvalidSetting::new("physics", e, "a grasp MuJoCo can simulate"))?;
        r.gripper = gripper_state(r)?;
        return Ok(reason == super::Reason::Success);
    }
    let _ = r;
    Ok(false)
}

fn arbiter_reset(r: &mut Running) {
    r.arbiter.reset(&mut r.ws);
}

fn gripper_state(r: &mut Running) -> Result<[f64; 3], ArbitrationError> {
    let robot = r.arbiter.robot();
    robot.forward_kinematics(&mut r.kin, &r.q)?;
    let pose = robot.frame_jacobian(&r.kin, r.arbiter.gripper_frame(), ReferenceFrame::WorldAligned, &mut r.jac)?;
    let n = r.q.len();
    for row in 0..3 {
        for c in 0..n {
            r.linear[row * n + c] = r.jac[(row, c)];
        }
    }
    Ok(pose.translation.vector.into())
}
