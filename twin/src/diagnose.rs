//! Belt-looseness diagnosis from measured speeds: per condition label, the steady slip
//! distribution (extrapolated where a recording still settles at its end,
//! `crate::settling`), a Bayesian inversion of the surrogate for centre distance and
//! installation tension, and the looseness class with its probability.

use egobox_doe::{Lhs, LhsKind, SamplingMethod};
use fom::stats::weighted_quantile;
use fom::{DesignPoint, DriveConfig};
use ndarray::Array2;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use rom::Surrogate;
use serde::Serialize;

use crate::error::{Result, TwinError};
use crate::inference::likelihood::{log_likelihood, misfit_variance};
use crate::measured::DataSet;
use crate::signal::{measured_slip, MeasuredSlip, Unsettled};

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

pub fn class_of(ratio: f64) -> usize {
    CLASS_THRESHOLDS.iter().filter(|&&t| ratio >= t).count()
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
    /// The prior sample nearest the measured mean slip misses it by this many standard
    /// deviations of the likelihood (above 3: the twin cannot reproduce the label).
    pub closest_sd: f64,
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
    /// Signs that the twin cannot reproduce this label; empty when none.
    pub misfit: Vec<String>,
}

/// Fewer effective posterior samples than this (n_eff = (sum w)^2 / sum w^2, Kish, Survey
/// Sampling, 1965) carry no interval worth the name.
pub const MIN_EFFECTIVE_SAMPLES: f64 = 20.0;

/// Misfit of one label's inversion: few effective samples, measured slip beyond every training
/// run, or no prior sample within three standard deviations of the likelihood.
fn misfit_flags(max_trained_slip_pct: Option<f64>, m: &MeasuredSlip, e: &Estimate) -> Vec<String> {
    let mut flags = Vec::new();
    if e.effective_samples < MIN_EFFECTIVE_SAMPLES {
        flags.push(format!(
            "the posterior rests on {:.1} effective samples (fewer than {MIN_EFFECTIVE_SAMPLES}): \
             the twin barely reaches the measured slip",
            e.effective_samples
        ));
    }
    if let Some(max) = max_trained_slip_pct {
        if m.mean_pct > max {
            flags.push(format!(
                "measured slip {:.3} % is beyond every training run ({max:.3} %): out of the \
                 twin's reach",
                m.mean_pct
            ));
        }
    }
    if e.closest_sd > 3.0 {
        flags.push(format!(
            "no twin state within the trained box comes closer than {:.1} sd to the measured \
             slip {:.3} %",
            e.closest_sd, m.mean_pct
        ));
    }
    flags
}

/// Prior sample over (d, T, mu): a Latin hypercube over the surrogate's d and tension ranges
/// and mu within +-1 % of the configuration's nominal (seed paper, section 4.2).
fn prior(s: &Surrogate, mu_nominal: f64) -> Vec<DesignPoint> {
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
        .map(|r| DesignPoint {
            center_distance_m: r[0],
            friction: r[2],
            installation_tension_n: r[1],
            axial_stiffness_n: None,
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        })
        .collect()
}

/// The surrogate's side of a diagnosis, which no measurement changes: the prior sample with the
/// surrogate's mean slip and likelihood sd at each point, and the as-installed slip. Made once
/// per model and drive configuration and used for every label (or, in `rom serve`, every
/// segment), so that a diagnosis does not predict the prior sample again.
#[derive(Debug, Clone)]
pub struct Prior {
    /// Prior points inside the surrogate, each with (mean slip %, likelihood sd %).
    points: Vec<(DesignPoint, f64, f64)>,
    /// See [`healthy_slip_pct`].
    pub healthy_slip_pct: f64,
}

impl Prior {
    pub fn new(s: &Surrogate, cfg: &DriveConfig) -> Result<Self> {
        let mut points = Vec::with_capacity(PRIOR_SAMPLES);
        for q in prior(s, cfg.effective_friction()) {
            // Points looser than any training run, or where the surrogate overshoots every
            // training run's slip, are outside the surrogate: zero prior there.
            if s.looser_than_trained(cfg, &q).is_some() {
                continue;
            }
            let p = s.predict_point(cfg, &q)?;
            if s.beyond_trained_slip(p.mean_slip_pct).is_some() {
                continue;
            }
            points.push((q, p.mean_slip_pct, p.likelihood_std_pct));
        }
        Ok(Self {
            points,
            healthy_slip_pct: healthy_slip_pct(s, cfg)?,
        })
    }
}

/// Bayesian inversion for one label's measured mean slip.
pub fn invert(
    s: &Surrogate,
    cfg: &DriveConfig,
    m: &MeasuredSlip,
    prior: &Prior,
) -> Result<Estimate> {
    let healthy_slip_pct = prior.healthy_slip_pct;
    let mut w = Vec::with_capacity(prior.points.len());
    let mut class_p = [0.0; 5];
    let mut kept: Vec<(DesignPoint, f64)> = Vec::new();
    let mut closest_sd = f64::INFINITY;
    for &(q, mean_slip_pct, likelihood_std_pct) in &prior.points {
        let var = misfit_variance(m.mean_se_pct, likelihood_std_pct.powi(2), mean_slip_pct);
        let ll = log_likelihood(m.mean_pct - mean_slip_pct, var);
        w.push(ll);
        kept.push((q, mean_slip_pct));
        closest_sd = closest_sd.min((m.mean_pct - mean_slip_pct).abs() / var.sqrt());
    }
    let max = w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return Err(TwinError::Unusable(
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
    let twin = rom::predict_distribution(
        s,
        cfg,
        &DesignPoint {
            center_distance_m: d_med,
            friction: cfg.effective_friction(),
            installation_tension_n: t_med,
            axial_stiffness_n: None,
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
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
        closest_sd,
    })
}

/// The twin's mean slip, %, for the belt as installed (reference centre distance, nominal
/// tension and friction): the slip the looseness classes are ratios to (`CLASS_THRESHOLDS`).
pub fn healthy_slip_pct(s: &Surrogate, cfg: &DriveConfig) -> Result<f64> {
    Ok(s.predict_point(
        cfg,
        &DesignPoint {
            center_distance_m: cfg
                .belt
                .reference_center_distance_m
                .unwrap_or(cfg.center_distance_m()),
            friction: cfg.effective_friction(),
            installation_tension_n: cfg.belt.installation_tension_n.unwrap_or(
                0.5 * (s.settings.installation_tension_n[0] + s.settings.installation_tension_n[1]),
            ),
            axial_stiffness_n: None,
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        },
    )?
    .mean_slip_pct)
}

/// Diagnoses every label of a data set at its reference load (`DataSet::split_by_load`).
pub fn diagnose(s: &Surrogate, cfg: &DriveConfig, set: &DataSet) -> Result<Vec<LabelVerdict>> {
    diagnose_with(s, cfg, &Prior::new(s, cfg)?, set)
}

/// [`diagnose`] with the surrogate's side made beforehand (`prior` of the same `s` and `cfg`).
pub fn diagnose_with(
    s: &Surrogate,
    cfg: &DriveConfig,
    prior: &Prior,
    set: &DataSet,
) -> Result<Vec<LabelVerdict>> {
    // The surrogate runs at one load: labels at another are left to `rom gap`'s load levels.
    let set = &*set.at_reference_load();
    let m = &set.manifest;
    let ratio = set.speed_ratio(cfg);
    // A recording still drifting is used where its drift is below the finest step the
    // classes draw (weak begins 5 % above the healthy slip), and extrapolated where it heads
    // for gross slip, the critical class (docs/decisions/settling-extrapolation.md).
    let extrapolate = Unsettled::Use {
        small_drift_pp: (CLASS_THRESHOLDS[0] - 1.0) * prior.healthy_slip_pct,
        gross_slip_from_pct: CLASS_THRESHOLDS[3] * prior.healthy_slip_pct,
    };
    let mut out = Vec::new();
    for label in set.labels() {
        let idx = set.runs_of(&label);
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
            misfit: Vec::new(),
        };
        match measured_slip(&set.recordings_of(&label), ratio, extrapolate) {
            Err(why) => v.cannot_diagnose = Some(why.to_string()),
            Ok(ms) => {
                let e = invert(s, cfg, &ms, prior)?;
                v.misfit = misfit_flags(s.max_trained_slip_pct, &ms, &e);
                v.estimate = Some(e);
                v.measured = Some(ms);
            }
        }
        out.push(v);
    }
    Ok(out)
}

#[cfg(test)]
mod misfit_tests {
    use super::*;

    #[test]
    fn each_sign_of_misfit_is_flagged_and_a_good_fit_has_none() {
        let m = MeasuredSlip {
            samples: 2000,
            steady_s: 2.0,
            mean_pct: 0.7,
            std_pct: 0.1,
            mean_se_pct: 0.005,
            quantiles_pct: [0.55, 0.65, 0.7, 0.75, 0.85],
            settling: Vec::new(),
            drifting: Vec::new(),
        };
        let e = Estimate {
            center_distance_m: 0.42,
            center_distance_90_m: [0.419, 0.421],
            installation_tension_n: 250.0,
            installation_tension_90_n: [240.0, 260.0],
            class_probability: [1.0, 0.0, 0.0, 0.0, 0.0],
            class: "healthy".into(),
            twin_quantiles_pct: [0.55, 0.65, 0.7, 0.75, 0.85],
            twin_mean_slip_pct: 0.7,
            effective_samples: 400.0,
            closest_sd: 0.1,
        };
        assert!(misfit_flags(Some(30.0), &m, &e).is_empty());
        let few = Estimate {
            effective_samples: 3.0,
            ..e.clone()
        };
        assert!(misfit_flags(Some(30.0), &m, &few)[0].contains("3.0 effective samples"));
        let far = Estimate {
            closest_sd: 7.5,
            ..e.clone()
        };
        assert!(misfit_flags(Some(30.0), &m, &far)[0].contains("7.5 sd"));
        let beyond = MeasuredSlip {
            mean_pct: 45.0,
            ..m.clone()
        };
        assert!(misfit_flags(Some(30.0), &beyond, &e)[0].contains("out of the twin's reach"));
    }
}
