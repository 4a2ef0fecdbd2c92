//! A policy network run through candle, as training runs it: the reference
//! the hand-written forward pass ([`PolicyNetwork::forward`], every compiled
//! variant) is checked against, and its timing peer in `benches/`.

use super::LearnError;
use super::layers::{Layers, candle};
use super::network::PolicyNetwork;
use candle_core::{Device, Tensor};
use rand::SeedableRng;

/// A [`PolicyNetwork`]'s layers as candle tensors, with its input
/// normalisation.
pub struct CandleNetwork {
    layers: Layers,
    mean: Vec<f32>,
    std: Vec<f32>,
}

impl CandleNetwork {
    /// The same weights, biases and normalisation as `network`.
    ///
    /// # Errors
    /// candle failing to build a tensor.
    pub fn new(network: &PolicyNetwork) -> Result<CandleNetwork, LearnError> {
        // Every layer is copied from `network`: the generator draws nothing.
        let mut unused = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let layers = Layers::with_shapes(&network.meta().layer_shapes(), |i| Some(network.layer(i)), &mut unused)?;
        let (mean, std) = network.normalisation();
        Ok(CandleNetwork { layers, mean, std })
    }

    /// The raw outputs (`dof + 1` per row) for unnormalised `inputs`, rows
    /// of the network's input width one after another.
    ///
    /// # Errors
    /// `inputs` not whole rows, or candle failing.
    pub fn forward(&self, inputs: &[f32]) -> Result<Vec<f32>, LearnError> {
        let d = self.mean.len();
        if d == 0 || !inputs.len().is_multiple_of(d) {
            return Err(LearnError::Metadata {
                path: "(in memory)".into(),
                message: format!("{} inputs are not whole rows of {d}", inputs.len()),
            });
        }
        let x: Vec<f32> = inputs
            .chunks_exact(d)
            .flat_map(|row| row.iter().zip(self.mean.iter().zip(&self.std)).map(|(v, (m, s))| (v - m) / s))
            .collect();
        let x = Tensor::from_vec(x, (inputs.len() / d, d), &Device::Cpu).map_err(candle)?;
        self.layers.forward(&x).and_then(|y| y.flatten_all()).and_then(|y| y.to_vec1::<f32>()).map_err(candle)
    }
}
