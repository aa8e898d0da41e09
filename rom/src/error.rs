//! Errors of the surrogate crate.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum RomError {
    #[error(transparent)]
    Fom(#[from] fom::FomError),
    #[error(transparent)]
    Training(#[from] training::TrainingError),
    #[error("fitting the surrogate: {0}")]
    Fit(String),
    /// A Gaussian process or the reconstruction failed at prediction time.
    #[error("{0}")]
    Predict(String),
    /// A request outside what the surrogate was trained on (range or looseness).
    #[error("{reason}")]
    Extrapolation { reason: String },
    /// A request parameter out of its domain; `name` is the library's name for it.
    #[error("{name} {message}")]
    InvalidArgument { name: &'static str, message: String },
    #[error("surrogate file {0}")]
    Model(String),
    #[error("{0}")]
    Data(String),
}

/// Result of the surrogate crate's operations.
pub type Result<T> = std::result::Result<T, RomError>;
