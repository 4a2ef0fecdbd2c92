//! Settings out of range, one error shape in every module: which setting
//! (its path, `safety.margin`), the value given, and what it must be.

/// A setting outside its range.
///
/// ```
/// use tandem::arbitration::ArbiterSettings;
/// let mut settings = ArbiterSettings::default();
/// settings.safety.margin = -0.01;
/// let e = settings.validate().unwrap_err();
/// assert_eq!((e.field.as_str(), e.value.as_str()), ("safety.margin", "-0.01"));
/// assert_eq!(e.to_string(), "safety.margin must be finite and at least 0 m, got -0.01");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field} must be {expected}, got {value}")]
pub struct InvalidSetting {
    /// The setting's path within the settings validated (`metric.step`),
    /// or the option that gave it (`--threads`).
    pub field: String,
    /// The value given, as text.
    pub value: String,
    /// What it must be (`finite and above 0 s`, `1 … 1024`).
    pub expected: String,
}

impl InvalidSetting {
    /// `field` = `value` is not `expected`.
    pub fn new(field: impl Into<String>, value: impl std::fmt::Display, expected: impl Into<String>) -> Self {
        InvalidSetting { field: field.into(), value: value.to_string(), expected: expected.into() }
    }

    /// A number out of range, written readably (`1e300`, not 301 digits).
    pub fn number(field: impl Into<String>, value: f64, expected: impl Into<String>) -> Self {
        InvalidSetting { field: field.into(), value: readable(value), expected: expected.into() }
    }

    /// The same setting seen from the settings holding it: `step` of
    /// `metric` becomes `metric.step`.
    pub fn within(mut self, parent: &str) -> Self {
        self.field = format!("{parent}.{}", self.field);
        self
    }
}

/// `Ok` when `ok`, else [`InvalidSetting::number`].
pub(crate) fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<(), InvalidSetting> {
    if ok { Ok(()) } else { Err(InvalidSetting::number(field, value, expected)) }
}

/// Finite and above 0, in `unit`.
pub(crate) fn positive(field: &str, value: f64, unit: &str) -> Result<(), InvalidSetting> {
    let expected =
        if unit.is_empty() { "finite and above 0".to_string() } else { format!("finite and above 0 {unit}") };
    check(field, value, value.is_finite() && value > 0.0, &expected)
}

/// Finite and at least 0, in `unit`.
pub(crate) fn non_negative(field: &str, value: f64, unit: &str) -> Result<(), InvalidSetting> {
    let expected =
        if unit.is_empty() { "finite and at least 0".to_string() } else { format!("finite and at least 0 {unit}") };
    check(field, value, value.is_finite() && value >= 0.0, &expected)
}

/// `value` in plain notation when that is short, else in scientific
/// notation: error messages quoting 1e-300 would print 300 zeros.
pub(crate) fn readable(value: f64) -> String {
    if value == 0.0 || !value.is_finite() || (1e-5..1e7).contains(&value.abs()) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}
