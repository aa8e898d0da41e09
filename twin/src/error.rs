//! Errors of the twin crate.

use thiserror::Error;

use crate::measured::MeasuredError;

#[derive(Debug, Error)]
pub enum TwinError {
    /// Bad measured data: file, line and what is wrong.
    #[error(transparent)]
    Measured(#[from] MeasuredError),
    #[error(transparent)]
    Rom(#[from] rom::RomError),
    #[error(transparent)]
    Fom(#[from] fom::FomError),
    /// Data that are readable but cannot support the requested answer (the reason).
    #[error("{0}")]
    Unusable(String),
    #[error("{0}")]
    Calibration(String),
    /// The gap diagnosis cannot go on (the reason).
    #[error("{0}")]
    Gap(String),
    /// A request parameter out of its domain; `input` names it (`rom::Input`).
    #[error("{input} {message}")]
    InvalidArgument { input: rom::Input, message: String },
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
}

/// Result of the twin crate's operations.
pub type Result<T> = std::result::Result<T, TwinError>;
