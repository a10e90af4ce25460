//! A validation case, its verdict and its result.

use crate::compat::validate::stats::{Statistics, Value};
use crate::error::Result;

/// The verdict of a case.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    Pass,
    Fail,
    /// Reported, not tested (see the case's note).
    Informational,
}

impl Verdict {
    pub fn label(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "FAIL",
            Verdict::Informational => "info",
        }
    }
}

/// A validation case: a reference table and how atmosim reproduces it.
#[derive(Debug, Clone, Copy)]
pub struct Case {
    /// Name on the command line, e.g. `iprt_a2`.
    pub name: &'static str,
    pub title: &'static str,
    /// The reference and its file in `validation/`.
    pub reference: &'static str,
    /// The geometry and settings atmosim runs, and why.
    pub setup: &'static str,
    /// The reference's accuracy floor in the z test and its justification.
    pub floor: &'static str,
    /// Paths per direction when none are asked for (sized for CI).
    pub default_samples: u64,
    /// Reported without a verdict.
    pub informational: bool,
    /// When set, the case also fails if a group's inverse-variance mean
    /// ratio ([`GroupRatio`](crate::compat::validate::stats::GroupRatio)) is farther than this from 1: a bias shared by
    /// a group's directions, each within its own noise.
    pub ratio_limit: Option<f64>,
    pub(super) run: fn(u64) -> Result<Vec<Value>>,
}

/// The result of one case.
#[derive(Debug, Clone)]
pub struct CaseResult {
    pub case: Case,
    pub samples: u64,
    pub values: Vec<Value>,
    pub stats: Statistics,
    pub verdict: Verdict,
    pub seconds: f64,
}
