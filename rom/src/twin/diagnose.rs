//! Belt-looseness diagnosis from measured speeds: per condition label, the steady slip
//! distribution, a Bayesian inversion of the surrogate for centre distance and installation
//! tension, and the looseness class with its probability.

use egobox_doe::{Lhs, LhsKind, SamplingMethod};
use fom::output::quantile;
use fom::DriveConfig;
use ndarray::Array2;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use serde::Serialize;

use super::measured::{DataSet, Recording};
use crate::surrogate::{Query, Surrogate};
use crate::RomError;

/// Looseness classes, from the ratio of the steady mean slip to the twin's slip for the belt as
/// installed (reference centre distance, nominal tension and friction). The seed paper's five
/// conditions had ratios 1, 1.008, 1.029, 1.37 and 2.19 (its Table 2); the thresholds sit where
/// slip measurably leaves creep (+5 %), where a quarter more slip wastes fan power (+25 %), and
/// where gross slip sets in (x1.6, x3).
pub const CLASSES: [&str; 5] = ["healthy", "weak", "moderate", "strong", "critical"];
/// Lower ratio bounds of weak, moderate, strong and critical.
pub const CLASS_THRESHOLDS: [f64; 4] = [1.05, 1.25, 1.6, 3.0];

/// Prior samples of the inversion.
pub const PRIOR_SAMPLES: usize = 4000;
/// Model discrepancy between twin and measurement (1 sd, relative): the surrogate's accuracy
/// target (2 %) on top of its own variance.
pub const MODEL_DISCREPANCY: f64 = 0.02;
/// Least steady running after start-up, s, and samples.
pub const MIN_STEADY_S: f64 = 0.5;
pub const MIN_STEADY_SAMPLES: usize = 100;

pub fn class_of(ratio: f64) -> usize {
    CLASS_THRESHOLDS.iter().filter(|&&t| ratio >= t).count()
}

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

#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    pub center_distance_m: f64,
    pub center_distance_90_m: [f64; 2],
    pub installation_tension_n: f64,
    pub installation_tension_90_n: [f64; 2],
    /// Probability of each class in `CLASSES` order.
    pub class_probability: [f64; 5],
    pub class: String,
    /// The twin's slip at the posterior median (d, T) and nominal friction: p05..p95, %.
    pub twin_quantiles_pct: [f64; 5],
    pub twin_mean_slip_pct: f64,
    /// Effective number of prior samples carrying the posterior (importance weights).
    pub effective_samples: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct LabelVerdict {
    pub label: String,
    pub runs: usize,
    /// Centre distance stated in the manifest, if all runs of the label state the same one.
    pub known_center_distance_m: Option<f64>,
    pub measured: Option<MeasuredSlip>,
    pub estimate: Option<Estimate>,
    /// Why no verdict could be given.
    pub cannot_diagnose: Option<String>,
}

/// Steady slip samples of one run after discarding standstill and start-up: the run is steady
/// from the last sample where the driven speed was more than 2 % away from its final level
/// (median of the last quarter of the record).
pub fn steady_slip(rec: &Recording, ratio: f64) -> Result<(Vec<f64>, f64), String> {
    let max = rec.driver_rpm.iter().copied().fold(0.0, f64::max);
    if max < 60.0 {
        return Err(format!(
            "the driver is at standstill (largest speed {max:.1} rpm)"
        ));
    }
    let n = rec.len();
    let first_running = (0..n)
        .find(|&i| rec.driver_rpm[i] >= 0.05 * max)
        .unwrap_or(n);
    let tail: Vec<f64> = {
        let mut t: Vec<f64> = rec.driven_rpm[n - (n / 4).max(1)..].to_vec();
        t.sort_by(f64::total_cmp);
        t
    };
    let final_rpm = quantile(&tail, 0.5);
    if final_rpm <= 0.0 {
        return Err("the driven pulley does not turn at the end of the record".into());
    }
    let unsettled = (first_running..n)
        .rev()
        .find(|&i| (rec.driven_rpm[i] - final_rpm).abs() > 0.02 * final_rpm);
    let start = unsettled.map_or(first_running, |i| i + 1);
    let slip: Vec<f64> = (start..n)
        .filter(|&i| rec.driver_rpm[i] >= 0.05 * max)
        .map(|i| 100.0 * (1.0 - ratio * rec.driven_rpm[i] / rec.driver_rpm[i]))
        .collect();
    let steady_s = if start < n {
        rec.time_s[n - 1] - rec.time_s[start]
    } else {
        0.0
    };
    if slip.len() < MIN_STEADY_SAMPLES || steady_s < MIN_STEADY_S {
        return Err(format!(
            "too short: {steady_s:.2} s and {} samples of steady running after start-up \
             (need {MIN_STEADY_S} s and {MIN_STEADY_SAMPLES} samples)",
            slip.len()
        ));
    }
    let first = slip[0];
    if slip.iter().all(|&s| s == first) {
        return Err("the speed signals are constant (a stuck or disconnected sensor?)".into());
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
pub fn measured_slip(recs: &[&Recording], ratio: f64) -> Result<MeasuredSlip, String> {
    let mut all = Vec::new();
    let mut steady_s = 0.0;
    let mut var_sum = 0.0;
    let mut weights = 0.0;
    for (k, r) in recs.iter().enumerate() {
        let (s, t) = steady_slip(r, ratio).map_err(|e| format!("run {}: {e}", k + 1))?;
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

fn weighted_quantile(values: &[(f64, f64)], p: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = v.iter().map(|x| x.1).sum();
    let mut acc = 0.0;
    for (x, w) in &v {
        acc += w;
        if acc >= p * total {
            return *x;
        }
    }
    v.last().map_or(f64::NAN, |x| x.0)
}

/// Prior sample over (d, T, mu): a Latin hypercube over the surrogate's d and tension ranges
/// and mu within +-1 % of the configuration's nominal (seed paper, section 4.2).
fn prior(s: &Surrogate, mu_nominal: f64) -> Vec<Query> {
    let st = &s.settings;
    let mu = [
        (mu_nominal * 0.99).max(st.friction[0]),
        (mu_nominal * 1.01).min(st.friction[1]),
    ];
    let lim = Array2::from_shape_fn((3, 2), |(i, j)| {
        [st.center_distance_m, st.installation_tension_n, mu][i][j]
    });
    Lhs::new_with_rng(&lim, Xoshiro256Plus::seed_from_u64(7))
        .kind(LhsKind::Classic)
        .sample(PRIOR_SAMPLES)
        .rows()
        .into_iter()
        .map(|r| Query {
            center_distance_m: r[0],
            friction: r[2],
            installation_tension_n: r[1],
            axial_stiffness_n: None,
        })
        .collect()
}

/// Bayesian inversion for one label's measured mean slip.
pub fn invert(
    s: &Surrogate,
    cfg: &DriveConfig,
    m: &MeasuredSlip,
    prior_points: &[Query],
    healthy_slip_pct: f64,
) -> Result<Estimate, RomError> {
    let mut w = Vec::with_capacity(prior_points.len());
    let mut class_p = [0.0; 5];
    let mut kept: Vec<(Query, f64)> = Vec::new();
    for q in prior_points {
        // Points looser than any training run are outside the surrogate: zero prior there.
        if s.looser_than_trained(cfg, q)?.is_some() {
            continue;
        }
        let p = s.predict_point(cfg, q)?;
        let var = m.mean_se_pct.powi(2)
            + p.surrogate_std_pct.powi(2)
            + (MODEL_DISCREPANCY * p.mean_slip_pct).powi(2);
        let ll = -0.5 * (m.mean_pct - p.mean_slip_pct).powi(2) / var - 0.5 * var.ln();
        w.push(ll);
        kept.push((*q, p.mean_slip_pct));
    }
    let max = w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return Err(RomError::Predict(
            "no prior sample inside the surrogate's range".into(),
        ));
    }
    let w: Vec<f64> = w.iter().map(|l| (l - max).exp()).collect();
    let total: f64 = w.iter().sum();
    let ess = total * total / w.iter().map(|x| x * x).sum::<f64>();
    for ((_, slip), wi) in kept.iter().zip(&w) {
        class_p[class_of(slip / healthy_slip_pct)] += wi / total;
    }
    let d: Vec<(f64, f64)> = kept
        .iter()
        .zip(&w)
        .map(|((q, _), wi)| (q.center_distance_m, *wi))
        .collect();
    let t: Vec<(f64, f64)> = kept
        .iter()
        .zip(&w)
        .map(|((q, _), wi)| (q.installation_tension_n, *wi))
        .collect();
    let best = (0..5)
        .max_by(|&a, &b| class_p[a].total_cmp(&class_p[b]))
        .unwrap_or(0);
    let d_med = weighted_quantile(&d, 0.5);
    let t_med = weighted_quantile(&t, 0.5);
    let twin = crate::predict::predict_distribution(
        s,
        cfg,
        &Query {
            center_distance_m: d_med,
            friction: cfg.contact.effective_friction(),
            installation_tension_n: t_med,
            axial_stiffness_n: None,
        },
        50,
        true,
    )?;
    let tq = twin.quantiles_pct;
    Ok(Estimate {
        center_distance_m: d_med,
        center_distance_90_m: [weighted_quantile(&d, 0.05), weighted_quantile(&d, 0.95)],
        installation_tension_n: t_med,
        installation_tension_90_n: [weighted_quantile(&t, 0.05), weighted_quantile(&t, 0.95)],
        class_probability: class_p,
        class: CLASSES[best].to_string(),
        twin_quantiles_pct: [tq.p05, tq.p25, tq.p50, tq.p75, tq.p95],
        twin_mean_slip_pct: twin.mean_slip_pct,
        effective_samples: ess,
    })
}

/// Diagnoses every label of a data set.
pub fn diagnose(
    s: &Surrogate,
    cfg: &DriveConfig,
    set: &DataSet,
) -> Result<Vec<LabelVerdict>, RomError> {
    let m = &set.manifest;
    let ratio = set.speed_ratio(cfg.driven.pitch_diameter_m / cfg.driver.pitch_diameter_m);
    let mu = cfg.contact.effective_friction();
    let healthy = s
        .predict_point(
            cfg,
            &Query {
                center_distance_m: cfg
                    .belt
                    .reference_center_distance_m
                    .unwrap_or(cfg.center_distance_m()),
                friction: mu,
                installation_tension_n: cfg.belt.installation_tension_n.unwrap_or(
                    0.5 * (s.settings.installation_tension_n[0]
                        + s.settings.installation_tension_n[1]),
                ),
                axial_stiffness_n: None,
            },
        )?
        .mean_slip_pct;
    let prior_points = prior(s, mu);
    let mut out = Vec::new();
    for label in set.labels() {
        let idx = set.runs_of(&label);
        let recs: Vec<&Recording> = idx.iter().map(|&i| &set.recordings[i]).collect();
        let known: Vec<Option<f64>> = idx.iter().map(|&i| m.runs[i].center_distance_m).collect();
        let known_center_distance_m = match known.first() {
            Some(Some(d)) if known.iter().all(|k| *k == Some(*d)) => Some(*d),
            _ => None,
        };
        let mut v = LabelVerdict {
            label: label.clone(),
            runs: idx.len(),
            known_center_distance_m,
            measured: None,
            estimate: None,
            cannot_diagnose: None,
        };
        match measured_slip(&recs, ratio) {
            Err(why) => v.cannot_diagnose = Some(why),
            Ok(ms) => {
                v.estimate = Some(invert(s, cfg, &ms, &prior_points, healthy)?);
                v.measured = Some(ms);
            }
        }
        out.push(v);
    }
    Ok(out)
}

/// Readable table of the verdicts.
pub fn to_text(verdicts: &[LabelVerdict]) -> String {
    let mut t = String::from(
        "label  runs | measured slip % (mean, p05-p95) | d estimate (m) [90 %]          known d | \
         tension (N) [90 %]        | class (probability)\n",
    );
    for v in verdicts {
        match (&v.measured, &v.estimate, &v.cannot_diagnose) {
            (Some(m), Some(e), _) => {
                let p = e.class_probability;
                let known = v
                    .known_center_distance_m
                    .map_or("   -   ".to_string(), |d| format!("{d:.4}"));
                t += &format!(
                    "{:<6} {:>4} | {:7.4} ({:.4}-{:.4})        | {:.4} [{:.4}, {:.4}]  {known} | \
                     {:5.1} [{:5.1}, {:5.1}] | {} ({:.0} %; h {:.0} w {:.0} m {:.0} s {:.0} c {:.0})\n",
                    v.label,
                    v.runs,
                    m.mean_pct,
                    m.quantiles_pct[0],
                    m.quantiles_pct[4],
                    e.center_distance_m,
                    e.center_distance_90_m[0],
                    e.center_distance_90_m[1],
                    e.installation_tension_n,
                    e.installation_tension_90_n[0],
                    e.installation_tension_90_n[1],
                    e.class,
                    100.0 * p.iter().copied().fold(0.0, f64::max),
                    100.0 * p[0],
                    100.0 * p[1],
                    100.0 * p[2],
                    100.0 * p[3],
                    100.0 * p[4],
                );
            }
            (_, _, Some(why)) => {
                t += &format!("{:<6} {:>4} | cannot diagnose: {why}\n", v.label, v.runs)
            }
            _ => {}
        }
    }
    t
}
