//! Results on disk and on screen: run CSV, tension profile CSV, summary statistics.
//! Files are written to a temporary sibling and renamed, so no partial file is ever left
//! (`crate::output_files`, docs/decisions/output-files.md).

use crate::error::FomError;
use std::io::Write;
use std::path::Path;

pub use crate::output_files::{check_output_path, write_atomic, OutputSet};

/// One output row: means over the output interval ending at `time_s`. `Default` is the
/// all-zero row (tests build rows from a few fields).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OutputRow {
    pub time_s: f64,
    pub driver_rpm: f64,
    pub driven_rpm: f64,
    /// Paper eq. 1, %; NaN while the driver is (nearly) at rest.
    pub slip_pct: f64,
    /// Axial force of the element nearest the middle of the span entering the driver, N.
    pub tight_span_tension_n: f64,
    /// Same for the span leaving the driver, N.
    pub slack_span_tension_n: f64,
    /// Torque supplied to the driver shaft (motor, or what a prescribed-speed drive needs), N m.
    pub driver_torque_nm: f64,
    /// Load torque braking the driven shaft, N m.
    pub driven_torque_nm: f64,
}

// The configuration's memory limit counts rows of this size (`config::limits`).
const _: () = assert!(std::mem::size_of::<OutputRow>() == crate::config::limits::OUTPUT_ROW_BYTES);

impl OutputRow {
    /// The row's values in the order of `OUTPUT_COLUMNS`.
    pub fn values(&self) -> [f64; 8] {
        [
            self.time_s,
            self.driver_rpm,
            self.driven_rpm,
            self.slip_pct,
            self.tight_span_tension_n,
            self.slack_span_tension_n,
            self.driver_torque_nm,
            self.driven_torque_nm,
        ]
    }
}

/// Column names of `OutputRow` in CSV order.
pub const OUTPUT_COLUMNS: [&str; 8] = [
    "time_s",
    "driver_rpm",
    "driven_rpm",
    "slip_pct",
    "tight_span_tension_n",
    "slack_span_tension_n",
    "driver_torque_nm",
    "driven_torque_nm",
];

/// Steady-state statistics of a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunSummary {
    /// Simulated time, s (shorter than the configured duration when the run stopped settled).
    pub simulated_s: f64,
    /// The run's settling by the one steady-state definition (`crate::steady`); when unsettled
    /// the statistics below are over the last minimum window and must not be taken as steady.
    pub settling: crate::steady::Settling,
    /// Start of the window the statistics are over, s.
    pub steady_start_s: f64,
    pub steady_rows: usize,
    pub mean_slip_pct: f64,
    pub std_slip_pct: f64,
    pub p05_slip_pct: f64,
    pub p50_slip_pct: f64,
    pub p95_slip_pct: f64,
    pub mean_driver_rpm: f64,
    pub mean_driven_rpm: f64,
    pub mean_tight_tension_n: f64,
    pub mean_slack_tension_n: f64,
    pub mean_driver_torque_nm: f64,
    pub mean_driven_torque_nm: f64,
    pub max_penetration_m: f64,
    pub wall_time_s: f64,
    pub real_time_factor: f64,
    pub energy: EnergyBalance,
}

/// Energy balance over the steady window: input = load + dissipated + change of stored energy.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct EnergyBalance {
    /// Work done by the drive, J.
    pub input_j: f64,
    /// Work absorbed by the load, J.
    pub load_j: f64,
    /// Work dissipated by friction, contact and belt damping and bearings, J.
    pub dissipated_j: f64,
    /// Change of kinetic, elastic and gravitational energy, J.
    pub stored_change_j: f64,
}

/// Energy-balance residual beyond which a run is flagged, %: converged runs close within
/// 0.5 % (`docs/validation/fom.md`, "Against closed-form mechanics"); a larger residual has marked
/// a numerical artefact (the default step near the limit on a low-tension drive: -8.5 % at 1e-5 s,
/// -0.03 % at 5e-6 s).
pub const ENERGY_RESIDUAL_FLAG_PCT: f64 = 2.0;

impl EnergyBalance {
    /// Whether the balance is off by more than `ENERGY_RESIDUAL_FLAG_PCT`.
    pub fn is_off(&self) -> bool {
        let r = self.residual_pct();
        r.is_nan() || r.abs() > ENERGY_RESIDUAL_FLAG_PCT
    }

    /// (input - load - dissipated - stored change) / input, %.
    pub fn residual_pct(&self) -> f64 {
        100.0 * (self.input_j - self.load_j - self.dissipated_j - self.stored_change_j)
            / self.input_j
    }
}

/// Why a finished run cannot stand as a steady data point (`RunSummary::steady_data`).
#[derive(Debug, Clone, PartialEq)]
pub enum Unusable {
    /// Not settled within the longest run (`crate::steady`).
    Unsettled(String),
    /// Settled, but the energy balance is off (`ENERGY_RESIDUAL_FLAG_PCT`).
    Unbalanced(String),
}

impl Unusable {
    /// The status word a campaign records: `unsettled` or `unbalanced`.
    pub fn status(&self) -> &'static str {
        match self {
            Unusable::Unsettled(_) => "unsettled",
            Unusable::Unbalanced(_) => "unbalanced",
        }
    }
}

impl std::fmt::Display for Unusable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unusable::Unsettled(m) | Unusable::Unbalanced(m) => f.write_str(m),
        }
    }
}

impl RunSummary {
    /// Standard error of the steady mean slip, percentage points (`steady::DriftTest::
    /// mean_se_pp`); `None` when the run did not settle.
    pub fn mean_slip_se_pp(&self) -> Option<f64> {
        self.settling.window().map(|w| w.mean_se_pp)
    }

    /// One line on the run's settling.
    pub fn settling_text(&self) -> String {
        match &self.settling {
            crate::steady::Settling::Settled { window } => format!(
                "settled            steady from {:.2} s (drift {:+.4} pp, within {:.4} pp); \
                 standard error of the mean slip {:.4} pp",
                window.start_s, window.drift_pp, window.tolerance_pp, window.mean_se_pp
            ),
            crate::steady::Settling::Unsettled { reason, .. } => {
                format!("UNSETTLED          {reason}; the statistics below are not steady")
            }
        }
    }

    /// Whether the run can stand as a steady data point (training, validation, a twin's
    /// confirmation): settled, and with an energy balance that closes. Returns the start of
    /// the steady window, s, or why not.
    pub fn steady_data(&self) -> Result<f64, Unusable> {
        match &self.settling {
            crate::steady::Settling::Unsettled { reason, .. } => Err(Unusable::Unsettled(format!(
                "did not settle in {:.1} s: {reason}",
                self.simulated_s
            ))),
            crate::steady::Settling::Settled { window } => match self.energy_warning() {
                Some(w) => Err(Unusable::Unbalanced(w)),
                None => Ok(window.start_s),
            },
        }
    }

    /// A warning when the energy balance does not close, else `None`.
    pub fn energy_warning(&self) -> Option<String> {
        self.energy.is_off().then(|| {
            format!(
                "ENERGY BALANCE OFF by {:.2} % over the steady window (converged runs close within \
                 0.5 %): the results are likely a numerical artefact; rerun with a smaller \
                 simulation.step_s",
                self.energy.residual_pct()
            )
        })
    }

    /// Human-readable summary.
    pub fn to_text(&self) -> String {
        format!(
            "{}{}\n\
             steady window      t > {:.3} s ({} rows, simulated {:.3} s)\n\
             slip (paper eq. 1) mean {:.4} %  std {:.4} %  p05 {:.4} %  p50 {:.4} %  p95 {:.4} %\n\
             speeds             driver {:.1} rpm  driven {:.1} rpm\n\
             span tensions      tight {:.1} N  slack {:.1} N\n\
             torques            driver {:.3} N m  driven (load) {:.3} N m\n\
             largest penetration {:.3e} m\n\
             energy (steady)    input {:.1} J = load {:.1} J + dissipated {:.1} J + stored {:.2} J \
             (residual {:.2} %)\n\
             wall time          {:.2} s  (real-time factor {:.2})",
            self.settling_text(),
            self.energy_warning()
                .map_or(String::new(), |w| format!("\n{w}")),
            self.steady_start_s,
            self.steady_rows,
            self.simulated_s,
            self.mean_slip_pct,
            self.std_slip_pct,
            self.p05_slip_pct,
            self.p50_slip_pct,
            self.p95_slip_pct,
            self.mean_driver_rpm,
            self.mean_driven_rpm,
            self.mean_tight_tension_n,
            self.mean_slack_tension_n,
            self.mean_driver_torque_nm,
            self.mean_driven_torque_nm,
            self.max_penetration_m,
            self.energy.input_j,
            self.energy.load_j,
            self.energy.dissipated_j,
            self.energy.stored_change_j,
            self.energy.residual_pct(),
            self.wall_time_s,
            self.real_time_factor
        )
    }
}

/// Whether `name` is one of `write_atomic`'s temporary files (`.NAME.PID-CALL-NANOS.tmp`).
fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(".tmp")
}

/// Removes the temporary files `write_atomic` leaves in `dir` when its process is killed
/// between create and rename. Call only while no other writer can be active in `dir` (a
/// campaign's exclusive lock). Returns how many were removed.
pub fn remove_stale_temporaries(dir: &Path) -> std::io::Result<usize> {
    let mut removed = 0;
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        if entry.file_type()?.is_file() && is_temporary(&entry.file_name().to_string_lossy()) {
            std::fs::remove_file(entry.path())?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Writes the run time series as CSV (columns `OUTPUT_COLUMNS`).
pub fn write_run_csv(path: &Path, rows: &[OutputRow]) -> Result<(), FomError> {
    write_atomic(path, |w| run_csv(w, rows))
}

/// The run time series as CSV (columns `OUTPUT_COLUMNS`) into `w`.
pub fn run_csv(w: &mut dyn Write, rows: &[OutputRow]) -> std::io::Result<()> {
    {
        writeln!(w, "{}", OUTPUT_COLUMNS.join(","))?;
        for r in rows {
            writeln!(
                w,
                "{:.6},{:.4},{:.4},{},{:.3},{:.3},{:.5},{:.5}",
                r.time_s,
                r.driver_rpm,
                r.driven_rpm,
                if r.slip_pct.is_finite() {
                    format!("{:.5}", r.slip_pct)
                } else {
                    String::new()
                },
                r.tight_span_tension_n,
                r.slack_span_tension_n,
                r.driver_torque_nm,
                r.driven_torque_nm
            )?;
        }
        Ok(())
    }
}

/// Writes the axial force along the belt as CSV `arc_length_m,axial_force_n`.
pub fn write_tension_profile_csv(path: &Path, profile: &[(f64, f64)]) -> Result<(), FomError> {
    write_atomic(path, |w| tension_profile_csv(w, profile))
}

/// The axial force along the belt as CSV `arc_length_m,axial_force_n` into `w`.
pub fn tension_profile_csv(w: &mut dyn Write, profile: &[(f64, f64)]) -> std::io::Result<()> {
    {
        writeln!(w, "arc_length_m,axial_force_n")?;
        for (s, f) in profile {
            writeln!(w, "{s:.6},{f:.4}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        let r = write_atomic(&path, |w| {
            writeln!(w, "partial")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn stale_temporaries_are_recognised_and_removed() {
        let dir = tempfile::tempdir().unwrap();
        // What a killed write_atomic leaves, and a name it must not touch.
        let tmp = dir
            .path()
            .join(format!(".drive.toml.{}-0-123.tmp", std::process::id()));
        std::fs::write(&tmp, "partial").unwrap();
        std::fs::write(dir.path().join("keep.tmp"), "user's").unwrap();
        write_atomic(&dir.path().join("drive.toml"), |w| writeln!(w, "x")).unwrap();
        assert_eq!(remove_stale_temporaries(dir.path()).unwrap(), 1);
        let mut left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["drive.toml", "keep.tmp"]);
    }
}
