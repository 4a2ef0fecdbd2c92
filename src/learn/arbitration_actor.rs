//! The learned arbitration's actor at query time (§6.5 of the dissertation):
//! the state without the operator's command goes through the "head" (three
//! 32-unit ReLU layers and a linear 2-unit layer); the head's output joined
//! with the operator's command goes through the "tail" (three 16-unit ReLU
//! layers and a `tanh` output scaled by [`ArbitrationMeta::max_command`]).
//! Hand-written `f32` layers, nothing allocated per query, saved as
//! safetensors (`head.{i}.weight`, `head.{i}.bias`, `tail.{i}.…`, `[out,
//! in]`; metadata key `tandem` = [`ArbitrationMeta`] as JSON).

use super::LearnError;
use super::network::{DenseLayer, first_non_finite_layer, read_f32, read_with_meta, safetensors_bytes};
use crate::arbitration::{ArbitrationPolicy, StateLayout};
use std::path::Path;

/// Value of [`ArbitrationMeta::format`].
pub const ARBITRATION_FORMAT: &str = "tandem.arbitration_actor";
/// Value of [`ArbitrationMeta::version`] this build writes and reads.
pub const ARBITRATION_FORMAT_VERSION: u32 = 1;

/// (inputs, outputs) of each layer.
pub type LayerShapes = Vec<(usize, usize)>;

/// What an actor file says about itself.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ArbitrationMeta {
    /// Always [`ARBITRATION_FORMAT`].
    pub format: String,
    /// Always [`ARBITRATION_FORMAT_VERSION`].
    pub version: u32,
    /// The state the actor reads.
    pub layout: StateLayout,
    /// Widths of the head's layers (the last is its output; the dissertation's: 32, 32, 32, 2).
    pub head: Vec<usize>,
    /// Widths of the tail's hidden layers (the dissertation's: 16, 16, 16).
    pub tail: Vec<usize>,
    /// Largest command component, in units of `layout.speed_scale`.
    pub max_command: f64,
    /// The reward trained with (`combined` or `environment`).
    pub reward: String,
    /// Training seed.
    pub seed: u64,
    /// Training episodes.
    pub episodes: usize,
}

impl ArbitrationMeta {
    /// Input and output widths of every head layer, then every tail layer.
    pub fn layer_shapes(&self) -> (LayerShapes, LayerShapes) {
        let d = self.layout.task_dims;
        let mut head = vec![self.layout.human_offset()];
        head.extend(&self.head);
        let mut tail = vec![self.head.last().copied().unwrap_or(0) + d];
        tail.extend(&self.tail);
        tail.push(d);
        let pairs = |w: Vec<usize>| w.windows(2).map(|w| (w[0], w[1])).collect();
        (pairs(head), pairs(tail))
    }

    fn check(&self) -> Result<(), String> {
        if self.format != ARBITRATION_FORMAT {
            return Err(format!("format is {:?}, expected {ARBITRATION_FORMAT:?}", self.format));
        }
        if self.version != ARBITRATION_FORMAT_VERSION {
            return Err(format!("format version {} (this build reads {ARBITRATION_FORMAT_VERSION})", self.version));
        }
        if !self.layout.is_valid() || self.layout.goals == 0 {
            return Err("the state layout needs 2 or 3 task dimensions, a goal and positive scales".into());
        }
        if self.head.is_empty() || self.head.contains(&0) || self.tail.contains(&0) {
            return Err("an empty head or an empty layer".into());
        }
        if !(self.max_command.is_finite() && self.max_command > 0.0) {
            return Err("max_command is not positive".into());
        }
        Ok(())
    }
}

/// The trained actor. Immutable and `Send + Sync`.
#[derive(Debug, Clone, PartialEq)]
pub struct ArbitrationActor {
    meta: ArbitrationMeta,
    head: Vec<DenseLayer>,
    tail: Vec<DenseLayer>,
}

impl ArbitrationActor {
    /// An actor from row-major `[out, in]` weights and biases, head layers
    /// then tail layers, in the shapes of `meta.layer_shapes()`.
    ///
    /// # Errors
    /// Invalid metadata, parts of other sizes, non-finite values.
    pub fn from_parts(meta: ArbitrationMeta, layers: &[(Vec<f32>, Vec<f32>)]) -> Result<ArbitrationActor, LearnError> {
        let here = || "(in memory)".into();
        meta.check().map_err(|message| LearnError::Metadata { path: here(), message })?;
        let (head_shapes, tail_shapes) = meta.layer_shapes();
        if layers.len() != head_shapes.len() + tail_shapes.len() {
            return Err(LearnError::Metadata {
                path: here(),
                message: format!("{} layers expected, got {}", head_shapes.len() + tail_shapes.len(), layers.len()),
            });
        }
        let mut built = vec![];
        for (i, ((inputs, outputs), (w, b))) in head_shapes.iter().chain(&tail_shapes).zip(layers).enumerate() {
            if w.len() != inputs * outputs || b.len() != *outputs {
                return Err(LearnError::TensorShape {
                    path: here(),
                    name: format!("layer {i}"),
                    expected: vec![*outputs, *inputs],
                    got: vec![w.len(), b.len()],
                });
            }
            built.push(DenseLayer::from_row_major(*inputs, *outputs, w, b.clone()));
        }
        let tail = built.split_off(head_shapes.len());
        let actor = ArbitrationActor { meta, head: built, tail };
        let bad = first_non_finite_layer(&actor.head, "head").or_else(|| first_non_finite_layer(&actor.tail, "tail"));
        match bad {
            Some(name) => Err(LearnError::NonFinite { path: here(), name }),
            None => Ok(actor),
        }
    }

    /// The metadata.
    pub fn meta(&self) -> &ArbitrationMeta {
        &self.meta
    }

    /// The file's bytes (safetensors). Same actor, same bytes.
    ///
    /// # Errors
    /// Serialisation errors.
    pub fn to_bytes(&self) -> Result<Vec<u8>, LearnError> {
        let meta = serde_json::to_string(&self.meta)
            .map_err(|e| LearnError::Metadata { path: "(in memory)".into(), message: e.to_string() })?;
        let mut tensors = vec![];
        for (prefix, layers) in [("head", &self.head), ("tail", &self.tail)] {
            for (i, l) in layers.iter().enumerate() {
                let (w, b) = l.row_major();
                tensors.push((format!("{prefix}.{i}.weight"), vec![l.outputs, l.inputs], w));
                tensors.push((format!("{prefix}.{i}.bias"), vec![l.outputs], b));
            }
        }
        safetensors_bytes(meta, &tensors)
    }

    /// Writes the actor to `path`.
    ///
    /// # Errors
    /// I/O errors.
    pub fn save(&self, path: &Path) -> Result<(), LearnError> {
        let bytes = self.to_bytes()?;
        std::fs::write(path, bytes).map_err(|source| LearnError::Io { path: path.into(), source })
    }

    /// Reads an actor written by [`ArbitrationActor::save`].
    ///
    /// # Errors
    /// An unreadable file, not safetensors, no or wrong `tandem` metadata
    /// (another format or version — a robot policy file, say), a missing
    /// tensor or one of another type or shape, non-finite values.
    pub fn load(path: &Path) -> Result<ArbitrationActor, LearnError> {
        let bytes = std::fs::read(path).map_err(|source| LearnError::Io { path: path.into(), source })?;
        ArbitrationActor::from_bytes(&bytes, path)
    }

    /// As [`ArbitrationActor::load`], from bytes; `path` names them in errors.
    ///
    /// # Errors
    /// As [`ArbitrationActor::load`].
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<ArbitrationActor, LearnError> {
        let (file, meta): (_, ArbitrationMeta) =
            read_with_meta(bytes, path, "a tandem arbitration actor", ARBITRATION_FORMAT)?;
        let metadata_error = |message: String| LearnError::Metadata { path: path.into(), message };
        meta.check().map_err(metadata_error)?;
        let (head, tail) = meta.layer_shapes();
        let mut layers = vec![];
        for (prefix, shapes) in [("head", &head), ("tail", &tail)] {
            for (i, (inputs, outputs)) in shapes.iter().enumerate() {
                let w = read_f32(&file, path, &format!("{prefix}.{i}.weight"), &[*outputs, *inputs])?;
                let b = read_f32(&file, path, &format!("{prefix}.{i}.bias"), &[*outputs])?;
                layers.push((w, b));
            }
        }
        if file.names().len() != 2 * layers.len() {
            return Err(metadata_error(format!(
                "{} tensors, the metadata implies {}",
                file.names().len(),
                2 * layers.len()
            )));
        }
        ArbitrationActor::from_parts(meta, &layers).map_err(|e| match e {
            LearnError::NonFinite { name, .. } => LearnError::NonFinite { path: path.into(), name },
            e => e,
        })
    }

    fn widest(&self) -> usize {
        self.head.iter().chain(&self.tail).map(|l| l.inputs.max(l.outputs)).max().unwrap_or(0)
    }
}

impl ArbitrationPolicy for ArbitrationActor {
    fn layout(&self) -> StateLayout {
        self.meta.layout
    }

    fn scratch_len(&self) -> usize {
        2 * self.widest()
    }

    fn act(&self, state: &[f64], scratch: &mut [f32], command: &mut [f64]) {
        let layout = self.meta.layout;
        let (d, h) = (layout.task_dims, layout.human_offset());
        let w = self.widest();
        let (mut a, mut b) = scratch.split_at_mut(w);
        for (x, s) in a.iter_mut().zip(&state[..h]) {
            *x = *s as f32;
        }
        let last = self.head.len() - 1;
        for (i, layer) in self.head.iter().enumerate() {
            layer.apply(a, b, i < last);
            std::mem::swap(&mut a, &mut b);
        }
        let joined = self.head[last].outputs;
        for (x, s) in a[joined..joined + d].iter_mut().zip(&state[h..h + d]) {
            *x = *s as f32;
        }
        let last = self.tail.len() - 1;
        for (i, layer) in self.tail.iter().enumerate() {
            layer.apply(a, b, i < last);
            std::mem::swap(&mut a, &mut b);
        }
        for (c, y) in command.iter_mut().zip(&a[..d]) {
            *c = f64::from(y.tanh()) * self.meta.max_command;
        }
    }
}
