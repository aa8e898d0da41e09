//! `rom gap`: the sim-to-real gap diagnosis.

use twin::gap::{gap, report, GapOptions};
use twin::{measured, signal};

use super::{load_model, set_threads, CommandResult};
use crate::args::{GapArgs, ReportFormat};
use crate::progress;

pub fn run(a: GapArgs) -> CommandResult {
    set_threads(a.threads)?;
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    let set = measured::read_dataset(&a.measured, signal::MIN_STEADY_SAMPLES)?;
    let opts = GapOptions {
        holdout: a.holdout.clone(),
        ..Default::default()
    };
    let working = progress::working(&format!(
        "diagnosing {} labels: calibration, then the twin's full-order runs at each",
        set.labels().len()
    ));
    let r = gap(&file.surrogate, &cfg, &set, &opts)?;
    working.finish_and_clear();
    if let Some(dir) = &a.report {
        report::write_gap_report(dir, &r)?;
    }
    match a.format {
        ReportFormat::Text => print!("{}", report::to_text(&r)),
        ReportFormat::Json => println!("{}", serde_json::to_string_pretty(&r)?),
    }
    Ok(())
}
