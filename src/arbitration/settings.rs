//! Everything an [`Arbiter`](super::Arbiter) can be told: [`ArbiterSettings`]
//! and the settings of its stages, each checked by its own `validate()`
//! beside its type (the stages' own settings live with their stage:
//! [`MetricSettings`], [`IntentSettings`], [`ModeSettings`],
//! [`SafetySettings`]).

use super::intent::IntentSettings;
use super::metric::MetricSettings;
use super::modes::{ArbitrationMode, ModeSettings};
use super::safety::SafetySettings;
use crate::settings::{InvalidSetting, non_negative, positive};
use tandem_solvers::conic::ConicSettings;

/// Damped least squares for task commands near singularities (Nakamura's
/// variable damping, per singular direction): a direction of the task
/// Jacobian whose singular value `σ` is below `threshold` is damped by
/// `max_damping² · (1 − (σ/threshold)²)`; `floor` regularises the null
/// space. Only the directions losing rank slow down: the arm keeps moving
/// where it can, and the tick says so (`TickStatus::SingularityDamped`).
///
/// ```
/// # use tandem::arbitration::DampingSettings;
/// let d = DampingSettings::default();
/// assert_eq!((d.threshold, d.max_damping, d.floor, d.null_space_weight), (0.03, 0.05, 1e-6, 0.01));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampingSettings {
    /// σ_min below which damping grows (m/rad).
    pub threshold: f64,
    /// Largest damping factor (m/rad).
    pub max_damping: f64,
    /// Damping always present, regularising the null space.
    pub floor: f64,
    /// Weight of joint-space deviation from the operator's command against
    /// task-space deviation when a constraint binds (m²/rad²): the command
    /// gives way in the null space first.
    pub null_space_weight: f64,
}

impl Default for DampingSettings {
    fn default() -> Self {
        DampingSettings { threshold: 0.03, max_damping: 0.05, floor: 1e-6, null_space_weight: 0.01 }
    }
}

impl DampingSettings {
    /// Checks every setting: a threshold and damping finite and at least
    /// 0, a floor finite and at least 0, a null-space weight above 0.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        non_negative("threshold", self.threshold, "m/rad")?;
        non_negative("max_damping", self.max_damping, "m/rad")?;
        non_negative("floor", self.floor, "")?;
        positive("null_space_weight", self.null_space_weight, "m²/rad²")
    }
}

/// Which solver handles the QP modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SolverBackend {
    /// A dense Goldfarb–Idnani dual active-set method for the QP modes
    /// (exact up to rounding, allocation-free), Clarabel for `Constrained`'s
    /// cone and whenever the active set cannot finish (dependent active
    /// rows, a step limit).
    #[default]
    ActiveSet,
    /// Clarabel's interior point method (every mode).
    Clarabel,
    /// OSQP (QP modes; `Constrained` still uses Clarabel). Needs the `osqp`
    /// cargo feature.
    #[cfg(feature = "osqp")]
    Osqp,
}

/// Everything an [`Arbiter`](super::Arbiter) can be told. The defaults:
/// direct control (choose a mode), 15 Hz as the dissertation's loop, the
/// exact active-set solver, the closed form first.
///
/// ```
/// # use tandem::arbitration::{ArbiterSettings, ArbitrationMode, SolverBackend};
/// let s = ArbiterSettings::default();
/// assert_eq!((s.mode, s.backend, s.closed_form_first), (ArbitrationMode::DirectControl, SolverBackend::ActiveSet, true));
/// assert_eq!(s.period, 1.0 / 15.0);
/// assert!(s.validate().is_ok());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArbiterSettings {
    /// The mode new workspaces start in.
    pub mode: ArbitrationMode,
    /// Control period `dt` (s).
    pub period: f64,
    /// The metrics' settings.
    pub metric: MetricSettings,
    /// The goal posterior's settings.
    pub intent: IntentSettings,
    /// The modes' settings.
    pub modes: ModeSettings,
    /// The hard constraints' settings.
    pub safety: SafetySettings,
    /// Damped least squares of task commands.
    pub damping: DampingSettings,
    /// Tolerance and iteration limit of the solver.
    pub solver: ConicSettings,
    /// Which solver solves the QP modes.
    pub backend: SolverBackend,
    /// Skip the solver when the mode's closed form meets every constraint
    /// (it is then the optimum of the convex problem).
    pub closed_form_first: bool,
}

impl Default for ArbiterSettings {
    fn default() -> Self {
        ArbiterSettings {
            mode: ArbitrationMode::default(),
            // The dissertation's 15 Hz.
            period: 1.0 / 15.0,
            metric: MetricSettings::default(),
            intent: IntentSettings::default(),
            modes: ModeSettings::default(),
            safety: SafetySettings::default(),
            damping: DampingSettings::default(),
            solver: ConicSettings::default(),
            backend: SolverBackend::default(),
            closed_form_first: true,
        }
    }
}

impl ArbiterSettings {
    /// Checks the period and every stage's settings; a setting out of
    /// range is named by its path (`safety.margin`).
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        positive("period", self.period, "s")?;
        self.metric.validate().map_err(|e| e.within("metric"))?;
        self.intent.validate().map_err(|e| e.within("intent"))?;
        self.modes.validate().map_err(|e| e.within("modes"))?;
        self.safety.validate().map_err(|e| e.within("safety"))?;
        self.damping.validate().map_err(|e| e.within("damping"))
    }
}
