//! beltwin training campaigns: a Latin-hypercube design over centre distance, friction and
//! installation tension (`design`), run through the full-order model in parallel and stored on
//! disk (`campaign`, `dataset`), resumable and shardable over a cluster's job array.

pub mod campaign;
pub mod cluster;
pub mod dataset;
pub mod design;
pub mod settings;

pub use campaign::{
    add_points, merge, point_config, prepare, progress, run_campaign, CampaignReport, Event,
    Progress, Shard,
};
pub use dataset::{config_hash, Dataset, PointRecord, SeriesRow};
pub use design::{latin_hypercube, latin_hypercube_about};
pub use settings::{
    CampaignSettings, DesignRanges, ToothRanges, MAX_DESIGN_SAMPLES, MIN_FIT_SAMPLES,
};

use thiserror::Error;

/// Result of the training crate's operations.
pub type Result<T> = std::result::Result<T, TrainingError>;

#[derive(Debug, Error)]
pub enum TrainingError {
    #[error("invalid campaign settings: {0}")]
    Settings(String),
    #[error(transparent)]
    Fom(#[from] fom::FomError),
    #[error("{path}: {message}")]
    Data { path: String, message: String },
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Mismatch(String),
    #[error("{0}")]
    Incomplete(String),
    /// Another process holds the campaign directory's lock.
    #[error("{0}")]
    Busy(String),
    /// The cluster's scheduler refused or failed a submission.
    #[error("{0}")]
    Cluster(String),
}
