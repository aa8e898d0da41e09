//! Errors of the full-order model. Each names what is wrong and where.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum FomError {
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
    #[error("invalid configuration ({origin}): {message}")]
    Config { origin: String, message: String },
    #[error("impossible geometry: {0}")]
    Geometry(String),
    #[error("numerical step: {0}")]
    Step(String),
    #[error("numerical failure at t = {time_s:.6} s: {message}")]
    Numerical { time_s: f64, message: String },
    /// The caller asked the run to stop (`RunOptions::stop`), e.g. Ctrl-C in Python.
    #[error("interrupted at t = {time_s:.3} s")]
    Interrupted { time_s: f64 },
}

/// Result of the full-order model's operations.
pub type Result<T> = std::result::Result<T, FomError>;
