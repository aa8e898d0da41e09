//! The 90 % intervals of the slip surrogate: leave-one-out factors from the fit, and their
//! split-conformal calibration on held-out full-order runs.

use fom::{DesignPoint, DriveConfig};
use serde::{Deserialize, Serialize};

use super::Surrogate;
use crate::features::{capacity_feature_n, knee_band_capacity_n};
use crate::RomError;

/// Knee runs needed before the knee gets its own uncertainty calibration.
pub const KNEE_CALIBRATION_RUNS: usize = 5;

/// Held-out runs needed per part ([`IntervalPart`]) for a split-conformal 90 %
/// factor: the ceil((n + 1) 0.9)-th smallest score exists only for n >= 9.
pub const CONFORMAL_MIN_RUNS: usize = 9;

/// A held-out full-order run: its design point and its settled mean slip, %.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldOutRun {
    pub point: DesignPoint,
    pub mean_slip_pct: f64,
}

/// How the 90 % intervals were calibrated on held-out full-order runs (split conformal
/// prediction: Lei, G'Sell, Rinaldo, Tibshirani & Wasserman, J. Am. Stat. Assoc. 113, 2018;
/// the score |prediction - truth| / sd, normalised by the surrogate's own sd).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IntervalCalibration {
    /// Seeds of the held-out designs (`rom validate` refuses them: their points are no longer
    /// fresh for the intervals).
    pub seeds: Vec<u64>,
    /// Held-out runs on the creep plateau (outside the knee band, below the onset) and in the
    /// knee band.
    pub runs_outside_band: usize,
    pub runs_in_band: usize,
    /// Split-conformal factors on the processes' sd for the 90 % interval, outside the knee
    /// band and in it (a part with too few runs: its leave-one-out factor).
    pub factor: f64,
    pub factor_knee: f64,
    /// Root mean square of the held-out scores |error| / the processes' sd, outside the band
    /// and in it (`None` without runs): the factor a Gaussian likelihood's sd would need to
    /// match the held-out errors' second moment, against `std_calibration` (`docs/surrogate.md`,
    /// "90 % intervals calibrated on held-out runs").
    pub rms_score: Option<f64>,
    pub rms_score_knee: Option<f64>,
    /// The knee's onset outside the band (predicted mean slip from `ONSET_SLIP_PCT`): its
    /// runs, its factor (`None` with fewer than `CONFORMAL_MIN_RUNS` runs: `factor` applies)
    /// and its root mean square score. Files before it: no onset part.
    #[serde(default)]
    pub runs_onset: usize,
    #[serde(default)]
    pub factor_onset: Option<f64>,
    #[serde(default)]
    pub rms_score_onset: Option<f64>,
}

/// Predicted mean slip, %, from which a query outside the knee band belongs to the onset part
/// of the interval calibration (`IntervalPart::Onset`): the default drive creeps at 0.69 %,
/// and the surrogate's creep plateau stays below 0.75 % over the shipped box. (It was 0.8 %
/// until the knee-aligned input: that surrogate predicts some onset runs at 0.75-0.80 %, and
/// those 7 of the creep part's 42 held-out runs carried all its errors above 0.007 pp.)
pub const ONSET_SLIP_PCT: f64 = 0.75;

/// Settled mean slip, %, above which a full-order run has settled on the gross-slip branch:
/// the belt slides over the whole driver wrap (no stick zone left; Johnson, Contact Mechanics,
/// 1985, sec. 8.7) and the fan turns as fast as friction alone carries it. The surrogate models the
/// traction branch (creep and the looseness knee) and leaves such runs out, in training
/// (`Surrogate::fit_with_exponents`) and as held-out truths (`rom validate`, interval calibration):
/// one single-valued process cannot fit both branches where the drive is bistable. On the default
/// drive the two lie far apart: the 440-point knee-aligned campaign
/// (`docs/validation/surrogate.md`, "The shipped model") settled at most 5.6 % on the traction
/// branch in 421 runs, and at 32.2 and 32.6 % in two runs whose neighbours settled at 3-5 %; fitted
/// with them, the surrogate predicted 14-33 % across that corner, where the full-order model
/// settles at 3 %. 15 % sits between the branches (on a log scale, about midway).
pub const GROSS_SLIP_PCT: f64 = 15.0;

/// Whether a settled run with mean slip `mean_slip_pct` (%) is on the gross-slip branch
/// ([`GROSS_SLIP_PCT`]).
pub fn on_gross_slip_branch(mean_slip_pct: f64) -> bool {
    mean_slip_pct > GROSS_SLIP_PCT
}

/// The parts of the interval calibration (Mondrian conformal prediction: one conformal
/// quantile per category known at prediction time; Vovk, Gammerman & Shafer, Algorithmic
/// Learning in a Random World, 2005, ch. 4.5): the surrogate's errors at the knee's onset,
/// where the slip curve bends, are several times those of the creep plateau relative to its sd.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntervalPart {
    /// Outside the knee band, predicted mean below `ONSET_SLIP_PCT`.
    Creep,
    /// Outside the knee band, predicted mean from `ONSET_SLIP_PCT`.
    Onset,
    /// In the knee band (traction capacity below `knee_band_n`).
    KneeBand,
}

/// The interval calibration's part of a query of traction capacity `capacity_n` (N) and
/// predicted mean slip `mean_pct` (%), with the knee band below `band_n` (N).
pub fn interval_part(band_n: f64, capacity_n: f64, mean_pct: f64) -> IntervalPart {
    if capacity_n <= band_n {
        IntervalPart::KneeBand
    } else if mean_pct >= ONSET_SLIP_PCT {
        IntervalPart::Onset
    } else {
        IntervalPart::Creep
    }
}

/// The split-conformal factor on the sd for a 90 % interval mean +- Z90 k sd from the held-out
/// scores |error| / sd: k = r_(ceil((n + 1) 0.9)) / Z90 (Lei et al. 2018, sec. 2.2), so that a
/// fresh point exchangeable with them is covered with probability at least 90 %. `None` below
/// `CONFORMAL_MIN_RUNS` scores. The factor is widened by `CONFORMAL_ROUNDING` (relative), so
/// that the run whose score sets it stays covered when its interval is recomputed through
/// other roundings (the sd divided out of the likelihood's and multiplied back): on the
/// shipped model's creep runs that run missed its own interval by one ulp.
pub fn conformal_factor(scores: &[f64]) -> Option<f64> {
    let n = scores.len();
    if n < CONFORMAL_MIN_RUNS {
        return None;
    }
    let mut r = scores.to_vec();
    r.sort_by(f64::total_cmp);
    let k = ((n + 1) as f64 * 0.9).ceil() as usize;
    Some(r[k.min(n) - 1] / crate::stats::Z90 * (1.0 + CONFORMAL_ROUNDING))
}

/// Relative widening of a conformal factor against rounding (`conformal_factor`): far below
/// any score's resolution, far above a few ulps.
pub const CONFORMAL_ROUNDING: f64 = 1e-12;

impl Surrogate {
    /// Calibrates the 90 % predictive intervals on held-out full-order runs (`runs`, made with
    /// the design seeds `seeds`) by split conformal prediction ([`conformal_factor`]), one
    /// factor per [`IntervalPart`]: creep plateau `IntervalCalibration::factor`, the knee's
    /// onset `factor_onset`, the knee band `factor_knee`; a part with fewer than
    /// `CONFORMAL_MIN_RUNS` runs keeps its leave-one-out factor (the onset: the creep part's).
    /// The means and the likelihoods' sd (`std_factor`) are unchanged.
    /// Leave-one-out over an adaptive design overstates the error (its refinement runs sit
    /// where the surrogate was least sure; `docs/validation/surrogate.md`, "Calibrated intervals
    /// and two more rounds"); held-out runs at fresh points do not.
    pub fn calibrate_intervals(
        &mut self,
        runs: &[HeldOutRun],
        seeds: &[u64],
    ) -> Result<IntervalCalibration, RomError> {
        let cfg = self.config()?;
        let band = self.knee_band_upper_n(&cfg);
        if !self.extra_inputs().is_empty() {
            return Err(RomError::InvalidArgument {
                input: crate::Input::HeldOutRuns,
                message: "cannot calibrate this surrogate: it has inputs beyond d, mu and T, \
                          and a validation file records only those three"
                    .into(),
            });
        }
        let (mut outside, mut inside, mut onset) = (Vec::new(), Vec::new(), Vec::new());
        for r in runs {
            if let Some(why) = self.outside_ranges(&r.point) {
                return Err(RomError::InvalidArgument {
                    input: crate::Input::HeldOutRuns,
                    message: format!("include a run outside the trained box: {why}"),
                });
            }
            let p = self.predict_point(&cfg, &r.point)?;
            let u = capacity_feature_n(&cfg, &r.point);
            let raw_sd = p.likelihood_std_pct / self.std_factor(u);
            let score = (p.mean_slip_pct - r.mean_slip_pct).abs() / raw_sd.max(1e-12);
            match interval_part(band, u, p.mean_slip_pct) {
                IntervalPart::KneeBand => inside.push(score),
                IntervalPart::Onset => onset.push(score),
                IntervalPart::Creep => outside.push(score),
            }
        }
        let (out_factor, onset_factor, in_factor) = (
            conformal_factor(&outside),
            conformal_factor(&onset),
            conformal_factor(&inside),
        );
        if out_factor.is_none() && onset_factor.is_none() && in_factor.is_none() {
            return Err(RomError::InvalidArgument {
                input: crate::Input::HeldOutRuns,
                message: format!(
                    "are too few: {} on the creep plateau, {} at the knee's onset and {} in the \
                     knee band, and a 90 % factor needs at least {CONFORMAL_MIN_RUNS} in one of \
                     them",
                    outside.len(),
                    onset.len(),
                    inside.len()
                ),
            });
        }
        let rms = |r: &[f64]| {
            (!r.is_empty()).then(|| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt())
        };
        let record = IntervalCalibration {
            seeds: seeds.to_vec(),
            runs_outside_band: outside.len(),
            runs_in_band: inside.len(),
            factor: out_factor.unwrap_or(self.std_calibration),
            factor_knee: in_factor.unwrap_or_else(|| self.std_factor(f64::NEG_INFINITY)),
            rms_score: rms(&outside),
            rms_score_knee: rms(&inside),
            runs_onset: onset.len(),
            factor_onset: onset_factor,
            rms_score_onset: rms(&onset),
        };
        self.knee_band_n = Some(band);
        self.interval_calibration = Some(record.clone());
        Ok(record)
    }

    /// The knee band's upper traction capacity, N: the one fitted with the surrogate, else
    /// computed for `cfg` over the trained box (`features::knee_band_capacity_n`).
    pub fn knee_band_upper_n(&self, cfg: &DriveConfig) -> f64 {
        self.knee_band_n
            .unwrap_or_else(|| knee_band_capacity_n(cfg, &self.settings.ranges()))
    }

    /// The factor on the processes' sd for the 90 % predictive interval at a query of traction
    /// capacity `capacity_n` (N) whose predicted mean slip is `mean_pct`: the held-out runs'
    /// split-conformal factor of its part ([`IntervalPart`]) when the intervals were
    /// calibrated so (the onset part without enough runs: the creep part's), else
    /// `std_factor`.
    pub fn interval_factor(&self, capacity_n: f64, mean_pct: f64) -> f64 {
        let Some(c) = &self.interval_calibration else {
            return self.std_factor(capacity_n);
        };
        let band = self.knee_band_n.unwrap_or(f64::NEG_INFINITY);
        match interval_part(band, capacity_n, mean_pct) {
            IntervalPart::KneeBand => c.factor_knee,
            IntervalPart::Onset => c.factor_onset.unwrap_or(c.factor),
            IntervalPart::Creep => c.factor,
        }
    }

    /// The calibration factor of the standard deviation at a query of traction capacity
    /// `capacity_n` (N): the knee band's own inside it, else the overall one.
    pub fn std_factor(&self, capacity_n: f64) -> f64 {
        match (self.knee_band_n, self.std_calibration_knee) {
            (Some(band), Some(k)) if capacity_n <= band => k,
            _ => self.std_calibration,
        }
    }
}
