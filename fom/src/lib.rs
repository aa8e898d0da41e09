//! beltwin full-order model: a planar finite-segment belt drive.
//!
//! The belt is a closed chain of rigid segments joined by Timoshenko beam-force elements
//! (`belt`), in penalty contact with rigid pulleys with regularised Coulomb friction
//! (`contact`); a motor or a speed profile drives one pulley, a load brakes the other
//! (`drive`, `pulley`). `integrator` advances the state (the one place where a step is
//! orchestrated); optional physics plugs into it through `effects`, what a belt kind adds to
//! the contact (the teeth of a toothed belt) through `belt_kind`. `simulation` runs a drive
//! from static equilibrium and records it; `output` writes results. `params` is the design
//! point every other crate speaks; `slip` the one definition of belt slip; `statics` the static
//! formulas (belt length, tension, shaft load) used without a model. `config` is a leaf: the
//! TOML tables and their one check into a `ValidConfig`.

pub mod belt;
pub mod belt_kind;
pub mod config;
pub mod contact;
pub mod drive;
pub mod effects;
pub mod error;
pub mod fastmath;
pub mod geometry;
pub mod integration_parameters;
pub mod integrator;
pub mod model;
pub mod output;
pub mod output_files;
pub mod params;
pub mod pulley;
pub mod readable;
pub mod simulation;
pub mod slip;
pub mod statics;
pub mod stats;
pub mod steady;

pub use config::{DriveConfig, ValidConfig};
pub use error::{FomError, Result};
pub use model::Model;
pub use output::OutputRow;
pub use params::DesignPoint;
pub use simulation::{simulate, RunOptions, RunResult};
