//! beltwin as FMI 2.0 co-simulation FMUs (docs/decisions/fmi-version.md): the slip surrogate
//! (`rom predict`'s answer at the FMU's inputs) and the full-order model (`rom simulate`'s step
//! inside `fmi2DoStep`).
//!
//! Built twice from one source: as a `cdylib`, the FMU's binary (`ffi`: the FMI C functions
//! over an `instance`); as an `rlib`, the packing `rom export-fmu` calls (`package`, which
//! writes the model description of `description` from the variable table of `variables`, the
//! same table the binary maps value references with).

pub mod description;
pub mod ffi;
pub mod fom_slave;
pub mod instance;
pub mod package;
pub mod surrogate;
pub mod variables;

pub use package::{read_binary, write_fmu, FmuKind, Packed};
