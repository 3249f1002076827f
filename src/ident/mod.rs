//! Identification: estimating actuator model parameters from measurements
//! (Isermann & Raab 1993, "Identification"; see `../shared/PAPERS.md`).
//!
//! | file | job |
//! |---|---|
//! | [`ls`] | batch least squares by QR, with covariance, confidence intervals, condition |
//! | [`rls`] | recursive least squares with forgetting, covariance form, wind-up guard |
//! | [`dsfi`] | square-root information-form recursive LS (DSFI), robust over long runs |
//! | [`recursive`] | the common step report (estimator eigenvalue `z = 1 - ψᵀγ`) and trait |
//! | [`direction`] | direction-dependent ARX models from samples of monotone motion |
//! | [`svf`] | state-variable filters: filtered signals and their derivatives |
//! | [`output_error`] | output-error estimation by Levenberg–Marquardt with bounds |
//! | [`metrics`] | fit %, NRMSE, RMSE, AIC/BIC, correlation tests of residuals |
//! | [`stats`] | t, F and χ² distributions, F-test and likelihood-ratio test |
//!
//! Everything here is sans-I/O and deterministic. The recursive pieces used in the control
//! cycle ([`Rls`], [`Dsfi`], [`DirectionalRegressor`], [`StateVariableFilter`]) allocate in their
//! constructors only; their `step`/`push` methods do not allocate. Units are SI; the parameters
//! carry whatever units the regressors imply.

pub mod direction;
pub mod dsfi;
pub mod error;
pub mod ls;
pub mod metrics;
pub mod output_error;
pub mod recursive;
pub mod rls;
pub mod stats;
pub mod svf;

#[cfg(test)]
pub(crate) mod testutil;

pub use direction::{
    arx_regressor, fit_directional, monotone_direction, split_by_direction, ArxOrder,
    ArxParameters, Direction, DirectionData, DirectionalData, DirectionalFit, DirectionalRegressor,
    DirectionalSelection,
};
pub use dsfi::{Dsfi, DsfiConfig};
pub use error::IdentError;
pub use ls::{
    least_squares, least_squares_rotated, least_squares_with, ColumnFactor, LsFit, LsOptions,
};
pub use metrics::{
    aic, aicc, autocorrelation, bic, billings_voon, correlation_bound_95, cross_correlation,
    fit_percent, ljung_box, nrmse, rmse, Correlation, NonlinearCorrelationTests,
};
pub use output_error::{
    minimize, minimize_with_progress, Bounds, FiniteDifference, Fit, LmOptions, LmProgress,
    Termination,
};
pub use recursive::{RecursiveEstimator, RecursiveUpdate};
pub use rls::{CovarianceGuard, Rls, RlsConfig};
pub use stats::{f_test_nested, likelihood_ratio_test, NestedTest};
pub use svf::StateVariableFilter;
