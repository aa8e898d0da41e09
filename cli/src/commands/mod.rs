//! One module per command: read the arguments, call the libraries, print and write.

pub mod calibrate;
pub mod diagnose;
pub mod gap;
pub mod predict;
pub mod simulate;
pub mod train;
pub mod validate;

use std::path::Path;

use fom::{DriveConfig, ValidConfig};
use rom::{ModelFile, SurrogateFile};

/// What a command returns on failure: any library error, shown by `main`.
pub type CommandResult = Result<(), Box<dyn std::error::Error>>;

/// The drive configuration of `--config`, or the shipped default drive.
pub fn drive_config(path: Option<&Path>) -> Result<ValidConfig, fom::FomError> {
    match path {
        Some(p) => DriveConfig::from_file(p),
        None => Ok(ValidConfig::default_hvac()),
    }
}

/// Loads `--model` (default: the shipped slip surrogate, embedded: `rom::shipped`) for a
/// command that needs the slip kind, and the configuration it is used with: `--config`,
/// checked against the surrogate's training configuration, or its own.
pub fn load_model(
    model: Option<&Path>,
    config: Option<&Path>,
) -> Result<(SurrogateFile, ValidConfig), Box<dyn std::error::Error>> {
    let file = match model {
        Some(p) => ModelFile::load(p)?.into_slip(&p.display().to_string())?,
        None => rom::shipped::slip_model()?,
    };
    let cfg = file.drive_config(config)?;
    Ok((file, cfg))
}

/// Sets the worker threads of the global pool (`--threads`).
pub fn set_threads(threads: Option<usize>) -> Result<(), String> {
    if let Some(t) = threads {
        if t == 0 {
            return Err("--threads must be at least 1".into());
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| format!("--threads {t}: {e}"))?;
    }
    Ok(())
}
