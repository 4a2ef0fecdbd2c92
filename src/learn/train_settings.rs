//! How to train the policy network ([`TrainSettings`], [`LearnSettings`])
//! and what training reports ([`EpochLoss`], [`TrainReport`]).

use crate::settings::{InvalidSetting, non_negative, positive, readable};

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

/// What [`train_on`](super::train_on) needs beyond the training settings.
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
