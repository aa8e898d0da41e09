//! The full-order model's word on a calibration (seed paper Figure 1: update, confirm): steady
//! mean slip at the fitted point, run as a training run of the surrogate is.

use fom::{DesignPoint, DriveConfig, RunOptions};
use rayon::prelude::*;
use rom::Surrogate;

use super::layout::Point;
use crate::error::{Result, TwinError};

/// Steady mean slip (%) of the full-order model at each fitted condition, without the offset.
pub(super) fn confirm_with_fom(s: &Surrogate, cfg: &DriveConfig, p: &Point) -> Result<Vec<f64>> {
    let points: Vec<DesignPoint> = p.design_points().collect();
    points.par_iter().map(|q| fom_slip_pct(s, cfg, q)).collect()
}

/// Steady mean slip (%) of the full-order model at `point`, run as a training run of `s` is
/// (until settled); an error when the run is no steady result.
pub(super) fn fom_slip_pct(s: &Surrogate, cfg: &DriveConfig, point: &DesignPoint) -> Result<f64> {
    let st = &s.settings;
    // A surrogate without a stiffness range was trained at the configuration's EA.
    let point = DesignPoint {
        axial_stiffness_n: point
            .axial_stiffness_n
            .filter(|_| st.axial_stiffness_n.is_some()),
        ..*point
    };
    let c = training::point_config(cfg, st, &point)?;
    let run = fom::simulate(&c, RunOptions::default())?;
    // Only a settled, energy-balanced run confirms (fom::output::RunSummary::steady_data).
    run.summary.steady_data().map_err(|why| {
        TwinError::Calibration(format!(
            "the full-order run at d = {:.5} m is no steady result: {why}",
            point.center_distance_m
        ))
    })?;
    Ok(run.summary.mean_slip_pct)
}
