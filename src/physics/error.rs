//! Errors of the physics layer.

/// Everything that can go wrong while reading a plant description or a fault name.
#[derive(Debug, thiserror::Error)]
pub enum PhysicsError {
    /// The plant file could not be read.
    /// The I/O error is part of the message, not a separate cause, so that a chain printed with
    /// `{:#}` names it once.
    #[error("{origin}: cannot read: {error}")]
    Io {
        origin: String,
        error: std::io::Error,
    },
    /// The plant file is not valid TOML.
    #[error("{origin}: not valid TOML: {message}")]
    Toml { origin: String, message: String },
    /// A value breaks a rule, e.g. "[spring] stiffness_n_per_m must be > 0, got -3".
    #[error("{origin}: {}{key} {rule}", table_prefix(.table))]
    Invalid {
        origin: String,
        table: String,
        key: String,
        rule: String,
    },
    /// A name (family, effect, fault, parameter) that is not known.
    #[error("{origin}: unknown {what} \"{name}\"{hint}")]
    Unknown {
        origin: String,
        what: &'static str,
        name: String,
        hint: String,
    },
    /// A fault or schedule string that does not parse.
    #[error("cannot parse fault \"{text}\": {reason}")]
    FaultSyntax { text: String, reason: String },
    /// A parameter vector of the wrong length was given.
    #[error("parameter vector has {got} entries, the model has {expected} free parameters")]
    VectorLength { expected: usize, got: usize },
}

impl PhysicsError {
    pub(crate) fn invalid(origin: &str, table: &str, key: &str, rule: impl Into<String>) -> Self {
        PhysicsError::Invalid {
            origin: origin.to_string(),
            table: table.to_string(),
            key: key.to_string(),
            rule: rule.into(),
        }
    }
}

fn table_prefix(table: &str) -> String {
    if table.is_empty() {
        String::new()
    } else {
        format!("[{table}] ")
    }
}
