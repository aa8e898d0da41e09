//! `rom diagnose`: belt looseness from measured speeds.

use twin::{diagnose, measured, report, signal};

use super::{load_model, print_report, CommandResult};
use crate::args::DiagnoseArgs;

pub fn run(a: DiagnoseArgs) -> CommandResult {
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    let set = measured::read_dataset(&a.measured, signal::MIN_STEADY_SAMPLES)?;
    super::note_other_loads(&set, &cfg);
    let verdicts = diagnose::diagnose(&file.surrogate, &cfg, &set)?;
    // A condition that cannot be diagnosed fails the command (exit 1, no report files): a
    // verdict missing from a report that exits 0 goes unnoticed in a script. The conditions
    // that could be diagnosed are still printed, each refused one in its row with the reason
    // (docs/reliability.md).
    let undiagnosable: Vec<String> = verdicts
        .iter()
        .filter_map(|v| {
            v.cannot_diagnose
                .as_ref()
                .map(|why| format!("condition {:?}: cannot diagnose: {why}", v.label))
        })
        .collect();
    if !undiagnosable.is_empty() {
        let shown = undiagnosable.len() < verdicts.len();
        if shown {
            print_report(a.format, &report::to_text(&verdicts), &verdicts)?;
        }
        return Err(format!(
            "{}: {} of {} conditions cannot be diagnosed{}:\n  {}",
            a.measured.display(),
            undiagnosable.len(),
            verdicts.len(),
            if shown {
                " (the others are printed)"
            } else {
                ""
            },
            undiagnosable.join("\n  ")
        )
        .into());
    }
    if let Some(dir) = &a.report {
        report::write_diagnosis_report(dir, &verdicts)?;
    }
    print_report(a.format, &report::to_text(&verdicts), &verdicts)
}
