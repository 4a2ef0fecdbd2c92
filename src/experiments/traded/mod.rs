//! Traded control from predicted intent (the dissertation's chapter 7): the
//! operator mimics reaching for an object with their hand, a predictor names
//! the object and the grasp direction (top or side), and the robot plans and
//! executes the grasp on its own — early (as soon as the prediction
//! settles), late (after the demonstration) or continuously (re-planning
//! whenever the prediction changes).
//!
//! * [`hand`](self::synthesize_reach): the synthesized hand demonstrations
//!   (§7.5.6) and the Normal, Noisy and Biased users;
//! * intent: the dissertation's eight features, the candle classifier and the
//!   Bayesian goal posterior as predictors (§7.3.2);
//! * robot: the three-box scene and the IK → RRT-Connect → shortcut plan;
//! * episode: the commit rule and the three planning modes (§7.3.1);
//! * experiment: Table 7.3 and Fig. 7.9.
//!
//! Object poses are inputs: the dissertation's perception (Mask R-CNN, DBOT)
//! is out of scope.
//!
//! ```no_run
//! use tandem::experiments::traded::{TradedExperimentSettings, run_traded_experiment};
//! let results = run_traded_experiment(&TradedExperimentSettings::default(), &|| {})?;
//! println!("{} rows", results.rows.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod episode;
mod experiment;
mod hand;
mod intent;
mod robot;

pub use episode::{PickRecord, PlanningMode, TradedEpisode, TradedSettings, commit, run_traded_episode};
pub use experiment::{
    AccuracyCurve, CURVE_BINS, PredictorKind, TradedExperimentSettings, TradedResults, TradedRow, accuracy_curve,
    run_traded_experiment,
};
pub use hand::{
    Demonstration, GraspDirection, HAND_RATE, HAND_REST, HandSample, HandUser, grasp_orientation, grasp_position,
    minimum_jerk, synthesize_reach,
};
pub use intent::{INTENT_FEATURES, IntentPredictor, intent_features, train_intent_classifier};
pub use robot::{GRIPPER_SECONDS, JOINT_SPEED, PlannedGrasp, TradedError, TradedScene};
