//! One module per command: read the arguments, call the libraries, print and write.

pub mod calibrate;
pub mod diagnose;
pub mod export_fmu;
pub mod gap;
pub mod info;
pub mod predict;
pub mod serve;
pub mod simulate;
pub mod train;
pub mod validate;

use std::path::Path;

use fom::{DriveConfig, ValidConfig};
use rom::{ModelFile, SurrogateFile};

/// What a command returns on failure: any library error, shown by `main` (exit 1), or a
/// [`UsageError`] (clap's message, exit 2).
pub type CommandResult = Result<(), Box<dyn std::error::Error>>;

/// A usage error found after parsing (a flag the model requires left out): `main` shows it
/// through clap, with clap's exit code 2.
#[derive(Debug)]
pub struct UsageError {
    pub kind: clap::error::ErrorKind,
    pub message: String,
}

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for UsageError {}

/// Prints `text` to stdout, or the JSON of `value` (pretty, one object, nothing else on
/// stdout) when `format` asks for JSON.
pub fn print_report<T: serde::Serialize>(
    format: crate::args::ReportFormat,
    text: &str,
    value: &T,
) -> CommandResult {
    match format {
        crate::args::ReportFormat::Text => print!("{text}"),
        crate::args::ReportFormat::Json => println!("{}", serde_json::to_string_pretty(value)?),
    }
    Ok(())
}

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

/// Says on stderr which labels of `set` a command reading one load leaves out: those at
/// another load than its reference one (`rom gap` compares them through its load levels);
/// and, as `rom gap`'s verdict does, a given reference load far from `cfg`'s.
pub fn note_other_loads(set: &twin::measured::DataSet, cfg: &DriveConfig) {
    use twin::gap::load_levels::{reference_load_text, reference_note};
    if let Some(note) = reference_note(cfg, set, set.speed_ratio(cfg)) {
        eprintln!("note:{note}");
    }
    let others = set.other_load_labels();
    if !others.is_empty() {
        eprintln!(
            "note: left out at another load than the data set's reference load ({}): {} \
             (`rom gap` compares them through its load levels)",
            reference_load_text(set.reference_load_torque_nm()),
            others.join(", ")
        );
    }
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
