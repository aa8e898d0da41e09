//! One module per command: read the arguments, call the libraries, print and write.

pub mod calibrate;
pub mod diagnose;
pub mod gap;
pub mod predict;
pub mod simulate;
pub mod train;
pub mod validate;

use std::path::{Path, PathBuf};

use fom::{DriveConfig, ValidConfig};
use rom::model_file::SHIPPED_MODEL_PATH as SHIPPED_MODEL;
use rom::SurrogateFile;

/// What a command returns on failure: any library error, shown by `main`.
pub type CommandResult = Result<(), Box<dyn std::error::Error>>;

/// The drive configuration of `--config`, or the shipped default drive.
pub fn drive_config(path: Option<&Path>) -> Result<ValidConfig, fom::FomError> {
    match path {
        Some(p) => DriveConfig::from_file(p),
        None => Ok(ValidConfig::default_hvac()),
    }
}

/// Where the shipped surrogate is: the workspace the executable was built in (it sits in
/// `<workspace>/target/<profile>/`), else the current directory or one of its parents.
pub fn shipped_model() -> Result<PathBuf, String> {
    shipped_file(SHIPPED_MODEL)
}

/// The shipped file at `relative` (to the workspace root), found as [`shipped_model`] finds
/// the shipped surrogate.
pub fn shipped_file(relative: &str) -> Result<PathBuf, String> {
    let exe_dir = std::env::current_exe()
        .ok()
        .and_then(|p| p.parent().map(Path::to_path_buf));
    let cwd = std::env::current_dir().ok();
    let candidates = exe_dir
        .iter()
        .chain(cwd.iter())
        .flat_map(|d| d.ancestors().map(Path::to_path_buf).collect::<Vec<_>>());
    for dir in candidates {
        let p = dir.join(relative);
        if p.is_file() {
            return Ok(p);
        }
    }
    Err(format!(
        "no surrogate given and the shipped one ({relative}) was not found beside the \
         executable or above the current directory; pass --model FILE"
    ))
}

/// Loads `--model` (default: the shipped surrogate) and the configuration it is used with:
/// `--config`, checked against the surrogate's training configuration, or its own.
pub fn load_model(
    model: Option<&Path>,
    config: Option<&Path>,
) -> Result<(SurrogateFile, ValidConfig), Box<dyn std::error::Error>> {
    let path = match model {
        Some(p) => p.to_path_buf(),
        None => shipped_model()?,
    };
    let file = SurrogateFile::load(&path)?;
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
