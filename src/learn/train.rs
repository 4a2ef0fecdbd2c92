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
use super::layers::{Layers, candle, progress_bar, shuffle};
use super::loss::{Prepared, losses, normalisation, speed_scale};
use super::network::{PolicyMeta, PolicyNetwork};
use super::train_settings::{EpochLoss, LearnSettings, TrainReport, TrainSettings};
use candle_core::Tensor;
use candle_nn::ParamsAdamW;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

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
    use super::super::layers::tests::meta;
    use super::*;

    #[test]
    fn bad_settings_are_refused() {
        let pairs = Pairs { input_width: meta(vec![4]).input_width(), dof: 7, ..Pairs::default() };
        let e = train(meta(vec![4]), &pairs, &pairs, None, &TrainSettings::default()).unwrap_err();
        assert!(e.to_string().contains("no training pairs"), "{e}");
    }
}
