//! The gap stage's errors: the diagnosis itself cannot be made (the model cannot be evaluated,
//! the residuals' covariance is not positive definite).

/// Errors of the diagnosis itself (the model cannot be evaluated).
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    #[error(transparent)]
    Model(#[from] crate::model::ParamError),
    #[error("the covariance of the residuals is not positive definite")]
    Covariance,
}
