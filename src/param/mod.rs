//! Parameters of the algorithms: the error every constructor returns for a value it cannot be
//! built from (a named parameter and the rule it breaks, so the runtime can say which
//! configuration key is wrong), and the checks that produce it. The lowest layer: control and
//! supervision both build on it.

/// A configuration value an algorithm cannot be built from.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name}: {reason}")]
pub struct ParamError {
    /// The parameter's field name (the configuration key it comes from).
    pub name: &'static str,
    /// What is wrong with it, with the value.
    pub reason: String,
}

impl ParamError {
    /// An error for `name`.
    pub fn new(name: &'static str, reason: impl Into<String>) -> Self {
        Self {
            name,
            reason: reason.into(),
        }
    }
}

/// `x` must be finite and > 0.
pub fn positive(name: &'static str, x: f64) -> Result<f64, ParamError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(ParamError::new(
            name,
            format!("must be finite and > 0, got {x}"),
        ))
    }
}

/// `x` must be finite and >= 0.
pub fn non_negative(name: &'static str, x: f64) -> Result<f64, ParamError> {
    if x.is_finite() && x >= 0.0 {
        Ok(x)
    } else {
        Err(ParamError::new(
            name,
            format!("must be finite and >= 0, got {x}"),
        ))
    }
}

/// `x` must be finite.
pub fn finite(name: &'static str, x: f64) -> Result<f64, ParamError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(ParamError::new(name, format!("must be finite, got {x}")))
    }
}

/// `lo < hi`, both finite.
pub fn range(name: &'static str, lo: f64, hi: f64) -> Result<(f64, f64), ParamError> {
    if lo.is_finite() && hi.is_finite() && lo < hi {
        Ok((lo, hi))
    } else {
        Err(ParamError::new(
            name,
            format!("needs min < max, got [{lo}, {hi}]"),
        ))
    }
}

/// Persistence in cycles for a time, at least one cycle.
pub fn cycles(time_s: f64, period_s: f64) -> u32 {
    ((time_s / period_s).round() as u32).max(1)
}

mod choice;
mod declare;

pub use declare::{
    same, Access, Declared, Kind, ParamSpec, ParamValue, COMMAND_PER_M_UNIT, COMMAND_UNIT,
    FORCE_PER_COMMAND_UNIT,
};
