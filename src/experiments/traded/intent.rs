//! Grasp-intent features and predictors (§7.3.2 of the dissertation).
//!
//! Each tracker frame becomes the dissertation's eight features: the distances
//! from the palm to each of the three objects (m), the x of the palm position
//! (world, m), the x of the hand direction, the x and y of the palm normal,
//! and the rotation about y (pitch, rad). Two predictors map a frame to
//! `(object, direction)`:
//!
//! * [`IntentPredictor::Network`]: the candle classifier of
//!   [`grasp_intent`](crate::learn::grasp_intent), trained on synthesized
//!   demonstrations ([`train_intent_classifier`]);
//! * [`IntentPredictor::Posterior`]: the Bayesian goal posterior of
//!   [`IntentEstimator`] over the six palm grasp positions (three objects ×
//!   top/side), a baseline that sees only the palm path.
//!
//! Objects already picked are masked out of both.
//!
//! ```no_run
//! use tandem::experiments::traded::{HandUser, IntentPredictor, train_intent_classifier};
//! let objects = [[0.5, -0.2, 0.06], [0.55, 0.0, 0.06], [0.5, 0.2, 0.06]];
//! let net = train_intent_classifier(&objects, 60, 1)?;
//! let predictor = IntentPredictor::Network(net);
//! # Ok::<(), tandem::learn::LearnError>(())
//! ```

use super::hand::{Demonstration, GraspDirection, HandSample, HandUser, grasp_position, synthesize_reach};
use crate::arbitration::{IntentEstimator, IntentSettings};
use crate::learn::LearnError;
use crate::learn::grasp_intent::{IntentClassifier, IntentTrainSettings};

/// Number of features per frame with three objects.
pub const INTENT_FEATURES: usize = 8;

/// The dissertation's features of one frame (`objects`: object centres, world, m).
pub fn intent_features(sample: &HandSample, objects: &[[f64; 3]]) -> Vec<f32> {
    let p = sample.position;
    let mut f: Vec<f32> = objects
        .iter()
        .map(|o| ((p[0] - o[0]).powi(2) + (p[1] - o[1]).powi(2) + (p[2] - o[2]).powi(2)).sqrt() as f32)
        .collect();
    f.extend(
        [p[0], sample.direction[0], sample.palm_normal[0], sample.palm_normal[1], sample.rpy[1]].map(|v| v as f32),
    );
    f
}

/// A per-frame intent predictor.
#[derive(Debug)]
pub enum IntentPredictor {
    /// The trained classifier.
    Network(IntentClassifier),
    /// The Bayesian goal posterior over palm grasp positions.
    Posterior(IntentSettings),
}

impl IntentPredictor {
    /// Name as in the tables.
    pub fn as_str(&self) -> &'static str {
        match self {
            IntentPredictor::Network(_) => "network",
            IntentPredictor::Posterior(_) => "posterior",
        }
    }

    /// The predicted `(object, direction)` at every frame of `demo`, only
    /// among the objects with `available[i]` true (all when none is).
    ///
    /// # Errors
    /// Candle errors of the classifier.
    pub fn predict(
        &self,
        demo: &Demonstration,
        objects: &[[f64; 3]],
        available: &[bool],
    ) -> Result<Vec<(usize, GraspDirection)>, LearnError> {
        let allowed = |o: usize| available.get(o).copied().unwrap_or(false) || !available.iter().any(|&a| a);
        let to_dir = |d: usize| if d == 0 { GraspDirection::Top } else { GraspDirection::Side };
        match self {
            IntentPredictor::Network(net) => {
                let x: Vec<Vec<f32>> = demo.samples.iter().map(|s| intent_features(s, objects)).collect();
                let scores = net.scores(&x)?;
                Ok(scores
                    .iter()
                    .map(|(o, d)| {
                        let best = argmax_where(o, &allowed);
                        (best, to_dir(argmax_where(d, &|_| true)))
                    })
                    .collect())
            }
            IntentPredictor::Posterior(settings) => {
                let goals: Vec<[f64; 3]> = (0..objects.len())
                    .flat_map(|o| GraspDirection::ALL.map(|d| grasp_position(objects[o], d).into()))
                    .collect();
                let mut estimator = IntentEstimator::new(&goals, *settings);
                let prior: Vec<f64> = (0..goals.len()).map(|g| if allowed(g / 2) { 1.0 } else { 1e-9 }).collect();
                estimator.set_prior(&prior);
                let dt = 1.0 / super::hand::HAND_RATE;
                Ok(demo
                    .samples
                    .iter()
                    .map(|s| {
                        let b = estimator.observe(s.position, dt);
                        let g = argmax_where(&b.iter().map(|&v| v as f32).collect::<Vec<_>>(), &|g| allowed(g / 2));
                        (g / 2, to_dir(g % 2))
                    })
                    .collect())
            }
        }
    }
}

fn argmax_where(values: &[f32], allowed: &dyn Fn(usize) -> bool) -> usize {
    let mut best = (0, f32::NEG_INFINITY);
    for (i, &v) in values.iter().enumerate() {
        if allowed(i) && v > best.1 {
            best = (i, v);
        }
    }
    best.0
}

/// Trains the classifier on `per_class` synthesized demonstrations of each
/// (object, direction) pair, a third each by the Normal, Noisy and Biased
/// users, every frame a training row; seeded by `seed`.
///
/// # Errors
/// Candle errors.
pub fn train_intent_classifier(
    objects: &[[f64; 3]],
    per_class: usize,
    seed: u64,
) -> Result<IntentClassifier, LearnError> {
    let (mut x, mut labels) = (vec![], vec![]);
    let mut k = 0u64;
    for o in 0..objects.len() {
        for d in GraspDirection::ALL {
            for i in 0..per_class {
                let user = HandUser::ALL[i % 3];
                k += 1;
                let demo = synthesize_reach(objects, o, d, user, seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ k);
                // Every third frame: neighbouring frames are nearly equal.
                for s in demo.samples.iter().step_by(3) {
                    x.push(intent_features(s, objects));
                    labels.push((o, d.index()));
                }
            }
        }
    }
    let settings = IntentTrainSettings { seed, ..IntentTrainSettings::default() };
    IntentClassifier::train(&x, &labels, objects.len(), &settings)
}
