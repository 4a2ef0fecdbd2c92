//! Command-line options of the arbiter's settings, shared by the commands
//! that run shared control.

use crate::arbitration::{ArbiterSettings, ModeSettings, SafetySettings};

/// The centres κ of sum-of-squares and of the constrained mode (default:
/// the dissertation's, 0).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct CenterArgs {
    /// κ of sum-of-squares, 0 to 10: prefer the step κ ā_R (the robot
    /// action) instead of standing still, `min ‖J u − v‖²_C + ‖u − κ
    /// ā_R‖²_W`. 0 is the dissertation's eq. 5.4; 0.5 made the Approach
    /// operator's grasps succeed in 94.7–97.9 % with either robot policy
    /// (docs/experiments.md).
    #[arg(long, default_value_t = 0.0, value_name = "KAPPA", value_parser = |s: &str| super::number_in(s, 0.0..=10.0))]
    pub sos_center: f64,
    /// κ of the constrained mode's trust-region centre κ ā_R, 0 to 10
    /// (0: the dissertation's eq. 5.3, centred on standing still).
    #[arg(long, default_value_t = 0.0, value_name = "KAPPA", value_parser = |s: &str| super::number_in(s, 0.0..=10.0))]
    pub constrained_center: f64,
}

impl CenterArgs {
    /// `modes` with these centres.
    pub fn apply(&self, modes: ModeSettings) -> ModeSettings {
        ModeSettings { sum_of_squares_center: self.sos_center, constrained_center: self.constrained_center, ..modes }
    }

    /// The default arbiter settings at `period` (s) with these centres.
    pub fn arbiter_settings(&self, period: f64) -> ArbiterSettings {
        let defaults = ArbiterSettings::default();
        ArbiterSettings { period, modes: self.apply(defaults.modes), ..defaults }
    }
}

/// Whether the robot's motion limits hold.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct MotionLimitArgs {
    /// Let commands change by any amount from one tick to the next and
    /// holds stop in one tick: the robot's acceleration, deceleration and
    /// jerk limits (`tandem inspect` lists them) are then only counted, not
    /// kept. For comparisons with tandem before 2026-12; a real arm's
    /// controller refuses such commands.
    #[arg(long)]
    pub no_motion_limits: bool,
}

impl MotionLimitArgs {
    /// `settings` with the motion limits as chosen.
    pub fn apply(&self, settings: ArbiterSettings) -> ArbiterSettings {
        ArbiterSettings {
            safety: SafetySettings { motion_limits: !self.no_motion_limits, ..settings.safety },
            ..settings
        }
    }
}
