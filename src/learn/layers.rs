//! What every candle trainer here shares (the policy network, the grasp
//! intent classifier, the arbitration actor and critic, the candle
//! reference forward pass): trainable dense layers, the mapping of candle's
//! errors, the seeded minibatch shuffle and the progress bar.

use super::LearnError;
use super::network::{PolicyMeta, PolicyNetwork};
use candle_core::{Device, Tensor, Var};
use indicatif::{ProgressBar, ProgressStyle};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// A candle error as a training error.
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
    pub(crate) fn new(
        meta: &PolicyMeta,
        initial: Option<&PolicyNetwork>,
        rng: &mut ChaCha8Rng,
    ) -> Result<Layers, LearnError> {
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

/// Fisher-Yates with `rng`.
pub(crate) fn shuffle(order: &mut [usize], rng: &mut ChaCha8Rng) {
    for i in (1..order.len()).rev() {
        let j = rng.random_range(0..=i);
        order.swap(i, j);
    }
}

/// A progress bar of `total` steps counted in `unit` (stderr).
pub(crate) fn progress_bar(total: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::new(total);
    let template = format!("{{elapsed_precise}} [{{wide_bar}}] {{pos}}/{{len}} {unit} · ETA {{eta}} · {{msg}}");
    let style =
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> ");
    bar.set_style(style);
    bar
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::SeedableRng;

    /// A 7-joint network's description with `hidden` layers, for tests.
    pub(crate) fn meta(hidden: Vec<usize>) -> PolicyMeta {
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
}
