//! The context of validation: the job file's name, which every error about
//! a key names, and the range checks the resolvers share.

use crate::error::{Error, Result};

/// Validation context: the file name for every error.
pub(crate) struct Ctx<'a> {
    pub(crate) file: &'a str,
}

impl Ctx<'_> {
    pub(crate) fn invalid(&self, key: &str, value: impl std::fmt::Display, reason: &str, valid: &str) -> Error {
        Error::InvalidValue {
            file: self.file.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.to_string(),
            valid: valid.to_string(),
        }
    }

    /// A finite number within [lo, hi] (inclusive by the flags).
    pub(crate) fn range(&self, key: &str, v: f64, lo: f64, hi: f64, lo_open: bool, valid: &str) -> Result<f64> {
        let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && v <= hi;
        if ok {
            Ok(v)
        } else if !v.is_finite() {
            Err(self.invalid(key, v, "not a finite number", valid))
        } else {
            Err(self.invalid(key, v, "out of range", valid))
        }
    }
}
