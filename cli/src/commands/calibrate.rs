//! `rom calibrate`: model updating to measured slip.

use twin::calibrate::{self, CalibrationReport, FreeSet, Target};

use super::{load_model, CommandResult};
use crate::args::{CalibrateArgs, ReportFormat};

pub fn run(a: CalibrateArgs) -> CommandResult {
    // The output path is checked before any work (docs/decisions/output-files.md).
    if let Some(out) = &a.out {
        fom::output::check_output_path(out, "--out")?;
    }
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    let targets: Vec<Target> = match (&a.measured, &a.table) {
        (_, Some(t)) => calibrate::read_slip_table(t)?,
        (Some(dir), None) => {
            let set = twin::measured::read_dataset(dir, twin::signal::MIN_STEADY_SAMPLES)?;
            super::note_other_loads(&set, &cfg);
            calibrate::targets_from_dataset(&set, &cfg)?
        }
        (None, None) => unreachable!("clap requires one"),
    };
    let free = a.free.unwrap_or_else(|| FreeSet::default_for(&targets));
    let r = CalibrationReport::run(
        &file.surrogate,
        &cfg,
        &targets,
        free,
        a.tolerance,
        !a.no_confirm,
        a.leave_one_out,
        a.predictive_runs,
    )?;
    let mut text = match a.format {
        ReportFormat::Text => r.to_text(),
        ReportFormat::Json => serde_json::to_string_pretty(&r)? + "\n",
    };
    if let Some(out) = &a.out {
        let labels: Vec<String> = targets.iter().map(|t| t.label.clone()).collect();
        let toml = calibrate::calibrated_config_toml(&cfg, &r.calibration, &labels)?;
        fom::output::write_atomic(out, |w| w.write_all(toml.as_bytes()))?;
        if a.format == ReportFormat::Text {
            text += &format!("wrote {}\n", out.display());
        }
    }
    print!("{text}");
    Ok(())
}
