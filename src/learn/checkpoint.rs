//! Training that survives an interruption. After every epoch the whole
//! optimisation state — the weights, AdamW's moments and step count, the
//! minibatch order and its generator's position, the losses so far — is
//! written to a checkpoint file (safetensors, replaced atomically). A run
//! started again with the same checkpoint path, data and settings goes on
//! from the last finished epoch and ends with the same weights, bit for
//! bit, as a run never stopped; a checkpoint of other data or settings is
//! refused by name. The file is removed when training ends.

use super::LearnError;
use super::dataset::Pairs;
use super::layers::candle;
use super::network::PolicyMeta;
use super::train_settings::{EpochLoss, TrainSettings};
use candle_core::backprop::GradStore;
use candle_core::{Device, Tensor, Var};
use candle_nn::ParamsAdamW;
use safetensors::tensor::{Dtype, SafeTensors, TensorView};
use sha2::{Digest, Sha256};
use std::path::Path;

/// Value of the checkpoint metadata's `format`.
const CHECKPOINT_FORMAT: &str = "tandem.training_checkpoint";

/// candle_nn's AdamW, operation for operation (so its results are the
/// same), with its moments and step count readable and restorable.
pub(crate) struct AdamW {
    /// Each parameter with its first and second moments.
    vars: Vec<(Var, Var, Var)>,
    step_t: usize,
    params: ParamsAdamW,
}

impl AdamW {
    pub(crate) fn new(vars: Vec<Var>, params: ParamsAdamW) -> Result<AdamW, LearnError> {
        let vars = vars
            .into_iter()
            .map(|var| {
                let m = Var::zeros(var.shape(), var.dtype(), var.device()).map_err(candle)?;
                let v = Var::zeros(var.shape(), var.dtype(), var.device()).map_err(candle)?;
                Ok((var, m, v))
            })
            .collect::<Result<_, LearnError>>()?;
        Ok(AdamW { vars, step_t: 0, params })
    }

    pub(crate) fn set_learning_rate(&mut self, lr: f64) {
        self.params.lr = lr;
    }

    /// Back-propagates `loss` and takes one step.
    pub(crate) fn backward_step(&mut self, loss: &Tensor) -> Result<(), candle_core::Error> {
        let grads = loss.backward()?;
        self.step(&grads)
    }

    fn step(&mut self, grads: &GradStore) -> Result<(), candle_core::Error> {
        self.step_t += 1;
        let p = &self.params;
        let (lr, beta1, beta2) = (p.lr, p.beta1, p.beta2);
        let lr_lambda = lr * p.weight_decay;
        let scale_m = 1f64 / (1f64 - beta1.powi(self.step_t as i32));
        let scale_v = 1f64 / (1f64 - beta2.powi(self.step_t as i32));
        for (theta, m, v) in &self.vars {
            if let Some(g) = grads.get(theta) {
                let next_m = ((m.as_tensor() * beta1)? + (g * (1.0 - beta1))?)?;
                let next_v = ((v.as_tensor() * beta2)? + (g.sqr()? * (1.0 - beta2))?)?;
                let m_hat = (&next_m * scale_m)?;
                let v_hat = (&next_v * scale_v)?;
                let next_theta = (theta.as_tensor() * (1f64 - lr_lambda))?;
                let adjusted_grad = (m_hat / (v_hat.sqrt()? + p.eps)?)?;
                let next_theta = (next_theta - (adjusted_grad * lr)?)?;
                m.set(&next_m)?;
                v.set(&next_v)?;
                theta.set(&next_theta)?;
            }
        }
        Ok(())
    }
}

/// Where training stands after an epoch (the checkpoint's metadata).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct Progress {
    format: String,
    /// Hash of everything the run's result depends on ([`fingerprint`]).
    fingerprint: String,
    /// Epochs finished.
    pub epochs_done: usize,
    /// Minibatches done (the learning-rate schedule's position).
    pub batches_done: u64,
    /// Position of the minibatch generator (ChaCha8 words; text: a u128).
    pub rng_word_pos: String,
    /// Losses of the finished epochs.
    pub losses: Vec<EpochLoss>,
}

/// SHA-256 (hex) of what a training run's weights depend on: the network's
/// metadata, the settings that shape the optimisation, the normalisation,
/// the training and validation pairs, and the starting network if any.
pub(crate) fn fingerprint(
    meta: &PolicyMeta,
    settings: &TrainSettings,
    normalisation: (&[f32], &[f32]),
    train: &Pairs,
    validation: &Pairs,
    initial: Option<&[u8]>,
) -> String {
    let mut h = Sha256::new();
    let shaping = serde_json::json!({
        "meta": meta,
        "epochs": settings.epochs,
        "seed": settings.seed,
        "hidden": settings.hidden,
        "batch": settings.batch,
        "learning_rate": settings.learning_rate,
        "speed_weight": settings.speed_weight,
        "direction_speed": settings.direction_speed,
    });
    h.update(shaping.to_string().as_bytes());
    // Only when used, so checkpoints of the dissertation's loss keep theirs.
    let slopes = settings.slope_weight > 0.0;
    if slopes {
        h.update(format!("slope_weight {}", settings.slope_weight).as_bytes());
    }
    let mut floats = |values: &[f32]| {
        h.update((values.len() as u64).to_le_bytes());
        for v in values {
            h.update(v.to_le_bytes());
        }
    };
    floats(normalisation.0);
    floats(normalisation.1);
    for pairs in [train, validation] {
        floats(&pairs.inputs);
        floats(&pairs.directions);
        floats(&pairs.speeds);
        if slopes {
            floats(&pairs.slopes);
            floats(&pairs.slope_inverse_lengths);
            // Rows (below 2³²) as the bits of f32s, hashed like the values.
            let rows: Vec<f32> = pairs.slope_rows.iter().flatten().map(|r| f32::from_bits(*r as u32)).collect();
            floats(&rows);
        }
    }
    if let Some(bytes) = initial {
        h.update(Sha256::digest(bytes));
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// A checkpoint read back: parameters, moments, order and progress.
pub(crate) struct Saved {
    pub params: Vec<Tensor>,
    pub first_moments: Vec<Tensor>,
    pub second_moments: Vec<Tensor>,
    pub adam_step: usize,
    pub order: Vec<usize>,
    pub progress: Progress,
}

impl Progress {
    pub(crate) fn new(fingerprint: String) -> Progress {
        Progress {
            format: CHECKPOINT_FORMAT.into(),
            fingerprint,
            epochs_done: 0,
            batches_done: 0,
            rng_word_pos: "0".into(),
            losses: vec![],
        }
    }
}

fn bad(path: &Path, message: impl std::fmt::Display) -> LearnError {
    LearnError::Metadata { path: path.into(), message: format!("training checkpoint: {message}") }
}

/// Writes the state after an epoch to `path` (through a temporary file
/// renamed over it, so an interruption leaves the previous one whole).
pub(crate) fn save(path: &Path, adam: &AdamW, order: &[usize], progress: &Progress) -> Result<(), LearnError> {
    let mut owned: Vec<(String, Vec<usize>, Dtype, Vec<u8>)> = vec![];
    for (k, (theta, m, v)) in adam.vars.iter().enumerate() {
        for (name, var) in [("param", theta), ("m", m), ("v", v)] {
            let values = var.as_tensor().flatten_all().and_then(|t| t.to_vec1::<f32>()).map_err(candle)?;
            let bytes = values.iter().flat_map(|x| x.to_le_bytes()).collect();
            owned.push((format!("{name}.{k}"), var.dims().to_vec(), Dtype::F32, bytes));
        }
    }
    let order_bytes = order.iter().flat_map(|i| (*i as u64).to_le_bytes()).collect();
    owned.push(("order".into(), vec![order.len()], Dtype::U64, order_bytes));
    let mut meta = serde_json::to_value(progress).map_err(|e| bad(path, e))?;
    meta["adam_step"] = adam.step_t.into();
    let views = owned
        .iter()
        .map(|(name, shape, dtype, bytes)| {
            TensorView::new(*dtype, shape.clone(), bytes).map(|view| (name.clone(), view)).map_err(|e| bad(path, e))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let info = std::collections::HashMap::from([("tandem".to_string(), meta.to_string())]);
    let bytes = safetensors::serialize(views, Some(info)).map_err(|e| bad(path, e))?;
    let temporary = path.with_extension("partial");
    std::fs::write(&temporary, bytes).map_err(|source| LearnError::Io { path: temporary.clone(), source })?;
    std::fs::rename(&temporary, path).map_err(|source| LearnError::Io { path: path.into(), source })
}

/// Reads the checkpoint at `path` if there is one; refuses one written by
/// a run with another `fingerprint`.
pub(crate) fn load(path: &Path, fingerprint: &str) -> Result<Option<Saved>, LearnError> {
    let bytes = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(LearnError::Io { path: path.into(), source }),
    };
    let (_, header) = SafeTensors::read_metadata(&bytes).map_err(|e| bad(path, e))?;
    let file = SafeTensors::deserialize(&bytes).map_err(|e| bad(path, e))?;
    let text = header.metadata().as_ref().and_then(|m| m.get("tandem")).ok_or_else(|| bad(path, "no metadata"))?;
    let meta: serde_json::Value = serde_json::from_str(text).map_err(|e| bad(path, e))?;
    let progress: Progress = serde_json::from_value(meta.clone()).map_err(|e| bad(path, e))?;
    if progress.format != CHECKPOINT_FORMAT {
        return Err(bad(path, format!("format {:?}, not {CHECKPOINT_FORMAT:?}", progress.format)));
    }
    if progress.fingerprint != fingerprint {
        return Err(bad(
            path,
            "written by a run with other data or settings; give the same ones to resume, or remove the file",
        ));
    }
    let adam_step = meta["adam_step"].as_u64().ok_or_else(|| bad(path, "no adam_step"))? as usize;
    let tensor = |name: &str| -> Result<Tensor, LearnError> {
        let view = file.tensor(name).map_err(|e| bad(path, e))?;
        if view.dtype() != Dtype::F32 {
            return Err(bad(path, format!("{name} is {:?}, not F32", view.dtype())));
        }
        let values: Vec<f32> =
            view.data().chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        Tensor::from_vec(values, view.shape(), &Device::Cpu).map_err(candle)
    };
    let count = file.names().iter().filter(|n| n.starts_with("param.")).count();
    let read_all = |prefix: &str| (0..count).map(|k| tensor(&format!("{prefix}.{k}"))).collect::<Result<Vec<_>, _>>();
    let order_view = file.tensor("order").map_err(|e| bad(path, e))?;
    let order = order_view
        .data()
        .chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()) as usize)
        .collect();
    Ok(Some(Saved {
        params: read_all("param")?,
        first_moments: read_all("m")?,
        second_moments: read_all("v")?,
        adam_step,
        order,
        progress,
    }))
}

/// Puts a checkpoint's parameters and moments into `adam` (whose
/// parameters are the network's).
///
/// # Errors
/// A checkpoint for another architecture.
pub(crate) fn restore(adam: &mut AdamW, saved: &Saved, path: &Path) -> Result<(), LearnError> {
    if saved.params.len() != adam.vars.len() {
        return Err(bad(path, format!("{} parameters, the network has {}", saved.params.len(), adam.vars.len())));
    }
    for (k, (theta, m, v)) in adam.vars.iter().enumerate() {
        for (var, value) in [(theta, &saved.params[k]), (m, &saved.first_moments[k]), (v, &saved.second_moments[k])] {
            if var.dims() != value.dims() {
                return Err(bad(
                    path,
                    format!("parameter {k} has shape {:?}, the network {:?}", value.dims(), var.dims()),
                ));
            }
            var.set(value).map_err(candle)?;
        }
    }
    adam.step_t = saved.adam_step;
    Ok(())
}
