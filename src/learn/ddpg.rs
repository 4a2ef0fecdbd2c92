//! DDPG for arbitration (the dissertation's Algorithm 4) on the planar
//! [`ArbitrationEnv`]: actor and critic as in §6.5 (a shared-shape "head"
//! of three 32-unit layers and a 2-unit layer; actor: head ⊕ user command →
//! three 16-unit layers → 2-D action; critic: head ⊕ user command ⊕
//! arbitrated action → two 128-unit layers → value), target networks
//! updated softly, a replay buffer, Gaussian exploration noise, and
//! hindsight goal labelling: an episode's transitions wait in an episode
//! buffer until it ends and the user's goal is known, then get their
//! rewards ([`reward`], Algorithm 5) and join the replay buffer. Updates
//! start once `warmup_episodes` episodes are in it.
//!
//! Candle on the CPU; every random draw (weights, tasks, users, noise,
//! minibatches) comes from the seed, so the same settings give the same
//! actor, bit for bit.

use super::LearnError;
use super::arbitration_actor::{ARBITRATION_FORMAT, ARBITRATION_FORMAT_VERSION, ArbitrationActor, ArbitrationMeta};
use super::layers::{Layers, candle, progress_bar};
use crate::arbitration::StateLayout;
use crate::settings::InvalidSetting;
use crate::sim::{ArbitrationEnv, ArbitrationEnvSettings, EnvOutcome, RewardKind, reward};
use candle_core::{D, Device, Tensor, Var};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// Settings of [`train_arbitration`].
#[derive(Debug, Clone, PartialEq)]
pub struct DdpgSettings {
    /// Training episodes (default 300).
    pub episodes: usize,
    /// The reward (default combined).
    pub reward: RewardKind,
    /// Seed of everything random.
    pub seed: u64,
    /// Discount γ (default 0.98).
    pub gamma: f64,
    /// Soft target update τ (default 0.01).
    pub tau: f64,
    /// Actor learning rate (default 3e-4).
    pub actor_lr: f64,
    /// Critic learning rate (default 1e-3).
    pub critic_lr: f64,
    /// Minibatch size (default 64).
    pub batch: usize,
    /// Replay buffer capacity in transitions (default 100,000).
    pub buffer: usize,
    /// Episodes collected before the first update (default 5).
    pub warmup_episodes: usize,
    /// Exploration noise (standard deviation, units of the user speed;
    /// default 0.3, decayed linearly to a third over training).
    pub noise: f64,
    /// Widths of the head (default 32, 32, 32, 2).
    pub head: Vec<usize>,
    /// Widths of the actor's tail (default 16, 16, 16).
    pub actor_tail: Vec<usize>,
    /// Widths of the critic's tail (default 128, 128).
    pub critic_tail: Vec<usize>,
    /// The environment.
    pub env: ArbitrationEnvSettings,
    /// Show a progress bar.
    pub progress: bool,
}

impl Default for DdpgSettings {
    fn default() -> Self {
        DdpgSettings {
            episodes: 300,
            reward: RewardKind::Combined,
            seed: 0,
            gamma: 0.98,
            tau: 0.01,
            actor_lr: 3e-4,
            critic_lr: 1e-3,
            batch: 64,
            buffer: 100_000,
            warmup_episodes: 5,
            noise: 0.3,
            head: vec![32, 32, 32, 2],
            actor_tail: vec![16, 16, 16],
            critic_tail: vec![128, 128],
            env: ArbitrationEnvSettings::default(),
            progress: false,
        }
    }
}

/// One training episode.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrainingEpisode {
    /// Episode number (from 0).
    pub episode: usize,
    /// The user's name.
    pub user: String,
    /// How it ended.
    pub outcome: String,
    /// Sum of the trained reward.
    pub episode_return: f64,
    /// Sum of the environment reward.
    pub env_return: f64,
    /// Steps.
    pub steps: usize,
}

/// What [`train_arbitration`] returns.
#[derive(Debug, Clone)]
pub struct DdpgReport {
    /// The trained actor.
    pub actor: ArbitrationActor,
    /// Every episode.
    pub episodes: Vec<TrainingEpisode>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// A transition in the episode buffer, waiting for its reward until the
/// user's goal is known.
struct Pending {
    state: Vec<f64>,
    action: Vec<f64>,
    env_reward: f64,
    next: Vec<f64>,
    done: bool,
}

/// A transition in the replay buffer, with its reward.
#[derive(Debug, Clone)]
struct Transition {
    state: Vec<f32>,
    action: Vec<f32>,
    reward: f32,
    next: Vec<f32>,
    done: bool,
}

/// The actor or the critic: a head over the state without the command,
/// then a tail over the head's output joined with the rest.
struct Net {
    head: Layers,
    tail: Layers,
}

impl Net {
    fn new(
        layout: &StateLayout,
        head: &[usize],
        tail: &[usize],
        outputs: usize,
        extra: usize,
        rng: &mut ChaCha8Rng,
    ) -> Result<Net, LearnError> {
        let shapes = |first: usize, widths: &[usize]| -> Vec<(usize, usize)> {
            let mut w = vec![first];
            w.extend(widths);
            w.windows(2).map(|p| (p[0], p[1])).collect()
        };
        let head_out = head.last().copied().unwrap_or(0);
        let mut tail_widths = tail.to_vec();
        tail_widths.push(outputs);
        Ok(Net {
            head: Layers::with_shapes(&shapes(layout.human_offset(), head), |_| None, rng)?,
            tail: Layers::with_shapes(&shapes(head_out + extra, &tail_widths), |_| None, rng)?,
        })
    }

    /// The tail's raw output for `state` (`[B, W]`) and `extra` columns (`[B, e]`).
    fn forward(&self, state: &Tensor, h: usize, extra: &Tensor) -> candle_core::Result<Tensor> {
        let head = self.head.forward(&state.narrow(1, 0, h)?)?;
        self.tail.forward(&Tensor::cat(&[&head, extra], 1)?)
    }

    fn vars(&self) -> Vec<Var> {
        let mut v = self.head.vars();
        v.extend(self.tail.vars());
        v
    }

    fn copy(&self, rng: &mut ChaCha8Rng) -> Result<Net, LearnError> {
        let clone = |l: &Layers, rng: &mut ChaCha8Rng| -> Result<Layers, LearnError> {
            let (w, b) = l.values()?;
            let shapes: Vec<(usize, usize)> = l.vars()[..w.len()]
                .iter()
                .map(|v| {
                    let d = v.as_tensor().dims();
                    (d[1], d[0])
                })
                .collect();
            Layers::with_shapes(&shapes, |i| Some((w[i].clone(), b[i].clone())), rng)
        };
        Ok(Net { head: clone(&self.head, rng)?, tail: clone(&self.tail, rng)? })
    }

    /// `self ← (1 − τ) self + τ source`.
    fn soft_update(&self, source: &Net, tau: f64) -> candle_core::Result<()> {
        for (t, s) in self.vars().iter().zip(source.vars()) {
            let mixed = ((t.as_tensor() * (1.0 - tau))? + (s.as_tensor() * tau)?)?;
            t.set(&mixed)?;
        }
        Ok(())
    }
}

/// The actor's action `tanh(tail) · max` for `state` (`[B, W]`).
fn act(actor: &Net, state: &Tensor, layout: &StateLayout, max: f64) -> candle_core::Result<Tensor> {
    let (h, d) = (layout.human_offset(), layout.task_dims);
    actor.forward(state, h, &state.narrow(1, h, d)?)?.tanh()? * max
}

/// The critic's value of `action` (`[B, d]`) in `state`.
fn value(critic: &Net, state: &Tensor, action: &Tensor, layout: &StateLayout) -> candle_core::Result<Tensor> {
    let (h, d) = (layout.human_offset(), layout.task_dims);
    let extra = Tensor::cat(&[&state.narrow(1, h, d)?, action], 1)?;
    critic.forward(state, h, &extra)
}

/// Trains an arbitration actor with DDPG (see the module docs).
/// `on_episode` sees every finished episode (a progress line, say).
///
/// # Errors
/// Settings out of range, environment or candle errors.
pub fn train_arbitration(
    settings: &DdpgSettings,
    on_episode: &mut (dyn FnMut(&TrainingEpisode) + Send),
) -> Result<DdpgReport, LearnError> {
    check(settings)?;
    // The networks are tiny: candle's threads cost more than they give
    // (3× slower on two cores), and one thread per run lets callers train
    // several runs side by side.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| LearnError::Training(format!("cannot start the training thread pool: {e}")))?;
    pool.install(|| train_in_pool(settings, on_episode))
}

fn train_in_pool(
    settings: &DdpgSettings,
    on_episode: &mut (dyn FnMut(&TrainingEpisode) + Send),
) -> Result<DdpgReport, LearnError> {
    let began = Instant::now();
    let mut env = ArbitrationEnv::new(settings.env.clone()).map_err(|e| LearnError::Training(e.to_string()))?;
    let layout = env.layout();
    let (w, d) = (layout.width(), layout.task_dims);
    let max = settings.env.max_action;
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let actor = Net::new(&layout, &settings.head, &settings.actor_tail, d, d, &mut rng)?;
    let critic = Net::new(&layout, &settings.head, &settings.critic_tail, 1, 2 * d, &mut rng)?;
    let (actor_target, critic_target) = (actor.copy(&mut rng)?, critic.copy(&mut rng)?);
    let params = |lr: f64| ParamsAdamW { lr, weight_decay: 0.0, ..ParamsAdamW::default() };
    let mut actor_opt = AdamW::new(actor.vars(), params(settings.actor_lr)).map_err(candle)?;
    let mut critic_opt = AdamW::new(critic.vars(), params(settings.critic_lr)).map_err(candle)?;
    let mut replay: Vec<Transition> = Vec::with_capacity(settings.buffer.min(1 << 20));
    let mut replay_next = 0;
    let bar = settings.progress.then(|| progress_bar(settings.episodes as u64, "episodes"));
    let mut log = vec![];
    for episode in 0..settings.episodes {
        let noise = settings.noise * (1.0 - 2.0 / 3.0 * episode as f64 / settings.episodes.max(1) as f64);
        let mut state: Vec<f64> = env.reset(rng.random()).map_err(env_error)?.to_vec();
        let mut buffer: Vec<Pending> = vec![];
        let mut outcome = EnvOutcome::Running;
        while outcome == EnvOutcome::Running {
            let s = Tensor::from_vec(state.iter().map(|x| *x as f32).collect::<Vec<_>>(), (1, w), &Device::Cpu)
                .map_err(candle)?;
            let a = act(&actor, &s, &layout, max).and_then(|t| t.flatten_all()?.to_vec1::<f32>()).map_err(candle)?;
            let action: Vec<f64> =
                a.iter().map(|x| (f64::from(*x) + noise * gaussian(&mut rng)).clamp(-max, max)).collect();
            let step = env.step(&action).map_err(env_error)?;
            outcome = step.outcome;
            buffer.push(Pending {
                state: state.clone(),
                action: action.clone(),
                env_reward: step.env_reward,
                next: step.state.to_vec(),
                done: step.done(),
            });
            state.copy_from_slice(step.state);
            if episode >= settings.warmup_episodes && replay.len() >= settings.batch {
                let batch = sample(&replay, settings.batch, &mut rng)?;
                let nets = UpdateNets {
                    actor: &actor,
                    critic: &critic,
                    actor_target: &actor_target,
                    critic_target: &critic_target,
                };
                update(&nets, &mut actor_opt, &mut critic_opt, &batch, &layout, settings)?;
            }
        }
        // Hindsight goal labelling: the user's goal is known now.
        let goal = env.true_goal();
        let (mut total, mut env_total) = (0.0, 0.0);
        for p in buffer {
            let r = reward(&layout, &p.state, &p.action, goal, p.env_reward, settings.reward, &settings.env.decision);
            total += r;
            env_total += p.env_reward;
            let t = Transition {
                state: p.state.iter().map(|x| *x as f32).collect(),
                action: p.action.iter().map(|x| *x as f32).collect(),
                reward: r as f32,
                next: p.next.iter().map(|x| *x as f32).collect(),
                done: p.done,
            };
            if replay.len() < settings.buffer {
                replay.push(t);
            } else {
                replay[replay_next] = t;
                replay_next = (replay_next + 1) % settings.buffer;
            }
        }
        let entry = TrainingEpisode {
            episode,
            user: env.user().unwrap_or_default().to_string(),
            outcome: outcome.as_str().into(),
            episode_return: total,
            env_return: env_total,
            steps: env.steps(),
        };
        if let Some(bar) = &bar {
            bar.inc(1);
            let line = format!("{} {} · return {:.1}", entry.user, entry.outcome, entry.episode_return);
            if bar.is_hidden() {
                // Not a terminal (logs, CI): a line per 10 episodes.
                if (episode + 1) % 10 == 0 {
                    let recent = &log[log.len().saturating_sub(9)..];
                    let wins = recent.iter().filter(|e: &&TrainingEpisode| e.outcome == "success").count()
                        + usize::from(entry.outcome == "success");
                    eprintln!(
                        "episode {} · {line} · {wins}/10 successes · {:.0} s",
                        episode + 1,
                        began.elapsed().as_secs_f64()
                    );
                }
            } else {
                bar.set_message(line);
            }
        }
        on_episode(&entry);
        log.push(entry);
    }
    if let Some(bar) = &bar {
        bar.finish();
    }
    let meta = ArbitrationMeta {
        format: ARBITRATION_FORMAT.into(),
        version: ARBITRATION_FORMAT_VERSION,
        layout,
        head: settings.head.clone(),
        tail: settings.actor_tail.clone(),
        max_command: max,
        reward: settings.reward.as_str().into(),
        seed: settings.seed,
        episodes: settings.episodes,
    };
    let mut layers = vec![];
    for l in [&actor.head, &actor.tail] {
        let (w, b) = l.values()?;
        layers.extend(w.into_iter().zip(b));
    }
    let actor = ArbitrationActor::from_parts(meta, &layers)?;
    Ok(DdpgReport { actor, episodes: log, seconds: began.elapsed().as_secs_f64() })
}

fn env_error(e: crate::sim::EnvError) -> LearnError {
    LearnError::Training(format!("arbitration environment: {e}"))
}

fn check(s: &DdpgSettings) -> Result<(), LearnError> {
    Ok(s.validate()?)
}

impl DdpgSettings {
    /// Checks every setting: at least one episode and one pair per batch,
    /// a buffer of at least a batch, γ in [0, 1), τ in (0, 1], learning
    /// rates above 0, noise of at least 0, layers of 1 …
    /// [`MAX_HIDDEN_WIDTH`](super::MAX_HIDDEN_WIDTH) units (a head of at
    /// least one layer).
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        use crate::settings::{check, non_negative, positive};
        let at_least = |field: &str, value: usize, min: usize| {
            if value >= min { Ok(()) } else { Err(InvalidSetting::new(field, value, format!("at least {min}"))) }
        };
        at_least("episodes", self.episodes, 1)?;
        at_least("batch", self.batch, 1)?;
        at_least("buffer", self.buffer, self.batch)?;
        check("gamma", self.gamma, (0.0..1.0).contains(&self.gamma), "in [0, 1)")?;
        check("tau", self.tau, self.tau > 0.0 && self.tau <= 1.0, "in (0, 1]")?;
        positive("actor_lr", self.actor_lr, "")?;
        positive("critic_lr", self.critic_lr, "")?;
        non_negative("noise", self.noise, "")?;
        let max = super::MAX_HIDDEN_WIDTH;
        for (field, layers, min_layers) in
            [("head", &self.head, 1), ("actor_tail", &self.actor_tail, 0), ("critic_tail", &self.critic_tail, 0)]
        {
            if layers.len() < min_layers
                || layers.len() > super::MAX_HIDDEN_LAYERS
                || layers.iter().any(|w| !(1..=max).contains(w))
            {
                let widths = layers.iter().map(usize::to_string).collect::<Vec<_>>().join(",");
                return Err(InvalidSetting::new(field, widths, format!("layers of 1 … {max} units")));
            }
        }
        Ok(())
    }
}

/// A standard normal draw (Box–Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// A minibatch as tensors.
struct Batch {
    state: Tensor,
    action: Tensor,
    reward: Tensor,
    next: Tensor,
    not_done: Tensor,
}

fn sample(replay: &[Transition], n: usize, rng: &mut ChaCha8Rng) -> Result<Batch, LearnError> {
    let picks: Vec<&Transition> = (0..n).map(|_| &replay[rng.random_range(0..replay.len())]).collect();
    let (w, d) = (picks[0].state.len(), picks[0].action.len());
    let dev = &Device::Cpu;
    let rows = |f: &dyn Fn(&Transition) -> Vec<f32>, cols: usize| {
        let values: Vec<f32> = picks.iter().flat_map(|t| f(t)).collect();
        Tensor::from_vec(values, (n, cols), dev)
    };
    let make = || -> candle_core::Result<Batch> {
        Ok(Batch {
            state: rows(&|t| t.state.clone(), w)?,
            action: rows(&|t| t.action.clone(), d)?,
            reward: rows(&|t| vec![t.reward], 1)?,
            next: rows(&|t| t.next.clone(), w)?,
            not_done: rows(&|t| vec![if t.done { 0.0 } else { 1.0 }], 1)?,
        })
    };
    make().map_err(candle)
}

struct UpdateNets<'a> {
    actor: &'a Net,
    critic: &'a Net,
    actor_target: &'a Net,
    critic_target: &'a Net,
}

/// One critic step on the TD target, one actor step on `−Q(s, μ(s))`, and
/// the soft target updates.
fn update(
    nets: &UpdateNets<'_>,
    actor_opt: &mut AdamW,
    critic_opt: &mut AdamW,
    b: &Batch,
    layout: &StateLayout,
    s: &DdpgSettings,
) -> Result<(), LearnError> {
    let max = s.env.max_action;
    let mut step = || -> candle_core::Result<()> {
        let next_action = act(nets.actor_target, &b.next, layout, max)?;
        let next_value = value(nets.critic_target, &b.next, &next_action, layout)?.detach();
        let target = (&b.reward + ((next_value * &b.not_done)? * s.gamma)?)?;
        let q = value(nets.critic, &b.state, &b.action, layout)?;
        let critic_loss = (q - target)?.sqr()?.mean_all()?;
        critic_opt.backward_step(&critic_loss)?;
        let policy_value = value(nets.critic, &b.state, &act(nets.actor, &b.state, layout, max)?, layout)?;
        let actor_loss = policy_value.mean(D::Minus2)?.mean_all()?.neg()?;
        actor_opt.backward_step(&actor_loss)?;
        nets.actor_target.soft_update(nets.actor, s.tau)?;
        nets.critic_target.soft_update(nets.critic, s.tau)
    };
    step().map_err(candle)
}
