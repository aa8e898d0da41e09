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
/// 0.5 % (README, "Validation"); a larger residual has marked a numerical artefact (the
/// default step near the limit on a low-tension drive: -8.5 % at 1e-5 s, -0.03 % at 5e-6 s).
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

/// Column names of the tooth-load CSV (`write_tooth_loads_csv`).
pub const TOOTH_LOAD_COLUMNS: [&str; 5] = ["time_s", "tooth", "flank_a_n", "flank_b_n", "tip_n"];

/// What a run of a toothed belt records of its teeth (`contact::tooth`).
#[derive(Debug, Clone, Default)]
pub struct ToothRecord {
    pub teeth: usize,
    /// End time of each output row, s.
    pub time_s: Vec<f64>,
    /// Normal load on flank a, flank b and the tip of every tooth, mean over each output
    /// interval, row by row (`time_s.len() x teeth`), N.
    pub loads_n: Vec<crate::contact::tooth::ToothLoads>,
    /// Angle of every tooth about the driver's and the driven shaft at the end of each row, in
    /// the fixed frame, NaN while the tooth is not in that pulley's wrap, rad.
    pub angle_rad: Vec<[f32; 2]>,
    /// Largest instantaneous load of each region (flank a, flank b, tip) over the run, N.
    pub max_n: crate::contact::tooth::ToothLoads,
    /// When each maximum occurred, s.
    pub max_time_s: [f64; 3],
    /// Start of the run's tooth-load window (`tooth_load_window_start_s` of the configuration
    /// that ran), s.
    pub window_start_s: f64,
}

/// A tooth's root load, N: the larger of its two flank loads (flank a or b, whichever the
/// drive loads; the tooth-root load of seed paper "arc-tooth-synchronous-belt-recurdyn",
/// Figure 8).
fn root_load_n(l: &crate::contact::tooth::ToothLoads) -> f64 {
    l[0].max(l[1])
}

impl ToothRecord {
    /// The largest instantaneous flank load of the run (its largest root load), N.
    pub fn max_flank_load_n(&self) -> f64 {
        root_load_n(&self.max_n)
    }

    /// Tooth `tooth`'s root load at row `r`, N.
    fn root_load_at_n(&self, r: usize, tooth: usize) -> f64 {
        root_load_n(&self.loads_n[r * self.teeth + tooth])
    }

    /// The seed paper's statistic (section IV: 0.3 s "and the step is 100", the maximum at a
    /// point of one tooth): for each tooth, the largest of its larger flank load sampled at
    /// `samples` equally spaced output times over the run, N (one value per tooth). Sampling
    /// at the paper's 100 output steps (3 ms) misses most impacts, which last well under 3 ms.
    pub fn sampled_max_per_tooth_n(&self, samples: usize) -> Vec<f64> {
        let rows = self.time_s.len();
        let Some(&end_s) = self.time_s.last() else {
            return Vec::new();
        };
        let at: Vec<usize> = (1..=samples)
            .map(|k| {
                let t = end_s * k as f64 / samples as f64;
                self.time_s
                    .partition_point(|&x| x < t - 1e-12)
                    .min(rows - 1)
            })
            .collect();
        (0..self.teeth)
            .map(|tooth| {
                at.iter()
                    .map(|&r| self.root_load_at_n(r, tooth))
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    /// The rows of every complete pass of tooth `tooth` through pulley `pulley`'s wrap (0
    /// driver, 1 driven): runs of rows in the wrap that neither begin at the first row nor end
    /// at the last.
    fn pass_rows(&self, tooth: usize, pulley: usize) -> Vec<std::ops::Range<usize>> {
        let rows = self.time_s.len();
        let at = |r: usize| self.angle_rad[r * self.teeth + tooth][pulley].is_finite();
        let mut passes = Vec::new();
        let mut r = 0;
        while r < rows {
            if !at(r) {
                r += 1;
                continue;
            }
            let start = r;
            while r < rows && at(r) {
                r += 1;
            }
            if start > 0 && r < rows {
                passes.push(start..r);
            }
        }
        passes
    }

    /// Angle turned since entering the wrap at the fixed-frame angle `entry_angle_rad`
    /// (counter-clockwise drive) at row `r`, degrees in [-90, 270): a tooth approaching the
    /// entry has a small negative angle.
    fn turned_deg(&self, r: usize, tooth: usize, pulley: usize, entry_angle_rad: f64) -> f64 {
        let tau = 2.0 * std::f64::consts::PI;
        let a = f64::from(self.angle_rad[r * self.teeth + tooth][pulley]);
        ((a - entry_angle_rad + 0.25 * tau).rem_euclid(tau) - 0.25 * tau).to_degrees()
    }

    /// Tooth `tooth`'s loads over its last complete pass through pulley `pulley`'s wrap:
    /// (time, angle turned since the entry at `entry_angle_rad`, loads) per row. Empty when the
    /// record holds no complete pass.
    pub fn last_pass(
        &self,
        tooth: usize,
        pulley: usize,
        entry_angle_rad: f64,
    ) -> Vec<(f64, f64, crate::contact::tooth::ToothLoads)> {
        self.pass_rows(tooth, pulley)
            .pop()
            .map(|rows| {
                rows.map(|r| {
                    (
                        self.time_s[r],
                        self.turned_deg(r, tooth, pulley, entry_angle_rad),
                        self.loads_n[r * self.teeth + tooth],
                    )
                })
                .collect()
            })
            .unwrap_or_default()
    }

    /// The tooth-root load's peak of every complete pass of a tooth through either pulley's
    /// wrap that begins after `after_s`, N: the larger flank load (flank a or b, whichever the
    /// drive loads), its largest row mean over the pass. The samples of a toothed run's
    /// maximum-tooth-load distribution (the tooth-load surrogate's snapshot). Their mean is
    /// the typical maximum tooth load of steady running: unlike the largest instantaneous load
    /// of a run, which one impact decides, it does not jump by 10-30 % with the resolution
    /// (README, "Toothed belt").
    pub fn root_load_pass_peaks_n(&self, after_s: f64) -> Vec<f64> {
        let mut peaks = Vec::new();
        for pulley in 0..2 {
            for tooth in 0..self.teeth {
                for rows in self.pass_rows(tooth, pulley) {
                    if self.time_s[rows.start] > after_s {
                        peaks.push(
                            rows.map(|r| self.root_load_at_n(r, tooth))
                                .fold(0.0, f64::max),
                        );
                    }
                }
            }
        }
        peaks
    }

    /// `root_load_pass_peaks_n` over the run's tooth-load window: the samples of its
    /// maximum-tooth-load distribution (training, validation and the figure alike).
    pub fn window_pass_peaks_n(&self) -> Vec<f64> {
        self.root_load_pass_peaks_n(self.window_start_s)
    }

    /// The loads of every tooth pass through pulley `pulley`'s wrap that begins after
    /// `after_s`, averaged in bins of `bin_deg` of the angle turned since the entry at
    /// `entry_angle_rad`: (bin centre in degrees, mean loads) for each bin with data.
    pub fn mean_pass_profile(
        &self,
        pulley: usize,
        entry_angle_rad: f64,
        after_s: f64,
        bin_deg: f64,
    ) -> Vec<(f64, crate::contact::tooth::ToothLoads)> {
        let mut bins: std::collections::BTreeMap<i64, ([f64; 3], usize)> = Default::default();
        for tooth in 0..self.teeth {
            for rows in self.pass_rows(tooth, pulley) {
                if self.time_s[rows.start] <= after_s {
                    continue;
                }
                for r in rows {
                    let a = self.turned_deg(r, tooth, pulley, entry_angle_rad);
                    let bin = bins.entry((a / bin_deg).floor() as i64).or_default();
                    let l = self.loads_n[r * self.teeth + tooth];
                    for (sum, v) in bin.0.iter_mut().zip(l) {
                        *sum += v;
                    }
                    bin.1 += 1;
                }
            }
        }
        bins.into_iter()
            .map(|(b, (sum, n))| {
                let inv = 1.0 / n as f64;
                (
                    (b as f64 + 0.5) * bin_deg,
                    [sum[0] * inv, sum[1] * inv, sum[2] * inv],
                )
            })
            .collect()
    }

    /// Summary lines for the run's text output.
    pub fn to_text(&self) -> String {
        format!(
            "max tooth load     flank a {:.2} N (t = {:.4} s), flank b {:.2} N (t = {:.4} s), \
             tip {:.2} N (t = {:.4} s)",
            self.max_n[0],
            self.max_time_s[0],
            self.max_n[1],
            self.max_time_s[1],
            self.max_n[2],
            self.max_time_s[2]
        )
    }
}

/// Start of a toothed run's tooth-load window, s: tooth passes that begin later make its
/// maximum-tooth-load distribution (`ToothRecord::root_load_pass_peaks_n`). The configuration's
/// `simulation.steady_start_s` when given; else halfway between the end of the start-up ramps
/// (the driver's speed profile and the driven load's torque profile) and the end of the run, so
/// the ramp's transient has as long again to decay (0.2 s on `fom/configs/synchronous-arc.toml`:
/// ramps end at 0.1 s, the run at 0.3 s, as the paper's Figure 8 shows the running after 0.2 s).
/// The one definition of the window, for `rom simulate`, training and the figure.
pub fn tooth_load_window_start_s(cfg: &crate::DriveConfig) -> f64 {
    if let Some(t) = cfg.simulation.steady_start_s {
        return t;
    }
    let speed_end = cfg
        .driver
        .speed_profile
        .as_ref()
        .and_then(|p| p.time_s.last().copied())
        .unwrap_or(0.0);
    let load_end = cfg
        .driven
        .load
        .as_ref()
        .and_then(|l| l.profile.as_ref())
        .map_or(0.0, |p| p.end_s());
    let ramp_end = speed_end.max(load_end).min(cfg.simulation.duration_s);
    ramp_end + 0.5 * (cfg.simulation.duration_s - ramp_end)
}

/// Writes the tooth loads as CSV (columns `TOOTH_LOAD_COLUMNS`), one line per output row and
/// tooth.
pub fn write_tooth_loads_csv(path: &Path, record: &ToothRecord) -> Result<(), FomError> {
    write_atomic(path, |w| tooth_loads_csv(w, record))
}

/// The tooth loads as CSV (`write_tooth_loads_csv`) into `w`.
pub fn tooth_loads_csv(w: &mut dyn Write, record: &ToothRecord) -> std::io::Result<()> {
    {
        writeln!(w, "{}", TOOTH_LOAD_COLUMNS.join(","))?;
        for (r, t) in record.time_s.iter().enumerate() {
            for tooth in 0..record.teeth {
                let l = record.loads_n[r * record.teeth + tooth];
                writeln!(w, "{t:.6},{tooth},{:.4},{:.4},{:.4}", l[0], l[1], l[2])?;
            }
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

    /// Two teeth over 10 rows; tooth 0 has an impact between the sampled rows, tooth 1 a
    /// flank-b load on a sampled row, and the pass peaks see whole passes through a wrap.
    #[test]
    fn sampled_maxima_and_pass_peaks_of_a_tooth_record() {
        let rows = 10;
        let time_s: Vec<f64> = (1..=rows).map(|r| r as f64 * 0.01).collect();
        let mut loads_n = vec![[0.0; 3]; rows * 2];
        let mut angle_rad = vec![[f32::NAN; 2]; rows * 2];
        loads_n[2 * 2] = [90.0, 0.0, 0.0]; // tooth 0, row 2 (t = 0.03 s): not sampled
        loads_n[4 * 2] = [10.0, 0.0, 0.0]; // tooth 0, row 4 (t = 0.05 s): sampled
        loads_n[9 * 2 + 1] = [1.0, 7.0, 50.0]; // tooth 1, row 9 (t = 0.1 s): flank b 7 N
                                               // Tooth 0 in the driver's wrap over rows 1-5: one complete pass.
        for r in 1..=5 {
            angle_rad[r * 2][0] = 0.1 * r as f32;
        }
        let rec = ToothRecord {
            teeth: 2,
            time_s,
            loads_n,
            angle_rad,
            ..ToothRecord::default()
        };
        // Two samples: t = 0.05 s (row 4) and 0.1 s (row 9).
        assert_eq!(rec.sampled_max_per_tooth_n(2), vec![10.0, 7.0]);
        assert_eq!(rec.sampled_max_per_tooth_n(10), vec![90.0, 7.0]);
        assert_eq!(rec.root_load_pass_peaks_n(0.0), vec![90.0]);
        // The pass begins at 0.02 s: a window from later holds none.
        assert!(rec.root_load_pass_peaks_n(0.02).is_empty());
    }

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
