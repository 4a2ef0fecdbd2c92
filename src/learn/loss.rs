//! The training loss and the tensors it reads: pairs normalised for the
//! network, cut into minibatches, and the dissertation's loss (§3.3.3) — the
//! mean squared errors of the unit joint velocity and of its norm — with an
//! optional slope term that matches the network's directional derivatives
//! to the LQR tracking policy's (Sobolev training).
//!
//! **Slopes.** For a perturbed pair `q′` of a demonstrated state `q`, the
//! network's action change per unit distance `(a(q′) − a(q)) / ‖q′ − q‖` is
//! compared with the tracking policy's (stored in [`Pairs::slopes`]). The
//! arbiter's Hessian metric is read from these derivatives (eq. 5.5–5.6),
//! so the term teaches the network the metric the LQR policy gives, not
//! only its actions. Its mean squared error is divided by the mean squared
//! target, so weight 1 weighs a relative error of 1 like a direction error
//! of 1.

use super::LearnError;
use super::dataset::Pairs;
use super::layers::{Layers, candle};
use candle_core::{Device, Tensor};

/// One minibatch as tensors: normalised inputs, target directions, target
/// scaled speeds, direction weights, and the slopes of its perturbed rows.
pub(super) struct Batch {
    x: Tensor,
    direction: Tensor,
    speed: Tensor,
    weight: Tensor,
    slopes: Option<SlopeBatch>,
}

/// The perturbed rows of a minibatch: their positions in it, their
/// demonstrated states' inputs, target slopes (scaled speeds per rad) and
/// inverse distances.
struct SlopeBatch {
    at: Tensor,
    base: Tensor,
    target: Tensor,
    inverse_length: Tensor,
}

/// Normalised inputs and targets of a pair set, ready for minibatches.
pub(super) struct Prepared {
    d: usize,
    n: usize,
    x: Vec<f32>,
    direction: Vec<f32>,
    speed: Vec<f32>,
    weight: Vec<f32>,
    /// Per row, its slope's index + 1 (0: none).
    slope_of_row: Vec<u32>,
    slope_rows: Vec<[usize; 2]>,
    /// Slopes divided by the speed scale.
    slopes: Vec<f32>,
    slope_inverse_lengths: Vec<f32>,
}

impl Prepared {
    /// `pairs` normalised by `mean` and `std`, speeds and slopes divided by
    /// `speed_scale`, directions weighted down below `direction_speed`.
    pub(super) fn new(
        pairs: &Pairs,
        (mean, std): (&[f32], &[f32]),
        speed_scale: f64,
        direction_speed: f64,
    ) -> Prepared {
        let d = pairs.input_width;
        let x = pairs
            .inputs
            .chunks_exact(d)
            .flat_map(|row| row.iter().zip(mean.iter().zip(std)).map(|(v, (m, s))| (v - m) / s))
            .collect();
        let weight = pairs.speeds.iter().map(|s| (f64::from(*s) / direction_speed).min(1.0) as f32).collect();
        let speed = pairs.speeds.iter().map(|s| (f64::from(*s) / speed_scale) as f32).collect();
        let mut prepared = Prepared {
            d,
            n: pairs.dof,
            x,
            direction: pairs.directions.clone(),
            speed,
            weight,
            slope_of_row: vec![],
            slope_rows: vec![],
            slopes: vec![],
            slope_inverse_lengths: vec![],
        };
        if !pairs.slope_rows.is_empty() {
            prepared.slope_of_row = vec![0; pairs.len()];
            for (k, [row, _]) in pairs.slope_rows.iter().enumerate() {
                prepared.slope_of_row[*row] = k as u32 + 1;
            }
            prepared.slope_rows = pairs.slope_rows.clone();
            prepared.slopes = pairs.slopes.iter().map(|s| (f64::from(*s) / speed_scale) as f32).collect();
            prepared.slope_inverse_lengths = pairs.slope_inverse_lengths.clone();
        }
        prepared
    }

    pub(super) fn len(&self) -> usize {
        self.speed.len()
    }

    /// The mean squared norm of the (scaled) slopes: the slope term's
    /// unit (1 without slopes).
    pub(super) fn slope_scale(&self) -> f64 {
        let k = self.slope_rows.len();
        let sum: f64 = self.slopes.iter().map(|s| f64::from(*s).powi(2)).sum();
        if k == 0 || sum <= 0.0 { 1.0 } else { sum / k as f64 }
    }

    /// The minibatch of `rows`, with their slopes when `slopes` is set.
    pub(super) fn batch(&self, rows: &[usize], slopes: bool) -> Result<Batch, LearnError> {
        let (d, n, m) = (self.d, self.n, rows.len());
        let mut x = Vec::with_capacity(m * d);
        let mut direction = Vec::with_capacity(m * n);
        for &r in rows {
            x.extend_from_slice(&self.x[r * d..(r + 1) * d]);
            direction.extend_from_slice(&self.direction[r * n..(r + 1) * n]);
        }
        let speed: Vec<f32> = rows.iter().map(|&r| self.speed[r]).collect();
        let weight: Vec<f32> = rows.iter().map(|&r| self.weight[r]).collect();
        let dev = &Device::Cpu;
        Ok(Batch {
            x: Tensor::from_vec(x, (m, d), dev).map_err(candle)?,
            direction: Tensor::from_vec(direction, (m, n), dev).map_err(candle)?,
            speed: Tensor::from_vec(speed, (m, 1), dev).map_err(candle)?,
            weight: Tensor::from_vec(weight, (m, 1), dev).map_err(candle)?,
            slopes: if slopes { self.slope_batch(rows)? } else { None },
        })
    }

    fn slope_batch(&self, rows: &[usize]) -> Result<Option<SlopeBatch>, LearnError> {
        if self.slope_of_row.is_empty() {
            return Ok(None);
        }
        let (d, n) = (self.d, self.n);
        let (mut at, mut base, mut target, mut inverse_length) = (vec![], vec![], vec![], vec![]);
        for (i, &r) in rows.iter().enumerate() {
            let Some(k) = (self.slope_of_row[r] as usize).checked_sub(1) else { continue };
            let b = self.slope_rows[k][1];
            at.push(i as u32);
            base.extend_from_slice(&self.x[b * d..(b + 1) * d]);
            target.extend_from_slice(&self.slopes[k * n..(k + 1) * n]);
            inverse_length.push(self.slope_inverse_lengths[k]);
        }
        if at.is_empty() {
            return Ok(None);
        }
        let (k, dev) = (at.len(), &Device::Cpu);
        Ok(Some(SlopeBatch {
            at: Tensor::from_vec(at, k, dev).map_err(candle)?,
            base: Tensor::from_vec(base, (k, d), dev).map_err(candle)?,
            target: Tensor::from_vec(target, (k, n), dev).map_err(candle)?,
            inverse_length: Tensor::from_vec(inverse_length, (k, 1), dev).map_err(candle)?,
        }))
    }
}

/// The losses of a minibatch.
pub(super) struct Losses {
    /// Direction mean squared error, weighted by speed.
    pub direction: Tensor,
    /// Scaled speed mean squared error.
    pub speed: Tensor,
    /// Slope mean squared error over the mean squared target slope (`None`
    /// without perturbed rows or slope training).
    pub slope: Option<Tensor>,
}

/// The scaled action of raw outputs: the unit direction times the speed
/// (never negative), as a query reads them.
fn action(out: &Tensor, n: usize) -> Result<Tensor, candle_core::Error> {
    let direction = out.narrow(1, 0, n)?;
    let norm = (direction.sqr()?.sum_keepdim(1)? + 1e-12)?.sqrt()?;
    direction.broadcast_div(&norm)?.broadcast_mul(&out.narrow(1, n, 1)?.relu()?)
}

/// The losses of `batch`; the slope term in units of `slope_scale`.
pub(super) fn losses(layers: &Layers, batch: &Batch, n: usize, slope_scale: f64) -> Result<Losses, candle_core::Error> {
    let out = layers.forward(&batch.x)?;
    let direction = out.narrow(1, 0, n)?;
    let speed = out.narrow(1, n, 1)?;
    let direction_loss = (direction - &batch.direction)?.sqr()?.sum_keepdim(1)?.mul(&batch.weight)?.mean_all()?;
    let speed_loss = (speed - &batch.speed)?.sqr()?.mean_all()?;
    let slope = match &batch.slopes {
        None => None,
        Some(s) => {
            let perturbed = action(&out.index_select(&s.at, 0)?, n)?;
            let demonstrated = action(&layers.forward(&s.base)?, n)?;
            let slope = (perturbed - demonstrated)?.broadcast_mul(&s.inverse_length)?;
            Some(((slope - &s.target)?.sqr()?.sum_keepdim(1)?.mean_all()? / slope_scale)?)
        }
    };
    Ok(Losses { direction: direction_loss, speed: speed_loss, slope })
}

/// Input normalisation of `pairs`: per-feature mean and standard deviation
/// (1 for a feature that never varies).
pub fn normalisation(pairs: &Pairs) -> (Vec<f32>, Vec<f32>) {
    let d = pairs.input_width;
    let rows = pairs.len().max(1) as f64;
    let mut mean = vec![0.0f64; d];
    let mut square = vec![0.0f64; d];
    for row in pairs.inputs.chunks_exact(d) {
        for j in 0..d {
            mean[j] += f64::from(row[j]);
            square[j] += f64::from(row[j]).powi(2);
        }
    }
    let mean: Vec<f64> = mean.iter().map(|m| m / rows).collect();
    let std = square
        .iter()
        .zip(&mean)
        .map(|(s, m)| (s / rows - m * m).max(0.0).sqrt())
        .map(|s| if s > 1e-6 { s } else { 1.0 });
    (mean.iter().map(|m| *m as f32).collect(), std.map(|s| s as f32).collect())
}

/// Root mean square speed of `pairs` (rad/s): the output scale.
pub fn speed_scale(pairs: &Pairs) -> f64 {
    let rms = (pairs.speeds.iter().map(|s| f64::from(*s).powi(2)).sum::<f64>() / pairs.len().max(1) as f64).sqrt();
    if rms > 1e-9 { rms } else { 1.0 }
}

#[cfg(test)]
mod tests {
    use super::super::layers::tests::meta;
    use super::super::network::PolicyNetwork;
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

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
}
