//! Grasp-intent classifier (§7.3.2 of the dissertation): from one frame of
//! hand features, which object the person reaches for and whether from the top
//! or the side.
//!
//! A small dense network (the trainers' shared layers, `learn/layers.rs`: ReLU
//! between them, He-uniform initialisation) with two softmax heads — object
//! (`objects` classes) and grasp direction (2 classes) — trained with candle
//! by AdamW on the sum of the two cross-entropies. The inputs are normalised
//! by the training set's mean and standard deviation. Deterministic per seed.
//!
//! ```
//! use tandem::learn::grasp_intent::{IntentClassifier, IntentTrainSettings};
//! // Two features, two objects: the object is the sign of feature 0, the
//! // direction the sign of feature 1.
//! let mut x = vec![];
//! let mut labels = vec![];
//! for i in 0..200 {
//!     let (a, b) = ((i % 7) as f32 - 3.0, (i % 5) as f32 - 2.0);
//!     x.push(vec![a, b]);
//!     labels.push(((a > 0.0) as usize, (b > 0.0) as usize));
//! }
//! let settings = IntentTrainSettings { epochs: 40, ..IntentTrainSettings::default() };
//! let net = IntentClassifier::train(&x, &labels, 2, &settings)?;
//! let p = net.predict(&[vec![2.0, -2.0]])?;
//! assert_eq!(p[0], (1, 0));
//! # Ok::<(), tandem::learn::LearnError>(())
//! ```

use super::LearnError;
use super::layers::{Layers, candle, shuffle};
use candle_core::{Device, Tensor};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Logits of one row: (object logits, direction logits [top, side]).
pub type IntentLogits = (Vec<f32>, Vec<f32>);

/// How to train the classifier.
#[derive(Debug, Clone, PartialEq)]
pub struct IntentTrainSettings {
    /// Passes over the frames (default 20).
    pub epochs: usize,
    /// Widths of the hidden layers (default 64, 64).
    pub hidden: Vec<usize>,
    /// Frames per minibatch (default 256).
    pub batch: usize,
    /// AdamW learning rate (default 3e-3).
    pub learning_rate: f64,
    /// Seed of the weights and the minibatch order.
    pub seed: u64,
}

impl Default for IntentTrainSettings {
    fn default() -> Self {
        IntentTrainSettings { epochs: 20, hidden: vec![64, 64], batch: 256, learning_rate: 3e-3, seed: 0 }
    }
}

/// A trained grasp-intent classifier.
pub struct IntentClassifier {
    layers: Layers,
    mean: Vec<f32>,
    std: Vec<f32>,
    objects: usize,
}

impl std::fmt::Debug for IntentClassifier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IntentClassifier").field("inputs", &self.mean.len()).field("objects", &self.objects).finish()
    }
}

impl IntentClassifier {
    /// Trains on feature rows `x` (all of one width) labelled
    /// `(object, direction)` (direction 0 top, 1 side), `objects` classes.
    ///
    /// # Errors
    /// No rows, rows of different widths, labels out of range, zero epochs
    /// or batch, candle errors.
    pub fn train(
        x: &[Vec<f32>],
        labels: &[(usize, usize)],
        objects: usize,
        settings: &IntentTrainSettings,
    ) -> Result<IntentClassifier, LearnError> {
        let width = x.first().map_or(0, Vec::len);
        let bad = |m: &str| Err(LearnError::Training(m.to_string()));
        if x.is_empty() || width == 0 || x.len() != labels.len() {
            return bad("the intent classifier needs labelled feature rows");
        }
        if x.iter().any(|r| r.len() != width) {
            return bad("feature rows differ in width");
        }
        if labels.iter().any(|&(o, d)| o >= objects || d >= 2) {
            return bad("an intent label is out of range");
        }
        if settings.epochs == 0 || settings.batch == 0 {
            return bad("epochs and batch must be positive");
        }
        let (mean, std) = column_stats(x, width);
        let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
        let mut shapes = vec![];
        let mut inputs = width;
        for &h in &settings.hidden {
            shapes.push((inputs, h));
            inputs = h;
        }
        shapes.push((inputs, objects + 2));
        let layers = Layers::with_shapes(&shapes, |_| None, &mut rng)?;
        let net = IntentClassifier { layers, mean, std, objects };
        let params = ParamsAdamW { lr: settings.learning_rate, weight_decay: 0.0, ..ParamsAdamW::default() };
        let mut optimizer = AdamW::new(net.layers.vars(), params).map_err(candle)?;
        let mut order: Vec<usize> = (0..x.len()).collect();
        for _ in 0..settings.epochs {
            shuffle(&mut order, &mut rng);
            for rows in order.chunks(settings.batch) {
                let input = net.input(rows.iter().map(|&i| x[i].as_slice()))?;
                let object: Vec<u32> = rows.iter().map(|&i| labels[i].0 as u32).collect();
                let direction: Vec<u32> = rows.iter().map(|&i| labels[i].1 as u32).collect();
                let loss = net.loss(&input, &object, &direction).map_err(candle)?;
                optimizer.backward_step(&loss).map_err(candle)?;
            }
        }
        Ok(net)
    }

    fn loss(&self, input: &Tensor, object: &[u32], direction: &[u32]) -> Result<Tensor, candle_core::Error> {
        let logits = self.layers.forward(input)?;
        let n = object.len();
        let o = Tensor::from_slice(object, n, &Device::Cpu)?;
        let d = Tensor::from_slice(direction, n, &Device::Cpu)?;
        let lo = candle_nn::loss::cross_entropy(&logits.narrow(1, 0, self.objects)?, &o)?;
        let ld = candle_nn::loss::cross_entropy(&logits.narrow(1, self.objects, 2)?, &d)?;
        lo + ld
    }

    fn input<'a>(&self, rows: impl Iterator<Item = &'a [f32]>) -> Result<Tensor, LearnError> {
        let mut flat = vec![];
        let mut n = 0;
        for row in rows {
            flat.extend(row.iter().zip(&self.mean).zip(&self.std).map(|((v, m), s)| (v - m) / s));
            n += 1;
        }
        Tensor::from_vec(flat, (n, self.mean.len()), &Device::Cpu).map_err(candle)
    }

    /// Number of feature columns.
    pub fn inputs(&self) -> usize {
        self.mean.len()
    }

    /// The logits of every row: `(object logits, direction logits)`.
    ///
    /// # Errors
    /// Rows whose width differs from the training rows', candle errors.
    pub fn scores(&self, x: &[Vec<f32>]) -> Result<Vec<IntentLogits>, LearnError> {
        if x.iter().any(|r| r.len() != self.inputs()) {
            return Err(LearnError::Training(format!("intent features must have {} columns", self.inputs())));
        }
        if x.is_empty() {
            return Ok(vec![]);
        }
        let input = self.input(x.iter().map(Vec::as_slice))?;
        let logits = self.layers.forward(&input).map_err(candle)?.to_vec2::<f32>().map_err(candle)?;
        Ok(logits
            .into_iter()
            .map(|mut row| {
                let direction = row.split_off(self.objects);
                (row, direction)
            })
            .collect())
    }

    /// The most likely `(object, direction)` of every row.
    ///
    /// # Errors
    /// Rows whose width differs from the training rows', candle errors.
    pub fn predict(&self, x: &[Vec<f32>]) -> Result<Vec<(usize, usize)>, LearnError> {
        let argmax = |v: &[f32]| {
            v.iter().enumerate().fold((0, f32::NEG_INFINITY), |b, (i, &x)| if x > b.1 { (i, x) } else { b }).0
        };
        Ok(self.scores(x)?.iter().map(|(o, d)| (argmax(o), argmax(d))).collect())
    }
}

/// Mean and standard deviation (at least 1e-6) of each column.
fn column_stats(x: &[Vec<f32>], width: usize) -> (Vec<f32>, Vec<f32>) {
    let n = x.len() as f64;
    let mut mean = vec![0.0f64; width];
    let mut sq = vec![0.0f64; width];
    for r in x {
        for (j, &v) in r.iter().enumerate() {
            mean[j] += f64::from(v) / n;
        }
    }
    for r in x {
        for (j, &v) in r.iter().enumerate() {
            sq[j] += (f64::from(v) - mean[j]).powi(2) / n;
        }
    }
    (mean.iter().map(|&m| m as f32).collect(), sq.iter().map(|&s| (s.sqrt().max(1e-6)) as f32).collect())
}
