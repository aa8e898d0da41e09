//! beltwin reduced-order model: POD + Gaussian-process surrogate of the full-order belt drive.
//!
//! `snapshots` turns full-order runs into the two outputs (start-up slip series, steady slip
//! quantile function); `pod` reduces them (thin SVD, faer); `features` computes the physics-based
//! input (traction capacity); `gp` fits one Gaussian process per coefficient (egobox-gp);
//! `surrogate` is the fitted object; `model_file` its versioned file; `predict` the
//! friction-uncertain slip distribution; `validate` the comparison with fresh full-order runs;
//! `plot` the box plots; `physical` the physical domain of a request; `tooth` the tooth-load surrogate of a toothed belt; `shipped` the
//! two shipped models, embedded, and `info` what a model file is (its manifest entry). The crate speaks `fom::DesignPoint` and never a command-line flag.

pub mod error;
pub mod features;
pub mod gp;
pub mod info;
pub mod inputs;
pub mod kind;
pub mod model_file;
pub mod physical;
pub mod plot;
pub mod pod;
pub mod predict;
pub mod refine;
pub mod shipped;
pub mod snapshots;
pub mod stats;
pub mod surrogate;
pub mod tooth;
pub mod validate;

pub use error::{Input, Result, RomError};
pub use kind::{Kind, ModelFile};
pub use model_file::SurrogateFile;
pub use predict::{predict_distribution, Distribution};
pub use surrogate::Surrogate;
