//! Signal processing of measured speeds: the steady part of a recording, its slip samples and
//! the standard error of their mean. One definition, used by calibration and diagnosis.

use fom::slip::{slip_pct, STANDSTILL_SHARE};
use fom::stats::quantile;
use serde::Serialize;

use crate::error::{Result, TwinError};
use crate::measured::Recording;

/// Least steady running after start-up, s, and samples.
pub const MIN_STEADY_S: f64 = 0.5;
pub const MIN_STEADY_SAMPLES: usize = 100;

/// The measured steady slip of one label.
#[derive(Debug, Clone, Serialize)]
pub struct MeasuredSlip {
    pub samples: usize,
    pub steady_s: f64,
    pub mean_pct: f64,
    pub std_pct: f64,
    /// Standard error of the mean from batch means (10 batches per run), %.
    pub mean_se_pct: f64,
    /// p05, p25, p50, p75, p95, %.
    pub quantiles_pct: [f64; 5],
}

/// Steady slip samples of one run after discarding standstill and start-up: the run is steady
/// from the last sample where the driven speed was more than 2 % away from its final level
/// (median of the last quarter of the record).
pub fn steady_slip(rec: &Recording, ratio: f64) -> Result<(Vec<f64>, f64)> {
    let max = rec.driver_rpm.iter().copied().fold(0.0, f64::max);
    if max < 60.0 {
        return Err(TwinError::Unusable(format!(
            "the driver is at standstill (largest speed {max:.1} rpm)"
        )));
    }
    let n = rec.len();
    let first_running = (0..n)
        .find(|&i| rec.driver_rpm[i] >= STANDSTILL_SHARE * max)
        .unwrap_or(n);
    let tail: Vec<f64> = {
        let mut t: Vec<f64> = rec.driven_rpm[n - (n / 4).max(1)..].to_vec();
        t.sort_by(f64::total_cmp);
        t
    };
    let final_rpm = quantile(&tail, 0.5);
    if final_rpm <= 0.0 {
        return Err(TwinError::Unusable(
            "the driven pulley does not turn at the end of the record".into(),
        ));
    }
    let unsettled = (first_running..n)
        .rev()
        .find(|&i| (rec.driven_rpm[i] - final_rpm).abs() > 0.02 * final_rpm);
    let start = unsettled.map_or(first_running, |i| i + 1);
    let slip: Vec<f64> = (start..n)
        .filter(|&i| rec.driver_rpm[i] >= STANDSTILL_SHARE * max)
        .map(|i| slip_pct(ratio, rec.driver_rpm[i], rec.driven_rpm[i]))
        .collect();
    let steady_s = if start < n {
        rec.time_s[n - 1] - rec.time_s[start]
    } else {
        0.0
    };
    if slip.len() < MIN_STEADY_SAMPLES || steady_s < MIN_STEADY_S {
        return Err(TwinError::Unusable(format!(
            "too short: {steady_s:.2} s and {} samples of steady running after start-up \
             (need {MIN_STEADY_S} s and {MIN_STEADY_SAMPLES} samples)",
            slip.len()
        )));
    }
    let first = slip[0];
    if slip.iter().all(|&s| s == first) {
        return Err(TwinError::Unusable(
            "the speed signals are constant (a stuck or disconnected sensor?)".into(),
        ));
    }
    Ok((slip, steady_s))
}

/// Variance of the mean from 10 batch means (autocorrelated samples), %^2.
fn batch_mean_variance(slip: &[f64]) -> f64 {
    let b = 10;
    let len = slip.len() / b;
    let means: Vec<f64> = (0..b)
        .map(|k| slip[k * len..(k + 1) * len].iter().sum::<f64>() / len as f64)
        .collect();
    let m = means.iter().sum::<f64>() / b as f64;
    let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (b - 1) as f64;
    var / b as f64
}

/// Measured slip of a label from its runs.
pub fn measured_slip(recs: &[&Recording], ratio: f64) -> Result<MeasuredSlip> {
    let mut all = Vec::new();
    let mut steady_s = 0.0;
    let mut var_sum = 0.0;
    let mut weights = 0.0;
    for (k, r) in recs.iter().enumerate() {
        let (s, t) = steady_slip(r, ratio)
            .map_err(|e| TwinError::Unusable(format!("run {}: {e}", k + 1)))?;
        let v = batch_mean_variance(&s);
        let w = s.len() as f64;
        var_sum += w * w * v;
        weights += w;
        steady_s += t;
        all.extend(s);
    }
    let n = all.len() as f64;
    let mean = all.iter().sum::<f64>() / n;
    let std = (all.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    all.sort_by(f64::total_cmp);
    let q = |p| quantile(&all, p);
    Ok(MeasuredSlip {
        samples: all.len(),
        steady_s,
        mean_pct: mean,
        std_pct: std,
        mean_se_pct: (var_sum / (weights * weights)).sqrt(),
        quantiles_pct: [q(0.05), q(0.25), q(0.5), q(0.75), q(0.95)],
    })
}
