//! beltwin reduced-order model: POD + Gaussian-process surrogate of the full-order belt drive.
//!
//! `snapshots` turns full-order runs into the two outputs (start-up slip series, steady slip
//! quantile function); `pod` reduces them (thin SVD, faer); `gp` fits one Gaussian process per
//! coefficient (egobox-gp); `surrogate` is the fitted object; `model_file` its versioned file;
//! `predict` the friction-uncertain slip distribution; `validate` the comparison with fresh
//! full-order runs; `plot` the box plots; `twin` measured data and the sensor model.

pub mod gp;
pub mod model_file;
pub mod plot;
pub mod pod;
pub mod predict;
pub mod snapshots;
pub mod surrogate;
pub mod twin;
pub mod validate;

pub use model_file::SurrogateFile;
pub use predict::{predict_distribution, Distribution};
pub use surrogate::{Query, Surrogate};

use thiserror::Error;

#[derive(Debug, Error)]
pub enum RomError {
    #[error(transparent)]
    Fom(#[from] fom::FomError),
    #[error(transparent)]
    Training(#[from] training::TrainingError),
    #[error("fitting the surrogate: {0}")]
    Fit(String),
    #[error("{0}")]
    Predict(String),
    #[error("{0}")]
    Extrapolation(String),
    #[error("surrogate file {0}")]
    Model(String),
    #[error("{0}")]
    Data(String),
}
