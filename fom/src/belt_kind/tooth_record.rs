//! What a run of a toothed belt records of its teeth: the loads of every tooth over the run,
//! the tooth-load window its maximum-tooth-load distribution is taken over, and the CSV.
//! Recorded through the belt kind's recorder (`belt_kind::toothed`); the simulation does not
//! name it.

use std::path::Path;

use super::KindRecord;
use crate::contact::tooth::ToothLoads;
use crate::error::FomError;
use crate::output::write_atomic;

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
    pub loads_n: Vec<ToothLoads>,
    /// Angle of every tooth about the driver's and the driven shaft at the end of each row, in
    /// the fixed frame, NaN while the tooth is not in that pulley's wrap, rad.
    pub angle_rad: Vec<[f32; 2]>,
    /// Largest instantaneous load of each region (flank a, flank b, tip) over the run, N.
    pub max_n: ToothLoads,
    /// When each maximum occurred, s.
    pub max_time_s: [f64; 3],
    /// Start of the run's tooth-load window (`tooth_load_window_start_s` of the configuration
    /// that ran), s.
    pub window_start_s: f64,
}

/// A tooth's root load, N: the larger of its two flank loads (flank a or b, whichever the
/// drive loads; the tooth-root load of seed paper "arc-tooth-synchronous-belt-recurdyn",
/// Figure 8).
fn root_load_n(l: &ToothLoads) -> f64 {
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
    ) -> Vec<(f64, f64, ToothLoads)> {
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
    /// (`docs/validation/toothed-belt.md`, "What is not met").
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
    ) -> Vec<(f64, ToothLoads)> {
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
pub fn tooth_loads_csv(w: &mut dyn std::io::Write, record: &ToothRecord) -> std::io::Result<()> {
    writeln!(w, "{}", TOOTH_LOAD_COLUMNS.join(","))?;
    for (r, t) in record.time_s.iter().enumerate() {
        for tooth in 0..record.teeth {
            let l = record.loads_n[r * record.teeth + tooth];
            writeln!(w, "{t:.6},{tooth},{:.4},{:.4},{:.4}", l[0], l[1], l[2])?;
        }
    }
    Ok(())
}

impl KindRecord for ToothRecord {
    fn as_any(&self) -> &dyn std::any::Any {
        self
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
}
