//! `rom diagnose`: belt looseness from measured speeds.

use twin::{diagnose, measured, report, signal};

use super::{load_model, CommandResult};
use crate::args::DiagnoseArgs;

pub fn run(a: DiagnoseArgs) -> CommandResult {
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    let set = measured::read_dataset(&a.measured, signal::MIN_STEADY_SAMPLES)?;
    let verdicts = diagnose::diagnose(&file.surrogate, &cfg, &set)?;
    if let Some(dir) = &a.report {
        report::write_diagnosis_report(dir, &verdicts)?;
    }
    print!("{}", report::to_text(&verdicts));
    Ok(())
}
