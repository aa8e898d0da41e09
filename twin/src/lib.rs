//! beltwin digital twin: what the model does with measurements.
//!
//! `measured` reads and writes the exchange format `belt-measurements/1` (docs/measured-data.md);
//! `sensor` turns a full-order run into a synthetic recording (pulse tachometers); `signal`
//! extracts the steady slip of a recording; `inference` holds the general machinery
//! (optimisation, Markov-chain sampling, the Gaussian likelihood with its model discrepancy);
//! `calibrate` updates the model to measured slip (seed paper Figure 1); `diagnose` infers
//! looseness from measured speeds; `report` writes what `diagnose` found.

pub mod calibrate;
pub mod data_files;
pub mod diagnose;
pub mod error;
pub mod gap;
pub mod inference;
pub mod measured;
pub mod report;
pub mod sensor;
pub mod settling;
pub mod signal;

pub use error::{Result, TwinError};
