//! Training the policy network with candle (CPU): minibatch AdamW on the
//! dissertation's loss (§3.3.3, see [`loss`](super::loss)) — the weighted
//! sum of the mean squared errors of the unit joint velocity and of its norm,
//! optionally with a slope term — with a cosine learning-rate decay.
//!
//! Deterministic: the initial weights and the minibatch order come from the
//! seed (ChaCha8), and every operation runs in a fixed order on the CPU, so
//! the same seed and data give the same bytes of the weights.

use super::LearnError;
use super::checkpoint::{self, AdamW};
use super::dataset::Pairs;
use super::loss::{Prepared, losses, normalisation, speed_scale};
use super::network::{PolicyMeta, PolicyNetwork};
use crate::settings::{InvalidSetting, non_negative, positive, readable};
use candle_core::{Device, Tensor, Var};
use candle_nn::ParamsAdamW;
use indicatif::{ProgressBar, ProgressStyle};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// How to train.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainSettings {
    /// Passes over the training pairs (default 30).
    pub epochs: usize,
    /// Seed of the initial weights and the minibatch order.
    pub seed: u64,
    /// Widths of the hidden layers (default 128, 128, 128).
    pub hidden: Vec<usize>,
    /// Pairs per minibatch (default 512).
    pub batch: usize,
    /// Initial learning rate, decayed to 1 % of it by a cosine (default 2e-3).
    pub learning_rate: f64,
    /// Weight of the speed loss against the direction loss (default 1).
    pub speed_weight: f64,
    /// Speed (rad/s) below which a pair's direction loss is scaled down
    /// linearly: the direction of a near-zero velocity is noise (default 0.05).
    pub direction_speed: f64,
    /// Weight of the slope loss: the network's action change from each
    /// demonstrated state to its perturbed copies against the LQR tracking
    /// policy's, relative to its mean square (default 0: the dissertation's
    /// loss; needs perturbed pairs, see [`loss`](super::loss)).
    pub slope_weight: f64,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Save the optimisation state here after every epoch and resume from
    /// it when it exists (see [`checkpoint`](super::checkpoint)); removed
    /// when training ends. `None` (default): no checkpoint.
    pub checkpoint: Option<std::path::PathBuf>,
}

/// Most hidden layers of a policy network.
pub const MAX_HIDDEN_LAYERS: usize = 16;
/// Widest hidden layer of a policy network: 4096 × 4096 weights are 64 MB
/// of f32, already far past the 2 µs a query may take.
pub const MAX_HIDDEN_WIDTH: usize = 4096;

impl TrainSettings {
    /// Checks every setting: at least one epoch and one pair per batch,
    /// 1 … [`MAX_HIDDEN_LAYERS`] hidden layers of 1 … [`MAX_HIDDEN_WIDTH`]
    /// units, a learning rate and direction speed above 0, a speed weight
    /// of at least 0.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        if self.epochs == 0 {
            return Err(InvalidSetting::new("epochs", self.epochs, "at least 1"));
        }
        if self.batch == 0 {
            return Err(InvalidSetting::new("batch", self.batch, "at least 1"));
        }
        let widths = self.hidden.iter().map(usize::to_string).collect::<Vec<_>>().join(",");
        if self.hidden.is_empty() || self.hidden.len() > MAX_HIDDEN_LAYERS {
            return Err(InvalidSetting::new("hidden", widths, format!("1 … {MAX_HIDDEN_LAYERS} layer widths")));
        }
        if self.hidden.iter().any(|w| !(1..=MAX_HIDDEN_WIDTH).contains(w)) {
            return Err(InvalidSetting::new("hidden", widths, format!("widths of 1 … {MAX_HIDDEN_WIDTH} units")));
        }
        positive("learning_rate", self.learning_rate, "")?;
        positive("direction_speed", self.direction_speed, "rad/s")?;
        non_negative("slope_weight", self.slope_weight, "")?;
        non_negative("speed_weight", self.speed_weight, "")
    }
}

impl Default for TrainSettings {
    fn default() -> Self {
        TrainSettings {
            epochs: 30,
            seed: 0,
            hidden: vec![128, 128, 128],
            batch: 512,
            learning_rate: 2e-3,
            speed_weight: 1.0,
            direction_speed: 0.05,
            slope_weight: 0.0,
            progress: false,
            checkpoint: None,
        }
    }
}

/// Mean losses of one epoch.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EpochLoss {
    /// Epoch number, from 1.
    pub epoch: usize,
    /// Training loss (mean over the epoch's minibatches).
    pub train: f64,
    /// Validation loss (NaN without validation pairs).
    pub validation: f64,
    /// Its direction term (mean squared error of the unit direction).
    pub validation_direction: f64,
    /// Its speed term (mean squared error of the scaled norm).
    pub validation_speed: f64,
}

/// What training did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrainReport {
    /// Losses per epoch.
    pub losses: Vec<EpochLoss>,
    /// Wall-clock seconds of the optimisation.
    pub seconds: f64,
    /// State-action pairs trained on (perturbed ones included).
    pub train_pairs: usize,
    /// State-action pairs held out.
    pub validation_pairs: usize,
    /// Trajectories of the training split.
    pub train_trajectories: usize,
    /// Trajectories of the validation split.
    pub validation_trajectories: usize,
}

pub(crate) fn candle(e: candle_core::Error) -> LearnError {
    LearnError::Training(e.to_string())
}

/// Trainable dense layers (ReLU between them).
pub(crate) struct Layers {
    weights: Vec<Var>,
    biases: Vec<Var>,
}

impl Layers {
    /// He-uniform weights from `rng`, zero biases; or a copy of `initial`'s.
    fn new(meta: &PolicyMeta, initial: Option<&PolicyNetwork>, rng: &mut ChaCha8Rng) -> Result<Layers, LearnError> {
        Layers::with_shapes(&meta.layer_shapes(), |i| initial.map(|net| net.layer(i)), rng)
    }

    /// Layers of `shapes` (inputs, outputs): `initial(i)`'s weights
    /// (row-major `[out, in]`) and bias where it has them, else He-uniform
    /// weights from `rng` and zero biases.
    pub(crate) fn with_shapes(
        shapes: &[(usize, usize)],
        initial: impl Fn(usize) -> Option<(Vec<f32>, Vec<f32>)>,
        rng: &mut ChaCha8Rng,
    ) -> Result<Layers, LearnError> {
        let mut layers = Layers { weights: vec![], biases: vec![] };
        for (i, &(inputs, outputs)) in shapes.iter().enumerate() {
            let (w, b) = match initial(i) {
                Some(layer) => layer,
                None => {
                    let bound = (6.0 / inputs as f64).sqrt();
                    let w = (0..inputs * outputs).map(|_| rng.random_range(-bound..bound) as f32).collect();
                    (w, vec![0.0; outputs])
                }
            };
            let w = Tensor::from_vec(w, (outputs, inputs), &Device::Cpu).map_err(candle)?;
            let b = Tensor::from_vec(b, outputs, &Device::Cpu).map_err(candle)?;
            layers.weights.push(Var::from_tensor(&w).map_err(candle)?);
            layers.biases.push(Var::from_tensor(&b).map_err(candle)?);
        }
        Ok(layers)
    }

    pub(crate) fn forward(&self, x: &Tensor) -> Result<Tensor, candle_core::Error> {
        let last = self.weights.len() - 1;
        let mut h = x.clone();
        for (i, (w, b)) in self.weights.iter().zip(&self.biases).enumerate() {
            h = h.matmul(&w.as_tensor().t()?)?.broadcast_add(b.as_tensor())?;
            if i < last {
                h = h.relu()?;
            }
        }
        Ok(h)
    }

    pub(crate) fn vars(&self) -> Vec<Var> {
        self.weights.iter().chain(&self.biases).cloned().collect()
    }

    /// Weights and biases per layer, flattened (row-major).
    pub(crate) fn values(&self) -> Result<(LayerValues, LayerValues), LearnError> {
        let read = |v: &Var| v.as_tensor().flatten_all().and_then(|t| t.to_vec1::<f32>()).map_err(candle);
        Ok((
            self.weights.iter().map(read).collect::<Result<_, _>>()?,
            self.biases.iter().map(read).collect::<Result<_, _>>()?,
        ))
    }
}

/// One flattened tensor per layer.
type LayerValues = Vec<Vec<f32>>;

/// Trains a network described by `meta` on `train` (validated on
/// `validation` after each epoch). `initial` continues from a network
/// (same shapes; its normalisation and speed scale are kept); otherwise
/// they come from `train`.
///
/// # Errors
/// No training pairs, settings out of range, shapes that differ from
/// `initial`'s, candle errors.
pub fn train(
    meta: PolicyMeta,
    train: &Pairs,
    validation: &Pairs,
    initial: Option<&PolicyNetwork>,
    settings: &TrainSettings,
) -> Result<(PolicyNetwork, TrainReport), LearnError> {
    validate(&meta, train, settings, initial)?;
    let began = Instant::now();
    let (mean, std, meta) = match initial {
        Some(net) => {
            let (mean, std) = net.normalisation();
            (mean, std, PolicyMeta { speed_scale: net.meta().speed_scale, ..meta })
        }
        None => {
            let (mean, std) = normalisation(train);
            (mean, std, PolicyMeta { speed_scale: speed_scale(train), ..meta })
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let layers = Layers::new(&meta, initial, &mut rng)?;
    let prepare = |p: &Pairs| Prepared::new(p, (&mean, &std), meta.speed_scale, settings.direction_speed);
    let (data, held_out) = (prepare(train), prepare(validation));
    let (slopes, slope_scale) = (settings.slope_weight > 0.0, data.slope_scale());
    let params = ParamsAdamW { lr: settings.learning_rate, weight_decay: 0.0, ..ParamsAdamW::default() };
    let mut optimizer = AdamW::new(layers.vars(), params)?;
    let batches_per_epoch = data.len().div_ceil(settings.batch);
    let total = (batches_per_epoch * settings.epochs) as u64;
    let bar = settings.progress.then(|| progress_bar(total, "batches"));
    let mut order: Vec<usize> = (0..data.len()).collect();
    let mut report = TrainReport {
        losses: vec![],
        seconds: 0.0,
        train_pairs: train.len(),
        validation_pairs: validation.len(),
        train_trajectories: train.trajectories,
        validation_trajectories: validation.trajectories,
    };
    let mut step = 0u64;
    let mut first_epoch = 0;
    let mut progress = None;
    if let Some(path) = &settings.checkpoint {
        let initial_bytes = initial.map(PolicyNetwork::to_bytes).transpose()?;
        let fingerprint =
            checkpoint::fingerprint(&meta, settings, (&mean, &std), train, validation, initial_bytes.as_deref());
        if let Some(saved) = checkpoint::load(path, &fingerprint)? {
            checkpoint::restore(&mut optimizer, &saved, path)?;
            order = saved.order;
            step = saved.progress.batches_done;
            rng.set_word_pos(saved.progress.rng_word_pos.parse().unwrap_or_default());
            report.losses = saved.progress.losses.clone();
            first_epoch = saved.progress.epochs_done;
            if let Some(bar) = &bar {
                bar.set_position(step);
            }
        }
        progress = Some(checkpoint::Progress::new(fingerprint));
    }
    for epoch in first_epoch..settings.epochs {
        shuffle(&mut order, &mut rng);
        let mut sum = 0.0;
        for rows in order.chunks(settings.batch) {
            let progress = step as f64 / total.max(1) as f64;
            let lr = settings.learning_rate * (0.01 + 0.99 * 0.5 * (1.0 + (std::f64::consts::PI * progress).cos()));
            optimizer.set_learning_rate(lr);
            let batch = data.batch(rows, slopes)?;
            let loss = weighted_sum(&losses(&layers, &batch, meta.dof(), slope_scale).map_err(candle)?, settings)
                .map_err(candle)?;
            optimizer.backward_step(&loss).map_err(candle)?;
            sum += f64::from(loss.to_scalar::<f32>().map_err(candle)?);
            step += 1;
            if let Some(bar) = &bar {
                bar.inc(1);
            }
        }
        let (vd, vs) = evaluate(&layers, &held_out, meta.dof())?;
        let loss = EpochLoss {
            epoch: epoch + 1,
            train: sum / batches_per_epoch as f64,
            validation: vd + settings.speed_weight * vs,
            validation_direction: vd,
            validation_speed: vs,
        };
        let line = format!("epoch {} · train {:.4} · validation {:.4}", epoch + 1, loss.train, loss.validation);
        match &bar {
            Some(bar) if !bar.is_hidden() => bar.set_message(line),
            // Not a terminal (logs, CI): a line per epoch.
            Some(_) => eprintln!("{line} · {:.0} s", began.elapsed().as_secs_f64()),
            None => {}
        }
        report.losses.push(loss);
        if let (Some(path), Some(progress)) = (&settings.checkpoint, progress.as_mut()) {
            progress.epochs_done = epoch + 1;
            progress.batches_done = step;
            progress.rng_word_pos = rng.get_word_pos().to_string();
            progress.losses = report.losses.clone();
            checkpoint::save(path, &optimizer, &order, progress)?;
        }
    }
    if let Some(bar) = &bar {
        bar.finish();
    }
    if let Some(path) = &settings.checkpoint {
        let _ = std::fs::remove_file(path);
    }
    let (weights, biases) = layers.values()?;
    let network = PolicyNetwork::from_parts(meta, mean, std, &weights, &biases)?;
    report.seconds = began.elapsed().as_secs_f64();
    Ok((network, report))
}

fn validate(
    meta: &PolicyMeta,
    train: &Pairs,
    s: &TrainSettings,
    initial: Option<&PolicyNetwork>,
) -> Result<(), LearnError> {
    s.validate()?;
    let mismatch =
        |what: &str, expected: String, got: String| Err(LearnError::Mismatch { what: what.into(), expected, got });
    if train.is_empty() {
        let why = "no training pairs (is the validation share 1, or the dataset empty?)";
        return mismatch("training pairs", "at least one".into(), why.into());
    }
    if train.input_width != meta.input_width() || train.dof != meta.dof() {
        let (expected, got) = (meta.input_width().to_string(), train.input_width.to_string());
        return mismatch("input width of the pairs", expected, got);
    }
    if let Some(net) = initial
        && net.meta().layer_shapes() != meta.layer_shapes()
    {
        let (expected, got) = (format!("{:?}", meta.layer_shapes()), format!("{:?}", net.meta().layer_shapes()));
        return mismatch("layer shapes of the network to continue from", expected, got);
    }
    Ok(())
}

/// The weighted sum of a minibatch's losses.
fn weighted_sum(l: &super::loss::Losses, settings: &TrainSettings) -> Result<Tensor, candle_core::Error> {
    let loss = (&l.direction + (&l.speed * settings.speed_weight)?)?;
    match &l.slope {
        Some(slope) => loss + (slope * settings.slope_weight)?,
        None => Ok(loss),
    }
}

/// Mean direction and speed losses over `data` (NaN when empty): the
/// dissertation's loss, whatever the slope weight (validation pairs are
/// demonstrations only).
fn evaluate(layers: &Layers, data: &Prepared, n: usize) -> Result<(f64, f64), LearnError> {
    if data.len() == 0 {
        return Ok((f64::NAN, f64::NAN));
    }
    let value = |t: &Tensor| t.to_scalar::<f32>().map(f64::from).map_err(candle);
    let (mut direction, mut speed) = (0.0, 0.0);
    let rows: Vec<usize> = (0..data.len()).collect();
    for chunk in rows.chunks(8192) {
        let batch = data.batch(chunk, false)?;
        let l = losses(layers, &batch, n, 1.0).map_err(candle)?;
        let w = chunk.len() as f64;
        direction += w * value(&l.direction)?;
        speed += w * value(&l.speed)?;
    }
    Ok((direction / data.len() as f64, speed / data.len() as f64))
}

/// Fisher-Yates with `rng`.
pub(crate) fn shuffle(order: &mut [usize], rng: &mut ChaCha8Rng) {
    for i in (1..order.len()).rev() {
        let j = rng.random_range(0..=i);
        order.swap(i, j);
    }
}

pub(crate) fn progress_bar(total: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::new(total);
    let template = format!("{{elapsed_precise}} [{{wide_bar}}] {{pos}}/{{len}} {unit} · ETA {{eta}} · {{msg}}");
    let style =
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> ");
    bar.set_style(style);
    bar
}

/// What [`train_on`] needs beyond the training settings.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnSettings {
    /// Network and optimiser settings.
    pub train: TrainSettings,
    /// Share of sample ids held out for validation (default 0.1).
    pub validation: f64,
    /// Obstacle slots of the input (default 2, the grasp family's most).
    pub obstacle_slots: usize,
    /// Robot frames besides the gripper that each slot's obstacle is also
    /// placed relative to (default none; see [`features`](super::features)).
    pub obstacle_frames: Vec<String>,
    /// Perturbed states labelled by the LQR tracking policy, training
    /// split only (default: one per state; `per_state: 0` is the
    /// demonstrations alone, as in the dissertation).
    pub augment: super::Augmentation,
}

impl LearnSettings {
    /// Checks every setting: the training settings, a validation share in
    /// [0, 1), a perturbation range positive and ordered when augmenting.
    ///
    /// # Errors
    /// The first setting out of range (named by its path, `train.epochs`).
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        self.train.validate().map_err(|e| e.within("train"))?;
        let v = self.validation;
        crate::settings::check("validation", v, (0.0..1.0).contains(&v), "in [0, 1)")?;
        let (frames, most) = (self.obstacle_frames.len(), super::features::MAX_OBSTACLE_FRAMES);
        if frames > most {
            return Err(InvalidSetting::new("obstacle_frames", frames, format!("at most {most} frames")));
        }
        let (lo, hi) = self.augment.noise;
        if self.augment.per_state > 0 && !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
            let range = format!("[{}, {}]", readable(lo), readable(hi));
            return Err(InvalidSetting::new("augment.noise", range, "a range of rad above 0, low to high"));
        }
        Ok(())
    }
}

impl Default for LearnSettings {
    fn default() -> Self {
        LearnSettings {
            train: TrainSettings::default(),
            validation: 0.1,
            obstacle_slots: 2,
            obstacle_frames: Vec::new(),
            augment: super::Augmentation { per_state: 1, ..super::Augmentation::default() },
        }
    }
}

/// Trains a policy for `family`'s robot and gripper on `demos` (its base
/// scene's obstacles are static, the others fill the slots), split into
/// training and validation by sample id; `initial` continues from a network.
///
/// # Errors
/// A family without a gripper, demonstrations of other joints, as [`train`].
pub fn train_on(
    demos: &super::Demonstrations,
    family: &crate::problem::ProblemFamily,
    options: &LearnSettings,
    initial: Option<&PolicyNetwork>,
) -> Result<(PolicyNetwork, TrainReport), LearnError> {
    options.validate()?;
    if let Some(net) = initial {
        let (had, asked) = (
            (net.meta().obstacle_slots, &net.meta().obstacle_frames),
            (options.obstacle_slots, &options.obstacle_frames),
        );
        if had != asked {
            return Err(LearnError::Mismatch {
                what: "obstacle slots and frames of the network to continue from".into(),
                expected: format!("{} slots, frames {:?}", asked.0, asked.1),
                got: format!("{} slots, frames {:?}", had.0, had.1),
            });
        }
    }
    let base = &family.base;
    let gripper = base.robot_spec.gripper.clone().ok_or_else(|| LearnError::Mismatch {
        what: "family".into(),
        expected: "a robot with a gripper frame".into(),
        got: format!("{} without one", family.name),
    })?;
    let static_obstacles: Vec<String> = base.scene.obstacles().iter().map(|o| o.name.clone()).collect();
    let robot = &base.robot;
    let view = super::dataset::InputView {
        gripper: &gripper,
        static_obstacles: &static_obstacles,
        slots: options.obstacle_slots,
        frames: &options.obstacle_frames,
    };
    let v = options.validation;
    let augment = super::Augmentation { seed: options.train.seed, ..options.augment };
    let train_pairs = demos.pairs(robot, &view, &augment, |id| !super::in_validation(id, v))?;
    let none = super::Augmentation { per_state: 0, ..augment };
    let validation_pairs = demos.pairs(robot, &view, &none, |id| super::in_validation(id, v))?;
    let meta = PolicyMeta {
        format: super::FORMAT.into(),
        version: super::FORMAT_VERSION,
        joints: robot.joint_names().to_vec(),
        gripper,
        static_obstacles,
        obstacle_slots: options.obstacle_slots,
        obstacle_frames: options.obstacle_frames.clone(),
        hidden: options.train.hidden.clone(),
        speed_scale: 1.0,
        time_step: demos.items.first().map_or(0.0, |d| d.time_step),
        family: family.name.clone(),
        seed: options.train.seed,
        epochs: options.train.epochs,
        trajectories: train_pairs.trajectories,
        pairs: train_pairs.len(),
    };
    train(meta, &train_pairs, &validation_pairs, initial, &options.train)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(hidden: Vec<usize>) -> PolicyMeta {
        PolicyMeta {
            format: super::super::FORMAT.into(),
            version: super::super::FORMAT_VERSION,
            joints: (0..7).map(|i| format!("j{i}")).collect(),
            gripper: "tcp".into(),
            static_obstacles: vec![],
            obstacle_slots: 2,
            obstacle_frames: Vec::new(),
            hidden,
            speed_scale: 0.7,
            time_step: 0.08,
            family: "test".into(),
            seed: 0,
            epochs: 0,
            trajectories: 0,
            pairs: 0,
        }
    }

    /// The query-time network (hand-written f32 layers) computes what the
    /// training graph (candle) does, to float rounding.
    #[test]
    fn hand_written_forward_matches_the_training_graph() {
        let meta = meta(vec![20, 12]);
        let d = meta.input_width();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let layers = Layers::new(&meta, None, &mut rng).unwrap();
        // Non-zero biases too.
        for b in &layers.biases {
            let values: Vec<f32> = (0..b.as_tensor().elem_count()).map(|_| rng.random_range(-0.5..0.5)).collect();
            b.set(&Tensor::from_vec(values, b.as_tensor().shape(), &Device::Cpu).unwrap()).unwrap();
        }
        let mean: Vec<f32> = (0..d).map(|_| rng.random_range(-1.0..1.0)).collect();
        let std: Vec<f32> = (0..d).map(|_| rng.random_range(0.5..2.0)).collect();
        let (weights, biases) = layers.values().unwrap();
        let network = PolicyNetwork::from_parts(meta.clone(), mean.clone(), std.clone(), &weights, &biases).unwrap();
        let rows = 40;
        let x: Vec<f32> = (0..rows * d).map(|_| rng.random_range(-3.0..3.0)).collect();
        let normalised: Vec<f32> = x
            .chunks_exact(d)
            .flat_map(|r| r.iter().zip(mean.iter().zip(&std)).map(|(v, (m, s))| (v - m) / s))
            .collect();
        let graph = layers.forward(&Tensor::from_vec(normalised, (rows, d), &Device::Cpu).unwrap()).unwrap();
        let graph: Vec<f32> = graph.flatten_all().unwrap().to_vec1().unwrap();
        let mut scratch = network.scratch();
        let mut out = vec![0.0f32; 8];
        let mut worst = 0.0f32;
        for (r, row) in x.chunks_exact(d).enumerate() {
            network.forward(row, &mut scratch, &mut out);
            for (a, b) in out.iter().zip(&graph[r * 8..(r + 1) * 8]) {
                worst = worst.max((a - b).abs() / (1.0 + b.abs()));
            }
        }
        assert!(worst < 1e-5, "largest relative difference {worst}");
        assert!(graph.iter().any(|v| v.abs() > 0.1), "a non-trivial network");
    }

    /// The slope term of the training graph is the hand-written network's
    /// action change per unit distance against the target, to float
    /// rounding: the loss trains the derivative a query differentiates.
    #[test]
    fn slope_loss_is_the_queried_actions_difference_quotient() {
        let meta = meta(vec![16, 16]);
        let (d, n) = (meta.input_width(), 7);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let layers = Layers::new(&meta, None, &mut rng).unwrap();
        let mut pairs = Pairs { input_width: d, dof: n, ..Pairs::default() };
        let rows = 6;
        pairs.inputs = (0..rows * d).map(|_| rng.random_range(-2.0..2.0)).collect();
        pairs.directions = vec![0.0; rows * n];
        pairs.speeds = vec![0.5; rows];
        // Rows 3, 4, 5 perturb rows 0, 2, 0.
        pairs.slope_rows = vec![[3, 0], [4, 2], [5, 0]];
        pairs.slopes = (0..3 * n).map(|_| rng.random_range(-3.0..3.0)).collect();
        pairs.slope_inverse_lengths = vec![20.0, 50.0, 100.0];
        let (mean, std) = normalisation(&pairs);
        let data = Prepared::new(&pairs, (&mean, &std), meta.speed_scale, 0.05);
        let all: Vec<usize> = (0..rows).collect();
        let graph = losses(&layers, &data.batch(&all, true).unwrap(), n, 2.0).unwrap();
        let graph = f64::from(graph.slope.unwrap().to_scalar::<f32>().unwrap());

        let (weights, biases) = layers.values().unwrap();
        let network = PolicyNetwork::from_parts(meta.clone(), mean, std, &weights, &biases).unwrap();
        let mut scratch = network.scratch();
        // The query's velocity, in the graph's scaled units.
        let action = |r: usize, scratch: &mut _| -> Vec<f64> {
            let (mut out, mut velocity) = (vec![0.0f32; n + 1], vec![0.0; n]);
            network.forward(&pairs.inputs[r * d..(r + 1) * d], scratch, &mut out);
            network.velocity_from_outputs(&out, &mut velocity);
            velocity.iter().map(|v| v / meta.speed_scale).collect()
        };
        let mut hand = 0.0;
        for (k, [p, b]) in pairs.slope_rows.iter().enumerate() {
            let (ap, ab) = (action(*p, &mut scratch), action(*b, &mut scratch));
            let inverse = f64::from(pairs.slope_inverse_lengths[k]);
            for j in 0..n {
                let target = f64::from(pairs.slopes[k * n + j]) / meta.speed_scale;
                hand += ((ap[j] - ab[j]) * inverse - target).powi(2);
            }
        }
        hand /= 3.0 * 2.0;
        assert!(hand > 1.0, "a non-trivial comparison: {hand}");
        assert!((graph - hand).abs() < 1e-4 * hand, "graph {graph}, hand-written {hand}");
        // Without slopes asked for, none is computed.
        assert!(losses(&layers, &data.batch(&all, false).unwrap(), n, 2.0).unwrap().slope.is_none());
    }

    #[test]
    fn bad_settings_are_refused() {
        let pairs = Pairs { input_width: meta(vec![4]).input_width(), dof: 7, ..Pairs::default() };
        let e = train(meta(vec![4]), &pairs, &pairs, None, &TrainSettings::default()).unwrap_err();
        assert!(e.to_string().contains("no training pairs"), "{e}");
    }
}
