//! Typed errors shared by the identification algorithms.

use thiserror::Error;

/// Everything that can go wrong when estimating parameters.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum IdentError {
    /// Fewer samples than the estimate needs (at least one more than the parameters for a
    /// residual variance).
    #[error("too few samples: need at least {needed}, got {got}")]
    TooFewSamples {
        /// Samples required.
        needed: usize,
        /// Samples given.
        got: usize,
    },
    /// The regressor matrix does not have full column rank.
    #[error(
        "regressor matrix is rank deficient (numerical rank {rank} of {columns} columns); \
         column {column} is (nearly) a linear combination of the columns before it"
    )]
    RankDeficient {
        /// Zero-based index of the first column that is collinear with earlier columns.
        column: usize,
        /// Numerical rank.
        rank: usize,
        /// Number of columns.
        columns: usize,
    },
    /// Two inputs that must agree in length do not.
    #[error("dimension mismatch in {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A configuration value is out of its valid range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid, with the offending value.
        reason: String,
    },
    /// Data or an intermediate result is NaN or infinite.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// Where it appeared.
        what: &'static str,
    },
}

pub(crate) fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), IdentError> {
    if expected == got {
        Ok(())
    } else {
        Err(IdentError::DimensionMismatch {
            what,
            expected,
            got,
        })
    }
}

pub(crate) fn check_finite(what: &'static str, values: &[f64]) -> Result<(), IdentError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(IdentError::NonFinite { what })
    }
}
