//! The policy network at query time: a multi-layer perceptron in `f32`
//! evaluated by hand (no tensor library, nothing allocated per query), and
//! its file format (safetensors).
//!
//! File layout: tensors `input_mean` and `input_std` (`[D]`, the input
//! normalisation), `layers.{i}.weight` (`[out, in]`, PyTorch's `Linear`
//! convention) and `layers.{i}.bias` (`[out]`), all `F32`; the safetensors
//! metadata key `tandem` holds [`PolicyMeta`] as JSON. Hidden layers use
//! ReLU; the last layer is linear with `dof + 1` outputs: the direction of
//! the joint velocity (normalised at query time) and its norm divided by
//! [`PolicyMeta::speed_scale`].

use super::LearnError;
pub(crate) use super::dense::DenseLayer;
use super::features::input_width;
use safetensors::tensor::{Dtype, SafeTensors, TensorView};
use std::collections::HashMap;
use std::path::Path;

/// Value of [`PolicyMeta::format`].
pub const FORMAT: &str = "tandem.learned_policy";
/// Value of [`PolicyMeta::version`] this build writes and reads.
pub const FORMAT_VERSION: u32 = 2;

/// What a policy file says about itself (the safetensors metadata key
/// `tandem`, as JSON). Everything here is deterministic: training time
/// and losses go to the report beside the file, not into it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PolicyMeta {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`FORMAT_VERSION`].
    pub version: u32,
    /// Active joint names, in the order of `q` and of the output.
    pub joints: Vec<String>,
    /// Gripper frame whose position is the input `p` (world).
    pub gripper: String,
    /// Obstacles that are part of every task (never put in a slot).
    pub static_obstacles: Vec<String>,
    /// Obstacle slots of the input.
    pub obstacle_slots: usize,
    /// Frames besides the gripper that each slot's obstacle is placed
    /// relative to (see [`features`](super::features)); none in files
    /// written before this key.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub obstacle_frames: Vec<String>,
    /// Widths of the hidden layers.
    pub hidden: Vec<usize>,
    /// Joint speed (rad/s) of an output norm of 1.
    pub speed_scale: f64,
    /// Seconds between the dataset's slices.
    pub time_step: f64,
    /// The problem family the data came from.
    pub family: String,
    /// Training seed.
    pub seed: u64,
    /// Training epochs.
    pub epochs: usize,
    /// Trajectories trained on.
    pub trajectories: usize,
    /// State-action pairs trained on.
    pub pairs: usize,
}

impl PolicyMeta {
    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Input width.
    pub fn input_width(&self) -> usize {
        input_width(self.dof(), self.obstacle_slots, self.obstacle_frames.len())
    }

    /// Widths of every layer's input and output, first to last.
    pub fn layer_shapes(&self) -> Vec<(usize, usize)> {
        let mut widths = vec![self.input_width()];
        widths.extend(&self.hidden);
        widths.push(self.dof() + 1);
        widths.windows(2).map(|w| (w[0], w[1])).collect()
    }
}

/// The trained network: normalisation, layers and metadata. Immutable and
/// `Send + Sync`; [`PolicyNetwork::forward`] allocates nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct PolicyNetwork {
    meta: PolicyMeta,
    input_mean: Vec<f32>,
    input_std: Vec<f32>,
    layers: Vec<DenseLayer>,
}

/// Buffers of one caller's forward passes.
#[derive(Debug, Clone)]
pub struct NetworkWorkspace {
    a: Vec<f32>,
    b: Vec<f32>,
}

impl PolicyNetwork {
    /// A network from its parts: `weights[i]` row-major `[out, in]` and
    /// `biases[i]` for each layer of `meta.layer_shapes()`.
    ///
    /// # Errors
    /// Parts whose sizes disagree with `meta`, or non-finite values.
    pub fn from_parts(
        meta: PolicyMeta,
        input_mean: Vec<f32>,
        input_std: Vec<f32>,
        weights: &[Vec<f32>],
        biases: &[Vec<f32>],
    ) -> Result<PolicyNetwork, LearnError> {
        let d = meta.input_width();
        let shapes = meta.layer_shapes();
        let shape_error = |name: String, expected: Vec<usize>, got: usize| LearnError::TensorShape {
            path: "(in memory)".into(),
            name,
            expected,
            got: vec![got],
        };
        if input_mean.len() != d {
            return Err(shape_error("input_mean".into(), vec![d], input_mean.len()));
        }
        if input_std.len() != d {
            return Err(shape_error("input_std".into(), vec![d], input_std.len()));
        }
        if weights.len() != shapes.len() || biases.len() != shapes.len() {
            return Err(LearnError::Metadata {
                path: "(in memory)".into(),
                message: format!(
                    "{} layers expected, got {} weights and {} biases",
                    shapes.len(),
                    weights.len(),
                    biases.len()
                ),
            });
        }
        let mut layers = Vec::with_capacity(shapes.len());
        for (i, ((inputs, outputs), (w, b))) in shapes.iter().zip(weights.iter().zip(biases)).enumerate() {
            if w.len() != inputs * outputs {
                return Err(shape_error(format!("layers.{i}.weight"), vec![*outputs, *inputs], w.len()));
            }
            if b.len() != *outputs {
                return Err(shape_error(format!("layers.{i}.bias"), vec![*outputs], b.len()));
            }
            layers.push(DenseLayer::from_row_major(*inputs, *outputs, w, b.clone()));
        }
        let network = PolicyNetwork { meta, input_mean, input_std, layers };
        if let Some(name) = network.first_non_finite() {
            return Err(LearnError::NonFinite { path: "(in memory)".into(), name });
        }
        Ok(network)
    }

    fn first_non_finite(&self) -> Option<String> {
        let bad = |v: &[f32]| v.iter().any(|x| !x.is_finite());
        if bad(&self.input_mean) {
            return Some("input_mean".into());
        }
        if bad(&self.input_std) || self.input_std.iter().any(|s| *s <= 0.0) {
            return Some("input_std".into());
        }
        first_non_finite_layer(&self.layers, "layers")
    }

    /// The metadata.
    pub fn meta(&self) -> &PolicyMeta {
        &self.meta
    }

    /// Runs the forward pass compiled for `wanted` (or the best variant
    /// below it this CPU has) and returns the one that runs. By default
    /// the variant `TANDEM_SIMD` names, else the best available; all
    /// agree with candle's forward pass to 1e-5 (tests/learn/).
    pub fn set_simd(&mut self, wanted: crate::collision::SimdLevel) -> crate::collision::SimdLevel {
        self.layers.iter_mut().fold(wanted, |_, layer| layer.set_simd(wanted))
    }

    /// The variant of the forward pass that runs.
    pub fn simd(&self) -> crate::collision::SimdLevel {
        self.layers.first().map_or(crate::collision::SimdLevel::Baseline, DenseLayer::simd)
    }

    /// Layer `i`'s weights (row-major `[out, in]`) and bias.
    ///
    /// # Panics
    /// `i` beyond the last layer.
    pub fn layer(&self, i: usize) -> (Vec<f32>, Vec<f32>) {
        self.layers[i].row_major()
    }

    /// The input normalisation: per-feature mean and standard deviation.
    pub fn normalisation(&self) -> (Vec<f32>, Vec<f32>) {
        (self.input_mean.clone(), self.input_std.clone())
    }

    /// Buffers for [`PolicyNetwork::forward`].
    pub fn scratch(&self) -> NetworkWorkspace {
        let widest = self.layers.iter().map(|l| l.inputs.max(l.outputs)).max().unwrap_or(0);
        NetworkWorkspace { a: vec![0.0; widest], b: vec![0.0; widest] }
    }

    /// The raw outputs (`dof` direction values, then the scaled speed) for
    /// the unnormalised `input`, written to `out` (`dof + 1` values).
    /// Allocates nothing.
    pub fn forward(&self, input: &[f32], scratch: &mut NetworkWorkspace, out: &mut [f32]) {
        let d = self.input_mean.len();
        for (j, x) in input.iter().take(d).enumerate() {
            scratch.a[j] = (x - self.input_mean[j]) / self.input_std[j];
        }
        let last = self.layers.len() - 1;
        for (i, layer) in self.layers.iter().enumerate() {
            layer.apply(&scratch.a, &mut scratch.b, i < last);
            std::mem::swap(&mut scratch.a, &mut scratch.b);
        }
        let n = self.layers[last].outputs;
        out[..n].copy_from_slice(&scratch.a[..n]);
    }

    /// The joint velocity (rad/s) for raw outputs `raw`: the direction
    /// normalised, times the speed (never negative). A direction of zero
    /// length gives zero velocity.
    pub fn velocity_from_outputs(&self, raw: &[f32], velocity: &mut [f64]) {
        let n = self.meta.dof();
        let norm = raw[..n].iter().map(|v| f64::from(*v).powi(2)).sum::<f64>().sqrt();
        let speed = f64::from(raw[n]).max(0.0) * self.meta.speed_scale;
        let gain = if norm > 1e-12 { speed / norm } else { 0.0 };
        for (v, r) in velocity.iter_mut().zip(raw) {
            *v = f64::from(*r) * gain;
        }
    }

    /// The file's bytes (safetensors; see the module docs). Same network,
    /// same bytes.
    pub fn to_bytes(&self) -> Result<Vec<u8>, LearnError> {
        let meta = serde_json::to_string(&self.meta)
            .map_err(|e| LearnError::Metadata { path: "(in memory)".into(), message: e.to_string() })?;
        let mut tensors: Vec<(String, Vec<usize>, Vec<f32>)> = vec![
            ("input_mean".into(), vec![self.input_mean.len()], self.input_mean.clone()),
            ("input_std".into(), vec![self.input_std.len()], self.input_std.clone()),
        ];
        for (i, l) in self.layers.iter().enumerate() {
            let (w, b) = self.layer(i);
            tensors.push((format!("layers.{i}.weight"), vec![l.outputs, l.inputs], w));
            tensors.push((format!("layers.{i}.bias"), vec![l.outputs], b));
        }
        safetensors_bytes(meta, &tensors)
    }

    /// Writes the network to `path`.
    ///
    /// # Errors
    /// I/O errors.
    pub fn save(&self, path: &Path) -> Result<(), LearnError> {
        let bytes = self.to_bytes()?;
        std::fs::write(path, bytes).map_err(|source| LearnError::Io { path: path.into(), source })
    }

    /// Reads a network written by [`PolicyNetwork::save`].
    ///
    /// # Errors
    /// An unreadable file, not safetensors, no or wrong `tandem` metadata
    /// (format, version), a missing tensor, a tensor of another type or
    /// shape than the metadata implies, non-finite values.
    pub fn load(path: &Path) -> Result<PolicyNetwork, LearnError> {
        let bytes = std::fs::read(path).map_err(|source| LearnError::Io { path: path.into(), source })?;
        PolicyNetwork::from_bytes(&bytes, path)
    }

    /// As [`PolicyNetwork::load`], from bytes; `path` names them in errors.
    ///
    /// # Errors
    /// As [`PolicyNetwork::load`].
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<PolicyNetwork, LearnError> {
        let (file, meta): (_, PolicyMeta) = read_with_meta(bytes, path, "a tandem policy file", FORMAT)?;
        let metadata_error = |message: String| LearnError::Metadata { path: path.into(), message };
        if meta.format != FORMAT {
            return Err(metadata_error(format!("format is {:?}, expected {FORMAT:?}", meta.format)));
        }
        if meta.version != FORMAT_VERSION {
            return Err(metadata_error(format!("format version {} (this build reads {FORMAT_VERSION})", meta.version)));
        }
        if meta.joints.is_empty()
            || meta.hidden.contains(&0)
            || !(meta.speed_scale.is_finite() && meta.speed_scale > 0.0)
        {
            return Err(metadata_error(
                "no joints, an empty hidden layer or a speed scale that is not positive".into(),
            ));
        }
        let d = meta.input_width();
        let read = |name: &str, shape: &[usize]| read_f32(&file, path, name, shape);
        let mean = read("input_mean", &[d])?;
        let std = read("input_std", &[d])?;
        let mut weights = Vec::new();
        let mut biases = Vec::new();
        for (i, (inputs, outputs)) in meta.layer_shapes().into_iter().enumerate() {
            weights.push(read(&format!("layers.{i}.weight"), &[outputs, inputs])?);
            biases.push(read(&format!("layers.{i}.bias"), &[outputs])?);
        }
        let extra = file.names().len().saturating_sub(2 + 2 * weights.len());
        if extra > 0 {
            return Err(metadata_error(format!(
                "{extra} tensors more than the {} layers of the metadata",
                weights.len()
            )));
        }
        PolicyNetwork::from_parts(meta, mean, std, &weights, &biases).map_err(|e| match e {
            LearnError::NonFinite { name, .. } => LearnError::NonFinite { path: path.into(), name },
            e => e,
        })
    }
}

/// The first layer (as `{prefix}.{i}.weight` or `.bias`) holding a
/// non-finite value.
pub(crate) fn first_non_finite_layer(layers: &[DenseLayer], prefix: &str) -> Option<String> {
    layers.iter().enumerate().find_map(|(i, l)| match l.is_finite() {
        (false, _) => Some(format!("{prefix}.{i}.weight")),
        (_, false) => Some(format!("{prefix}.{i}.bias")),
        _ => None,
    })
}

/// Parses a safetensors file and its `tandem` metadata (JSON) as `T`;
/// `what` names the kind of file in errors, and a file of the other kind
/// than `expected_format` (a robot policy given as an arbitration actor)
/// says what it is.
pub(crate) fn read_with_meta<'a, T: serde::de::DeserializeOwned>(
    bytes: &'a [u8],
    path: &Path,
    what: &str,
    expected_format: &str,
) -> Result<(SafeTensors<'a>, T), LearnError> {
    let not_safetensors =
        |e: &dyn std::fmt::Display| LearnError::NotSafetensors { path: path.into(), message: e.to_string() };
    let (_, header) = SafeTensors::read_metadata(bytes).map_err(|e| not_safetensors(&e))?;
    let file = SafeTensors::deserialize(bytes).map_err(|e| not_safetensors(&e))?;
    let metadata_error = |message: String| LearnError::Metadata { path: path.into(), message };
    let text = header
        .metadata()
        .as_ref()
        .and_then(|m| m.get("tandem"))
        .ok_or_else(|| metadata_error(format!("no `tandem` metadata: not {what}")))?;
    // The other kind of tandem network says what it is, not which field it lacks.
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| metadata_error(format!("`tandem` metadata: {e}")))?;
    let format = value.get("format").and_then(serde_json::Value::as_str).unwrap_or_default();
    let kinds = [
        (FORMAT, "a learned robot policy (`tandem learn policy`; read by `tandem experiment policy --policy`)"),
        (
            super::ARBITRATION_FORMAT,
            "a learned arbitration actor (`tandem learn arbitration`; read by `--arbiter` with `--mode learned`)",
        ),
    ];
    if let Some((_, kind)) = kinds.iter().find(|(f, _)| *f == format && *f != expected_format) {
        return Err(metadata_error(format!("this file is {kind}, not {what}")));
    }
    let meta = serde_json::from_value(value).map_err(|e| metadata_error(format!("`tandem` metadata: {e}")))?;
    Ok((file, meta))
}

/// Reads `name` from `file` as `f32` values of exactly `shape`.
pub(crate) fn read_f32(
    file: &SafeTensors<'_>,
    path: &Path,
    name: &str,
    shape: &[usize],
) -> Result<Vec<f32>, LearnError> {
    let view = file.tensor(name).map_err(|_| LearnError::MissingTensor { path: path.into(), name: name.into() })?;
    if view.dtype() != Dtype::F32 {
        return Err(LearnError::TensorType {
            path: path.into(),
            name: name.into(),
            got: format!("{:?}", view.dtype()),
        });
    }
    if view.shape() != shape {
        return Err(LearnError::TensorShape {
            path: path.into(),
            name: name.into(),
            expected: shape.to_vec(),
            got: view.shape().to_vec(),
        });
    }
    Ok(view.data().chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

/// Serialises `tensors` (name, shape, values) with `meta` as the `tandem`
/// metadata key. Same input, same bytes.
pub(crate) fn safetensors_bytes(
    meta: String,
    tensors: &[(String, Vec<usize>, Vec<f32>)],
) -> Result<Vec<u8>, LearnError> {
    let data: Vec<Vec<u8>> = tensors.iter().map(|(_, _, v)| le_bytes(v)).collect();
    let views = tensors
        .iter()
        .zip(&data)
        .map(|((name, shape, _), data)| {
            TensorView::new(Dtype::F32, shape.clone(), data).map(|v| (name.clone(), v)).map_err(|e| {
                LearnError::Metadata { path: "(in memory)".into(), message: format!("tensor {name}: {e}") }
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    // One metadata key: safetensors writes its map in hash order.
    let info = HashMap::from([("tandem".to_string(), meta)]);
    safetensors::serialize(views, Some(info))
        .map_err(|e| LearnError::Metadata { path: "(in memory)".into(), message: e.to_string() })
}

fn le_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}
