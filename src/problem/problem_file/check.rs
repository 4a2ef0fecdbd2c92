//! The range checks of a problem file's values, each naming the key it
//! rejects.

use crate::problem::toml_source::KeyPath;
use crate::problem::{ProblemError, Source};
use crate::settings::readable;

/// Range checks that name the key.
pub(crate) struct Check<'a, 'b> {
    pub(super) src: &'a Source<'b>,
}

impl Check<'_, '_> {
    pub(super) fn positive(&self, path: &KeyPath, v: f64) -> Result<f64, ProblemError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.src.error(path, format!("must be positive, got {}", readable(v))))
        }
    }

    pub(super) fn non_negative(&self, path: &KeyPath, v: f64) -> Result<f64, ProblemError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.src.error(path, format!("must be zero or positive, got {v}")))
        }
    }

    pub(super) fn finite(&self, path: &KeyPath, v: &[f64]) -> Result<(), ProblemError> {
        match v.iter().position(|x| !x.is_finite()) {
            Some(i) => Err(self.src.error(&path.index(i), format!("must be finite, got {}", v[i]))),
            None => Ok(()),
        }
    }
}

/// The index of axis name `x`, `y` or `z`.
pub(super) fn axis_index(name: &str) -> Option<usize> {
    ["x", "y", "z"].iter().position(|a| *a == name)
}
