//! Fitting the slip surrogate to a complete data set, and its leave-one-out uncertainty check.

use fom::DesignPoint;
use ndarray::{Array1, Array2};
use rayon::prelude::*;
use training::Dataset;

use super::*;
use crate::features::{capacity_feature_n, knee_band_capacity_n};
use crate::gp;
use crate::snapshots::{from_z, probability_levels, startup_grid_s};
use crate::RomError;

impl Surrogate {
    /// Fits the surrogate to a complete data set, on the capacity itself (no knee-aligned
    /// input: see [`Surrogate::fit_with_exponents`]).
    pub fn fit(ds: &Dataset, energy: f64) -> Result<Self, RomError> {
        Self::fit_with_exponents(ds, energy, &[0.0])
    }

    /// [`Surrogate::fit`] with the knee-aligned input ([`AlignedCapacity`]), its exponent
    /// chosen by likelihood from `exponents` (`FRICTION_EXPONENTS`: `rom train
    /// --knee-aligned`; one entry: that exponent; 0 alone: the capacity itself).
    pub fn fit_with_exponents(
        ds: &Dataset,
        energy: f64,
        exponents: &[f64],
    ) -> Result<Self, RomError> {
        let settings = ds.header.settings.clone();
        let ratio = ds.config.transmission_ratio();
        // Runs on the gross-slip branch are left out (`GROSS_SLIP_PCT`).
        let all = usable_runs(ds)?;
        let ok: Vec<&training::PointRecord> = all
            .iter()
            .copied()
            .filter(|p| !p.status.mean_slip_pct.is_some_and(on_gross_slip_branch))
            .collect();
        let gross_slip_runs = all.len() - ok.len();
        enough_runs(ok.len(), ds, "training runs off the gross-slip branch")?;
        let snaps = ok
            .par_iter()
            .map(|p| {
                let rows = ds.series(p.index)?;
                let start = p.status.steady_start_s.ok_or_else(|| {
                    RomError::Data("a settled run without its steady start".into())
                })?;
                run_snapshots(&rows, &settings, start, ratio)
                    .map_err(|e| RomError::Data(format!("training point {}: {e}", p.index)))
            })
            .collect::<Result<Vec<_>, RomError>>()?;
        let queries: Vec<DesignPoint> = ok.iter().map(|p| p.point).collect();
        let u: Vec<f64> = queries
            .iter()
            .map(|q| capacity_feature_n(&ds.config, q))
            .collect();
        let u_range = [
            u.iter().copied().fold(f64::INFINITY, f64::min),
            u.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ];
        let mut s = Self {
            settings,
            config_toml: ds.config.to_toml_string(),
            capacity_range_n: u_range,
            max_trained_slip_pct: None,
            aligned_capacity: None,
            friction_exponent_likelihoods: Vec::new(),
            capacity_scale: if u_range[0] > 0.0 {
                CapacityScale::Log
            } else {
                CapacityScale::Linear
            },
            ratio,
            startup_time_s: startup_grid_s(ds.header.settings.min_duration_s),
            startup: PodGp {
                basis: empty_basis(),
                gps: Vec::new(),
                means: Vec::new(),
                variances: Vec::new(),
            },
            probability_levels: probability_levels(),
            steady: PodGp {
                basis: empty_basis(),
                gps: Vec::new(),
                means: Vec::new(),
                variances: Vec::new(),
            },
            truncation_var_pct2: 0.0,
            std_calibration: 1.0,
            std_calibration_knee: None,
            knee_band_n: None,
            interval_calibration: None,
            training_runs: ok.len(),
            failed_runs: ds.points.len() - all.len(),
            gross_slip_runs,
        };
        let startup: Vec<Vec<f64>> = snaps.iter().map(|(a, _)| a.clone()).collect();
        let steady: Vec<Vec<f64>> = snaps.iter().map(|(_, b)| b.clone()).collect();
        // The steady processes for each exponent of the knee-aligned input; the largest
        // summed likelihood wins (`AlignedCapacity`). A linear capacity scale has no log to
        // shear: c = 0.
        let exponents: &[f64] = match s.capacity_scale {
            CapacityScale::Log if !exponents.is_empty() => exponents,
            _ => &[0.0],
        };
        type Fitted = (
            f64,
            Option<AlignedCapacity>,
            Array2<f64>,
            PodGp,
            Vec<Vec<f64>>,
        );
        let mut best: Option<Fitted> = None;
        for &c in exponents {
            s.aligned_capacity = (c != 0.0).then(|| {
                let a = queries
                    .iter()
                    .zip(&u)
                    .map(|(q, ui)| ui * q.friction.powf(c));
                AlignedCapacity {
                    friction_exponent: c,
                    range: [
                        a.clone().fold(f64::INFINITY, f64::min),
                        a.fold(f64::NEG_INFINITY, f64::max),
                    ],
                }
            });
            let x = s.inputs(&ds.config, &queries);
            let (fit, coef) = PodGp::fit(&x, &steady, energy, true)?;
            let ll: f64 = fit.gps.iter().map(|g| g.likelihood()).sum();
            s.friction_exponent_likelihoods.push((c, ll));
            if best.as_ref().is_none_or(|b| ll > b.0) {
                best = Some((ll, s.aligned_capacity, x, fit, coef));
            }
        }
        let (_, aligned, x, steady_fit, coef) = best.expect("at least one exponent");
        s.aligned_capacity = aligned;
        // The start-up series is predicted from the mean predictors alone: its processes'
        // Cholesky factors, most of a file's bytes, would only slow every load
        // (`docs/surrogate.md`, "How it is built").
        s.startup = PodGp::fit(&x, &startup, energy, false)?.0;
        s.startup.gps.clear();
        s.steady = steady_fit;
        let mut buf = vec![0.0; s.probability_levels.len()];
        s.max_trained_slip_pct = Some(
            steady
                .iter()
                .map(|z| z.iter().map(|&v| from_z(v)).sum::<f64>() / z.len() as f64)
                .fold(f64::NEG_INFINITY, f64::max),
        );
        s.truncation_var_pct2 = steady
            .iter()
            .map(|z| {
                s.steady
                    .basis
                    .reconstruct_into(&s.steady.basis.project(z), &mut buf);
                let full: f64 = z.iter().map(|&v| from_z(v)).sum::<f64>() / z.len() as f64;
                let kept: f64 = buf.iter().map(|&v| from_z(v)).sum::<f64>() / z.len() as f64;
                (full - kept).powi(2)
            })
            .sum::<f64>()
            / steady.len() as f64;
        let truth: Vec<f64> = steady
            .iter()
            .map(|z| z.iter().map(|&v| from_z(v)).sum::<f64>() / z.len() as f64)
            .collect();
        let band = knee_band_capacity_n(&ds.config, &s.settings.ranges());
        s.knee_band_n = Some(band);
        let in_band: Vec<bool> = u.iter().map(|&ui| ui <= band).collect();
        (s.std_calibration, s.std_calibration_knee) =
            s.loo_std_calibration(&x, &coef, &truth, &in_band)?;
        Ok(s)
    }

    /// Leave-one-out check of the predictive uncertainty of the mean slip: each training run is
    /// predicted by processes refitted without it (length scales held, POD basis kept), and
    /// the standardised errors r_i = (prediction - truth) / sd are collected. Returns the
    /// factor that makes the 90 % interval cover 90 % of them, at least 1 (variance
    /// calibration by cross-validation: Bachoc, Comput. Stat. Data Anal. 66, 2013), over all
    /// runs and over the runs `in_band` (the knee band) alone, when there are at least
    /// `KNEE_CALIBRATION_RUNS`: the processes' variance is stationary, the knee's errors are not.
    fn loo_std_calibration(
        &self,
        x: &Array2<f64>,
        coef: &[Vec<f64>],
        truth: &[f64],
        in_band: &[bool],
    ) -> Result<(f64, Option<f64>), RomError> {
        let n = x.nrows();
        let r: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|i| {
                let keep: Vec<usize> = (0..n).filter(|&j| j != i).collect();
                let xi = x.select(ndarray::Axis(0), &keep);
                let at = x.select(ndarray::Axis(0), &[i]);
                let mut c = Vec::with_capacity(self.steady.gps.len());
                let mut v = Vec::with_capacity(self.steady.gps.len());
                for (k, g) in self.steady.gps.iter().enumerate() {
                    let y: Array1<f64> = keep.iter().map(|&j| coef[j][k]).collect();
                    let refit = gp::fit_fixed(&xi, &y, g)?;
                    let (m, var) = refit
                        .predict_valvar(&at)
                        .map_err(|e| RomError::Fit(format!("leave-one-out prediction: {e}")))?;
                    c.push(m[0]);
                    v.push(var[0]);
                }
                let (_, mean, var) = self.steady.steady_moments(&c, &v);
                Ok((mean - truth[i]).abs() / (var + self.truncation_var_pct2).sqrt().max(1e-12))
            })
            .collect::<Result<Vec<f64>, RomError>>()?;
        let factor = |mut r: Vec<f64>| {
            r.sort_by(f64::total_cmp);
            (fom::stats::quantile(&r, 0.9) / crate::stats::Z90).max(1.0)
        };
        let knee: Vec<f64> = r
            .iter()
            .zip(in_band)
            .filter(|(_, &b)| b)
            .map(|(&ri, _)| ri)
            .collect();
        let knee = (knee.len() >= KNEE_CALIBRATION_RUNS).then(|| factor(knee));
        Ok((factor(r), knee))
    }
}
