//! Where the targets come from: a table of mean slips (the seed paper's Table 2) or a measured
//! data set (each label's steady mean slip and its standard error, `signal::measured_slip`).

use super::options::Target;
use crate::error::{Result, TwinError};
use crate::measured::DataSet;
use crate::signal::{measured_slip, Unsettled};

/// Reads a table of mean slips per condition (columns `condition`, `experiment_mean_slip_pct`;
/// `#` comments), such as the seed paper's Table 2; positions follow the row order.
pub fn read_slip_table(path: &std::path::Path) -> Result<Vec<Target>> {
    read_slip_table_inner(path).map_err(TwinError::Calibration)
}

fn read_slip_table_inner(path: &std::path::Path) -> std::result::Result<Vec<Target>, String> {
    let name = path.display();
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| format!("{name}: {e}"))?;
    let h = rd.headers().map_err(|e| format!("{name}: {e}"))?.clone();
    let col = |c: &str| {
        h.iter()
            .position(|x| x == c)
            .ok_or_else(|| format!("{name}: missing column `{c}`"))
    };
    let (ci, si) = (col("condition")?, col("experiment_mean_slip_pct")?);
    let mut out = Vec::new();
    for r in rd.records() {
        let r = r.map_err(|e| format!("{name}: {e}"))?;
        let line = r.position().map_or(0, |p| p.line());
        let v: f64 = r[si]
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v > 0.0)
            .ok_or_else(|| format!("{name}: line {line}: `{}` is not a positive slip", &r[si]))?;
        out.push(Target {
            label: r[ci].to_string(),
            mean_slip_pct: v,
            mean_se_pct: 0.0,
            known_center_distance_m: None,
            tension_reading: None,
            position: out.len() as f64,
        });
    }
    if out.is_empty() {
        return Err(format!("{name}: no conditions"));
    }
    Ok(out)
}

/// One target per label of a measured data set at its reference load
/// (`DataSet::split_by_load`): its steady mean slip and standard error (as `rom diagnose`
/// measures them) and the known distance of its first run.
pub fn targets_from_dataset(set: &DataSet, cfg: &fom::DriveConfig) -> Result<Vec<Target>> {
    // The surrogate runs at one load: labels at another are left to `rom gap`'s load levels.
    let set = &*set.at_reference_load();
    let ratio = set.speed_ratio(cfg);
    set.labels()
        .into_iter()
        .enumerate()
        .map(|(k, label)| {
            target_of_label(set, &label, k as f64, ratio).map_err(|e| {
                TwinError::Unusable(format!("condition {label}: cannot calibrate: {e}"))
            })
        })
        .collect()
}

/// The target of one label: its measured steady mean slip and standard error (R_t `ratio`),
/// the known distance of its first run, at `position` in the spacing of the conditions.
pub fn target_of_label(set: &DataSet, label: &str, position: f64, ratio: f64) -> Result<Target> {
    let ms = measured_slip(&set.recordings_of(label), ratio, Unsettled::Refuse)?;
    Ok(Target {
        known_center_distance_m: set.known_center_distance_m(label),
        tension_reading: set.tension_reading(label),
        label: label.to_string(),
        mean_slip_pct: ms.mean_pct,
        mean_se_pct: ms.mean_se_pct,
        position,
    })
}
