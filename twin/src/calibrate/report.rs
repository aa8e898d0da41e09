//! What `rom calibrate` writes: the report (calibration and leave-one-out) and the calibrated
//! configuration.

use fom::DriveConfig;
use rom::Surrogate;
use serde::Serialize;

use super::calibrate;
use super::options::{FreeSet, Target};
use super::predictive::{leave_one_out, leave_one_out_text, LeftOut};
use super::result::Calibration;
use crate::error::Result;

/// The calibrated configuration as TOML: the surrogate's configuration with the fitted friction
/// and installation tension; the distances and the slip offset (not model inputs) as comments.
pub fn calibrated_config_toml(
    cfg: &DriveConfig,
    c: &Calibration,
    labels: &[String],
) -> Result<String> {
    let out = c.design_point(cfg.center_distance_m()).apply(cfg)?;
    let mut head = String::from("# Calibrated by `rom calibrate` (beltwin).\n");
    for (l, d) in labels.iter().zip(&c.distances_m) {
        head += &format!("# condition {l}: centre distance {d:.5} m\n");
    }
    head += &format!(
        "# slip offset (speed-ratio correction) {:+.4} % : add it to the model's slip to compare \
         with the measurements\n",
        c.slip_offset_pct
    );
    Ok(head + &out.to_toml_string())
}

/// What `rom calibrate` reports (`--format json`; Python's `beltwin.calibrate`): the
/// calibration and, when asked, the leave-one-out predictions.
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationReport {
    pub calibration: Calibration,
    pub leave_one_out: Option<Vec<LeftOut>>,
}

impl CalibrationReport {
    /// Calibrates (`calibrate`) and, with `leave_one_out`, predicts each condition from the
    /// others (`leave_one_out`); with `confirm`, at most `predictive_runs` full-order runs
    /// stand in for each predictive's draws where the surrogate is not trusted.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        s: &Surrogate,
        cfg: &DriveConfig,
        targets: &[Target],
        free: FreeSet,
        tolerance_pct: f64,
        confirm: bool,
        leave_one_out: bool,
        predictive_runs: usize,
    ) -> Result<Self> {
        let calibration = calibrate(s, cfg, targets, free, tolerance_pct, confirm)?;
        let leave_one_out = if leave_one_out {
            Some(self::leave_one_out(
                s,
                cfg,
                targets,
                free,
                tolerance_pct,
                if confirm { predictive_runs } else { 0 },
            )?)
        } else {
            None
        };
        Ok(Self {
            calibration,
            leave_one_out,
        })
    }

    /// The report as text (the calibration, then the leave-one-out table when run).
    pub fn to_text(&self) -> String {
        let mut text = self.calibration.to_text() + "\n";
        if let Some(rows) = &self.leave_one_out {
            text += &leave_one_out_text(rows);
        }
        text
    }
}
