//! Sensor model for synthetic measurements: a tachometer with P pulses per revolution on each
//! shaft, speed computed from the time between the last two pulses, read out at a fixed sampling
//! rate with additive Gaussian speed noise.

use rand::Rng;
use rand_distr::StandardNormal;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

use std::collections::BTreeMap;
use std::path::Path;

use fom::DriveConfig;

use crate::error::{Result, TwinError};
use crate::measured::{append_run, Recording, RunEntry};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorModel {
    /// Read-out rate, Hz.
    pub sample_rate_hz: f64,
    /// Tachometer pulses per shaft revolution.
    pub pulses_per_rev: u32,
    /// Standard deviation of the additive speed noise, rpm.
    pub speed_noise_rpm: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for SensorModel {
    /// 1 kHz read-out, a 60-tooth wheel (a common magnetic pick-up), 1 rpm noise (0.06 % of
    /// motor speed: an industrial tachometer's stated accuracy class).
    fn default() -> Self {
        Self {
            sample_rate_hz: 1000.0,
            pulses_per_rev: 60,
            speed_noise_rpm: 1.0,
            seed: 1,
        }
    }
}

impl SensorModel {
    /// Checks every setting; the error names it.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, message: String| Err(TwinError::InvalidArgument { name, message });
        if !(self.sample_rate_hz.is_finite() && self.sample_rate_hz > 0.0) {
            return bad(
                "sensor sample rate (Hz)",
                format!("must be positive, got {}", self.sample_rate_hz),
            );
        }
        if self.pulses_per_rev == 0 {
            return bad(
                "tachometer pulses per revolution",
                "must be at least 1, got 0".into(),
            );
        }
        if !(self.speed_noise_rpm.is_finite() && self.speed_noise_rpm >= 0.0) {
            return bad(
                "speed noise (rpm)",
                format!("must be zero or positive, got {}", self.speed_noise_rpm),
            );
        }
        Ok(())
    }
}

/// Whether `label` can name a condition in file names (`LABEL-runN.csv`).
pub fn check_label(label: &str) -> Result<()> {
    if label.trim().is_empty() || label.contains(['/', '\\']) {
        return Err(TwinError::InvalidArgument {
            name: "condition label",
            message: format!("`{label}` must be non-empty and contain no path separator"),
        });
    }
    Ok(())
}

/// Appends a full-order run to the measured data set in `dir` as a synthetic recording
/// `LABEL-runN.csv` (first free N), with the centre distance, friction and installation
/// tension as run metadata. Returns the file name.
pub fn append_synthetic_run(
    dir: &Path,
    label: &str,
    cfg: &DriveConfig,
    rows: &[fom::OutputRow],
    sensor: &SensorModel,
) -> Result<String> {
    check_label(label)?;
    let n = (1..)
        .find(|n| !dir.join(format!("{label}-run{n}.csv")).exists())
        .expect("a free run number");
    let file = format!("{label}-run{n}.csv");
    let rec = measure(rows, sensor);
    let mut metadata = BTreeMap::new();
    metadata.insert("synthetic".to_string(), toml::Value::Boolean(true));
    metadata.insert(
        "friction".to_string(),
        toml::Value::Float(cfg.effective_friction()),
    );
    if let Some(t) = cfg.belt.installation_tension_n {
        metadata.insert("installation_tension_n".to_string(), toml::Value::Float(t));
    }
    let comment = format!(
        "synthetic measurement by beltwin {}: sensor {} Hz, {} pulses/rev, noise {} rpm, seed {}",
        env!("CARGO_PKG_VERSION"),
        sensor.sample_rate_hz,
        sensor.pulses_per_rev,
        sensor.speed_noise_rpm,
        sensor.seed
    );
    append_run(
        dir,
        RunEntry {
            file: file.clone(),
            label: label.to_string(),
            center_distance_m: Some(cfg.center_distance_m()),
            metadata,
        },
        &rec,
        &comment,
        (cfg.driver.pitch_diameter_m, cfg.driven.pitch_diameter_m),
    )?;
    Ok(file)
}

/// Pulse times of one shaft from interval-mean speeds (rpm) on rows ending at `time_s`: the
/// angle is integrated row by row and a pulse falls every 1/P revolution (linear inside a row).
fn pulse_times(time_s: &[f64], rpm: &[f64], pulses_per_rev: u32) -> Vec<f64> {
    let step = 1.0 / pulses_per_rev as f64;
    let mut pulses = Vec::new();
    let mut rev = 0.0;
    let mut next = step;
    for k in 1..time_s.len() {
        let dt = time_s[k] - time_s[k - 1];
        let d_rev = rpm[k].max(0.0) / 60.0 * dt;
        while d_rev > 0.0 && rev + d_rev >= next {
            pulses.push(time_s[k - 1] + (next - rev) / d_rev * dt);
            next += step;
        }
        rev += d_rev;
    }
    pulses
}

/// Speed (rpm) a pulse tachometer reads at `t`: from the last two pulses up to `t`; zero
/// before the second pulse or when the last pulse is older than the gap to the one before
/// would allow at the slowest speed the sensor resolves (a time-out of 4 pulse gaps).
fn read_speed(pulses: &[f64], t: f64, pulses_per_rev: u32, cursor: &mut usize) -> f64 {
    while *cursor < pulses.len() && pulses[*cursor] <= t {
        *cursor += 1;
    }
    if *cursor < 2 {
        return 0.0;
    }
    let (a, b) = (pulses[*cursor - 2], pulses[*cursor - 1]);
    let gap = b - a;
    if t - b > 4.0 * gap.max(1e-6) {
        return 0.0;
    }
    60.0 / (pulses_per_rev as f64 * gap)
}

/// A synthetic recording of a full-order run's shaft speeds.
pub fn measure(rows: &[fom::OutputRow], sensor: &SensorModel) -> Recording {
    let t: Vec<f64> = rows.iter().map(|r| r.time_s).collect();
    let n1: Vec<f64> = rows.iter().map(|r| r.driver_rpm).collect();
    let n2: Vec<f64> = rows.iter().map(|r| r.driven_rpm).collect();
    let p1 = pulse_times(&t, &n1, sensor.pulses_per_rev);
    let p2 = pulse_times(&t, &n2, sensor.pulses_per_rev);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(sensor.seed);
    let mut gauss = || -> f64 { rng.sample(StandardNormal) };
    let end = t.last().copied().unwrap_or(0.0);
    let n = (end * sensor.sample_rate_hz).floor() as usize;
    let mut rec = Recording::default();
    let (mut c1, mut c2) = (0, 0);
    for k in 0..=n {
        let ts = k as f64 / sensor.sample_rate_hz;
        let mut s1 = read_speed(&p1, ts, sensor.pulses_per_rev, &mut c1);
        let mut s2 = read_speed(&p2, ts, sensor.pulses_per_rev, &mut c2);
        if s1 > 0.0 {
            s1 = (s1 + sensor.speed_noise_rpm * gauss()).max(0.0);
        }
        if s2 > 0.0 {
            s2 = (s2 + sensor.speed_noise_rpm * gauss()).max(0.0);
        }
        rec.time_s.push(ts);
        rec.driver_rpm.push(s1);
        rec.driven_rpm.push(s2);
    }
    rec
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_speed_gives_evenly_spaced_pulses_and_the_speed_back() {
        // 600 rpm = 10 rev/s; 1 kHz rows for 1.01 s: pulses every 25 ms up to 1.0 s.
        let t: Vec<f64> = (0..=1010).map(|k| k as f64 * 1e-3).collect();
        let rpm = vec![600.0; t.len()];
        let p = pulse_times(&t, &rpm, 4);
        assert_eq!(p.len(), 40);
        assert!(
            (p[0] - 0.025).abs() < 1e-9 && (p[39] - 1.0).abs() < 1e-9,
            "{p:?}"
        );
        let mut c = 0;
        assert!((read_speed(&p, 0.5, 4, &mut c) - 600.0).abs() < 1e-6);
        let mut c = 0;
        assert_eq!(
            read_speed(&p, 0.03, 4, &mut c),
            0.0,
            "one pulse is not a speed"
        );
    }

    #[test]
    fn noise_has_the_requested_spread() {
        let rows: Vec<fom::OutputRow> = (0..=2000)
            .map(|k| fom::OutputRow {
                time_s: k as f64 * 1e-3,
                driver_rpm: 1750.0,
                driven_rpm: 870.0,
                slip_pct: 0.0,
                tight_span_tension_n: 0.0,
                slack_span_tension_n: 0.0,
                driver_torque_nm: 0.0,
                driven_torque_nm: 0.0,
            })
            .collect();
        let sensor = SensorModel {
            speed_noise_rpm: 2.0,
            ..SensorModel::default()
        };
        let rec = measure(&rows, &sensor);
        let v: Vec<f64> = rec.driver_rpm[100..].to_vec();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        assert!((m - 1750.0).abs() < 0.2, "mean {m}");
        assert!((sd - 2.0).abs() < 0.15, "sd {sd}");
    }
}
