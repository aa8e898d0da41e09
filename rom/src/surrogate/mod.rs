//! The fitted surrogate: POD + one Gaussian process per coefficient, for the start-up slip
//! series and for the steady-state slip quantile function; fitting and evaluation.
//!
//! `pod_gp` is the POD + process pair both outputs use; `fit` fits the surrogate to a data set;
//! `evaluate` predicts (point, friction mixture, start-up); `domain` decides where it may answer;
//! `intervals` calibrates its 90 % intervals.

mod domain;
mod evaluate;
mod fit;
mod intervals;
mod pod_gp;

pub use intervals::*;
pub use pod_gp::{PodGp, DEFAULT_ENERGY};

use serde::{Deserialize, Serialize};
use training::{CampaignSettings, Dataset};

use crate::pod::PodBasis;
use crate::snapshots::{
    from_z, probability_levels, quantile_function, startup_grid_s, startup_series, steady_samples,
    to_z,
};
use crate::RomError;

/// How far above the largest training run's mean slip a prediction may go (x 1.25).
pub const OUTPUT_MARGIN: f64 = 1.25;

/// The fitted surrogate (the payload of a surrogate file).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Surrogate {
    /// The campaign it was trained on (ranges, run length, sample count, seed).
    pub settings: CampaignSettings,
    /// The full-order configuration of the campaign (canonical TOML).
    pub config_toml: String,
    /// Range of the traction-capacity feature over the training points, N (input scaling).
    pub capacity_range_n: [f64; 2],
    /// How the capacity feature is scaled onto [0, 1] (older files: linear).
    #[serde(default)]
    pub capacity_scale: CapacityScale,
    /// The knee-aligned capacity input (files before it: the capacity itself). See
    /// [`AlignedCapacity`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aligned_capacity: Option<AlignedCapacity>,
    /// The exponents c tried for it at fit time, each with the steady processes' summed log
    /// likelihood (empty in files before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub friction_exponent_likelihoods: Vec<(f64, f64)>,
    /// Largest steady mean slip of a training run, % (older files: absent, no output
    /// check). See [`Surrogate::beyond_trained_slip`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_trained_slip_pct: Option<f64>,
    /// Transmission ratio R_t = driven / driver pitch diameter (paper eq. 1).
    pub ratio: f64,
    /// Start-up grid (cell ends, s from motor start).
    pub startup_time_s: Vec<f64>,
    pub startup: PodGp,
    /// Probability levels of the steady-state quantile function.
    pub probability_levels: Vec<f64>,
    pub steady: PodGp,
    /// Mean square of the mean-slip error from POD truncation on the training set, %^2.
    pub truncation_var_pct2: f64,
    /// Factor on the Gaussian-process standard deviation of the mean slip from the
    /// leave-one-out check over all training runs (1 = the processes' own variance was already
    /// calibrated): the sd the twin's likelihoods take (`std_factor`), and the predictive
    /// intervals' unless `interval_calibration` replaces it there.
    pub std_calibration: f64,
    /// The same factor from the training runs in the knee band alone (traction capacity below
    /// `knee_band_n`), applied to queries in that band; `None` (files older than the knee band's
    /// own factor, or fewer than `KNEE_CALIBRATION_RUNS` runs in the band): `std_calibration`
    /// everywhere.
    #[serde(default)]
    pub std_calibration_knee: Option<f64>,
    /// The knee band's upper traction capacity, N (`features::knee_band_capacity_n`).
    #[serde(default)]
    pub knee_band_n: Option<f64>,
    /// Set when the 90 % predictive intervals are calibrated on held-out full-order runs
    /// (`Surrogate::calibrate_intervals`); `None`: they take the leave-one-out factors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interval_calibration: Option<IntervalCalibration>,
    /// Training runs used (finished) and failed.
    pub training_runs: usize,
    pub failed_runs: usize,
    /// Finished runs left out as settled on the gross-slip branch (`GROSS_SLIP_PCT`; files
    /// before it: 0).
    #[serde(default)]
    pub gross_slip_runs: usize,
}

/// Scaling of the traction-capacity input onto [0, 1] over its training range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CapacityScale {
    /// (u - lo) / (hi - lo).
    #[default]
    Linear,
    /// (ln u - ln lo) / (ln hi - ln lo): the knee sits at the low end of the capacity range
    /// (on the default drive below ~150 N of 77-680 N) and a stationary Gaussian process
    /// needs finer resolution there than over the flat creep plateau; the logarithm gives the
    /// knee ~30 % of the input instead of ~10 %. Used when the training capacities are all
    /// positive. Measured with `NUGGET` (knee means within tolerance 12 of 12 against 7 of
    /// 12 with the linear scale, on stored full-order truths; `docs/validation/surrogate.md`,
    /// "Earlier models").
    Log,
}

impl CapacityScale {
    pub fn unit(self, u: f64, [lo, hi]: [f64; 2]) -> f64 {
        match self {
            CapacityScale::Linear => (u - lo) / (hi - lo),
            // Below the trained minimum (extrapolation allowed) the log continues; a slack
            // belt (u <= 0) is clamped to a far point rather than NaN.
            CapacityScale::Log => (u.max(1e-3 * lo).ln() - lo.ln()) / (hi.ln() - lo.ln()),
        }
    }
}

/// The processes' third input as u mu^c on the log scale, u the traction capacity
/// (`features::capacity_feature_n`). The capstan law's capacity does not put the knee on one
/// axis: on held-out full-order runs of the default drive at 1.5-3.5 % slip, settled slip at
/// equal capacity falls as mu^-1.7, so a product kernel over (d, mu, ln u) must resolve a
/// cliff that runs obliquely in (mu, ln u). The shear ln u + c ln mu is a one-parameter
/// metric of the kernel, chosen with the length scales by maximum likelihood (type-II maximum
/// likelihood over a kernel family: Rasmussen & Williams, Gaussian Processes for Machine
/// Learning, 2006, sec. 5.1 and 5.4) over `FRICTION_EXPONENTS`; c = 0 is the capacity itself.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AlignedCapacity {
    /// The exponent c.
    pub friction_exponent: f64,
    /// Range of u mu^c over the training points (input scaling).
    pub range: [f64; 2],
}

/// The exponents c of [`AlignedCapacity`] tried at fit time.
pub const FRICTION_EXPONENTS: [f64; 6] = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0];

/// The surrogate's answer at one point, without friction uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct PointPrediction {
    /// Steady slip quantile function at `probability_levels`, %, non-decreasing.
    pub quantiles_pct: Vec<f64>,
    pub mean_slip_pct: f64,
    /// Standard deviation of the predicted mean slip: Gaussian-process variance propagated
    /// through the POD modes and the output transform, plus POD truncation, %, scaled so that
    /// mean +- 1.645 sd is the 90 % predictive interval (`Surrogate::interval_factor`).
    pub surrogate_std_pct: f64,
    /// The same variance scaled as the twin's Gaussian likelihoods take the surrogate's error
    /// (`Surrogate::std_factor`, leave-one-out; `rom calibrate`, `rom diagnose`, `rom gap`),
    /// %. Equal to `surrogate_std_pct` until the intervals are calibrated on held-out runs.
    pub likelihood_std_pct: f64,
}

/// Training snapshots of one settled run whose steady window starts at `steady_start_s`
/// (`fom::steady`, recorded by the campaign): (start-up z-series, steady quantile z-function).
pub fn run_snapshots(
    rows: &[training::SeriesRow],
    settings: &CampaignSettings,
    steady_start_s: f64,
    ratio: f64,
) -> Result<(Vec<f64>, Vec<f64>), RomError> {
    let grid = startup_grid_s(settings.min_duration_s);
    let startup = startup_series(rows, &grid, ratio)?;
    let steady = steady_samples(rows, steady_start_s);
    if steady.len() < 10 {
        return Err(RomError::Data(format!(
            "only {} steady-window samples after t = {steady_start_s} s (need at least 10)",
            steady.len(),
        )));
    }
    let q = quantile_function(&steady, &probability_levels());
    Ok((
        startup.into_iter().map(to_z).collect(),
        q.into_iter().map(to_z).collect(),
    ))
}

/// Slip (%) from transformed values `z` at the probability levels, in increasing order: the
/// monotone rearrangement, as a quantile function cannot decrease (Chernozhukov,
/// Fernández-Val & Galichon, Econometrica 78, 2010).
pub(crate) fn rearranged_slip(z: &[f64]) -> Vec<f64> {
    let mut s: Vec<f64> = z.iter().map(|&v| from_z(v)).collect();
    s.sort_unstable_by(f64::total_cmp);
    s
}

/// The runs of a data set that are data points (`ok`), refused when fewer than
/// `training::MIN_FIT_SAMPLES`; for the slip and the tooth-load surrogate alike.
pub(crate) fn usable_runs(ds: &Dataset) -> Result<Vec<&training::PointRecord>, RomError> {
    let ok: Vec<&training::PointRecord> = ds.points.iter().filter(|p| p.status.is_ok()).collect();
    enough_runs(ok.len(), ds, "finished training runs")?;
    Ok(ok)
}

/// Refuses a fit on fewer than `training::MIN_FIT_SAMPLES` runs (`what` names them).
pub(crate) fn enough_runs(n: usize, ds: &Dataset, what: &str) -> Result<(), RomError> {
    if n < training::MIN_FIT_SAMPLES {
        return Err(RomError::Fit(format!(
            "{n} {what} in {} (need at least {})",
            ds.dir.display(),
            training::MIN_FIT_SAMPLES
        )));
    }
    Ok(())
}

/// Chebyshev nodes over the friction samples' span in `Surrogate::friction_quantile_functions`.
pub const MIXTURE_NODES: usize = 8;

pub(crate) fn empty_basis() -> PodBasis {
    PodBasis {
        mean: Vec::new(),
        modes: Vec::new(),
        singular_values: Vec::new(),
        energy_kept: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::{conformal_factor, CapacityScale, CONFORMAL_MIN_RUNS, CONFORMAL_ROUNDING};
    use crate::stats::Z90;

    #[test]
    fn conformal_factor_is_the_finite_sample_quantile_of_the_scores() {
        // n = 9: ceil(10 x 0.9) = 9, the largest score; n = 19: the 18th smallest.
        let nine: Vec<f64> = (1..=9).map(f64::from).collect();
        let widen = 1.0 + CONFORMAL_ROUNDING;
        assert_eq!(conformal_factor(&nine), Some(9.0 / Z90 * widen));
        let nineteen: Vec<f64> = (1..=19).rev().map(f64::from).collect();
        assert_eq!(conformal_factor(&nineteen), Some(18.0 / Z90 * widen));
        assert_eq!(conformal_factor(&nine[..CONFORMAL_MIN_RUNS - 1]), None);
        // Whatever the scores, at least 90 % of them lie within the factor's interval.
        for n in CONFORMAL_MIN_RUNS..60 {
            let scores: Vec<f64> = (0..n).map(|i| ((i * 7919) % 97) as f64 * 0.01).collect();
            let k = conformal_factor(&scores).unwrap() * Z90;
            let inside = scores.iter().filter(|&&r| r <= k).count();
            assert!(inside as f64 >= 0.9 * n as f64, "n {n}: {inside} inside");
        }
        // Scores made as |error| / sd and the interval recomputed as Z90 factor sd: the run
        // that sets the factor is inside despite the two roundings (without the widening, an
        // error of 1 mm/s on an sd of 13 mm/s falls 2e-19 outside its own interval).
        let (err, sd) = (0.001, 0.013);
        let f = conformal_factor(&[err / sd; CONFORMAL_MIN_RUNS]).unwrap();
        assert!(err <= Z90 * (f * sd), "{} > {}", err, Z90 * (f * sd));
    }

    #[test]
    fn capacity_scales_map_the_training_range_onto_the_unit_interval() {
        let range = [77.0, 680.0];
        for scale in [CapacityScale::Linear, CapacityScale::Log] {
            assert!(scale.unit(77.0, range).abs() < 1e-12);
            assert!((scale.unit(680.0, range) - 1.0).abs() < 1e-12);
            let xs: Vec<f64> = [60.0, 100.0, 150.0, 300.0, 700.0]
                .iter()
                .map(|&u| scale.unit(u, range))
                .collect();
            assert!(xs.windows(2).all(|w| w[0] < w[1]), "{scale:?}: {xs:?}");
        }
        // The log scale gives the knee's capacities (77-150 N) a larger share of the input.
        let knee = |s: CapacityScale| s.unit(150.0, range);
        assert!(knee(CapacityScale::Log) > 2.5 * knee(CapacityScale::Linear));
        // A slack belt (no capacity) maps to a finite point below the range.
        assert!(CapacityScale::Log.unit(-5.0, range).is_finite());
        // Files written before the scale existed read as linear.
        let old: CapacityScale = serde_json::from_str::<Option<CapacityScale>>("null")
            .unwrap()
            .unwrap_or_default();
        assert_eq!(old, CapacityScale::Linear);
    }
}
