//! Errors of the robust design chain.

/// Why a model, a synthesis or a controller file cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum RobustError {
    /// A matrix had the wrong shape for the operation.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// A linear system or inverse was singular.
    #[error("singular matrix in {0}")]
    Singular(&'static str),
    /// The Riccati equation has no stabilising solution (or it could not be computed).
    #[error("Riccati equation: {0}")]
    Riccati(String),
    /// No γ up to the search limit satisfies the H∞ existence conditions.
    #[error("H-infinity synthesis infeasible: {0}")]
    Infeasible(String),
    /// A plant parameter is missing or out of range for the design model.
    #[error("design model: {0}")]
    Model(String),
    /// A controller file is malformed.
    #[error("controller file {origin}: {what}")]
    ControllerFile { origin: String, what: String },
    /// The plant file could not be read or built.
    #[error(transparent)]
    Physics(#[from] crate::physics::PhysicsError),
    /// Reading or writing a file.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}
