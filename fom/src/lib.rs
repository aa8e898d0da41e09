//! beltwin full-order model: a planar finite-segment belt drive.
//!
//! The belt is a closed chain of rigid segments joined by Timoshenko beam-force elements
//! (`belt`), in penalty contact with rigid pulleys with regularised Coulomb friction
//! (`contact`); a motor or a speed profile drives one pulley, a load brakes the other
//! (`drive`, `pulley`). `integrator` advances the state; `simulation` runs a drive from static
//! equilibrium and records it; `output` writes results.

pub mod belt;
pub mod config;
pub mod contact;
pub mod drive;
pub mod error;
pub mod geometry;
pub mod integrator;
pub mod model;
pub mod output;
pub mod pulley;
pub mod simulation;

pub use config::{DriveConfig, Overrides};
pub use error::FomError;
pub use model::Model;
pub use simulation::{simulate, OutputRow, RunOptions, RunResult};
