//! `rom validate`: the surrogate against fresh full-order runs at Latin-hypercube points that
//! were not in its training set.

use fom::stats::median;
use fom::{DesignPoint, DriveConfig, RunOptions};
use rayon::prelude::*;
use serde::Serialize;
use training::{latin_hypercube, point_config, SeriesRow};

use crate::snapshots::{quantile_function, startup_series, steady_samples};
use crate::stats::Z90;
use crate::surrogate::Surrogate;
use crate::RomError;

/// Mean-slip accuracy target of the issue: max(0.05 percentage points, 2 % of the truth).
pub fn mean_slip_tolerance_pct(truth_pct: f64) -> f64 {
    (0.02 * truth_pct.abs()).max(0.05)
}

/// One validation point.
#[derive(Debug, Clone, Serialize)]
pub struct ValidationPoint {
    pub center_distance_m: f64,
    pub friction: f64,
    pub installation_tension_n: f64,
    /// Set when the full-order run failed; the other figures are then NaN.
    pub error: Option<String>,
    pub fom_mean_slip_pct: f64,
    pub rom_mean_slip_pct: f64,
    pub mean_slip_error_pct: f64,
    pub within_tolerance: bool,
    /// 1-Wasserstein distance between predicted and simulated steady slip distributions, %.
    pub wasserstein1_pct: f64,
    /// Start-up slip series RMSE, %.
    pub startup_rmse_pct: f64,
    /// 90 % predictive interval of the mean slip, %.
    pub interval90_pct: [f64; 2],
    pub covered: bool,
    pub fom_wall_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ValidationReport {
    pub points: Vec<ValidationPoint>,
    pub seed: u64,
    /// Share of (successful) points with the mean slip within tolerance.
    pub within_tolerance_share: f64,
    /// Share of points whose simulated mean lies in the 90 % interval.
    pub coverage90_share: f64,
    pub median_wasserstein1_pct: f64,
    pub max_abs_mean_error_pct: f64,
    pub median_startup_rmse_pct: f64,
}

fn to_series(rows: &[fom::OutputRow]) -> Vec<SeriesRow> {
    rows.iter()
        .map(|r| SeriesRow {
            time_s: r.time_s,
            driver_rpm: r.driver_rpm,
            driven_rpm: r.driven_rpm,
            slip_pct: r.slip_pct,
        })
        .collect()
}

fn compare(
    s: &Surrogate,
    cfg: &DriveConfig,
    q: &DesignPoint,
    rows: &[SeriesRow],
) -> Result<ValidationPoint, RomError> {
    let st = &s.settings;
    let truth = steady_samples(rows, st.steady_start_s);
    if truth.len() < 10 {
        return Err(RomError::Data(
            "too few steady samples in the full-order run".into(),
        ));
    }
    let truth_q = quantile_function(&truth, &s.probability_levels);
    let truth_mean = truth.iter().sum::<f64>() / truth.len() as f64;
    let pred = s.predict_point(cfg, q)?;
    let w1 = pred
        .quantiles_pct
        .iter()
        .zip(&truth_q)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        / truth_q.len() as f64;
    let truth_startup = startup_series(rows, &s.startup_time_s, s.ratio)?;
    let pred_startup = s.predict_startup(cfg, q);
    let rmse = (truth_startup
        .iter()
        .zip(&pred_startup)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / truth_startup.len() as f64)
        .sqrt();
    let err = pred.mean_slip_pct - truth_mean;
    let half = Z90 * pred.surrogate_std_pct;
    let interval = [pred.mean_slip_pct - half, pred.mean_slip_pct + half];
    Ok(ValidationPoint {
        center_distance_m: q.center_distance_m,
        friction: q.friction,
        installation_tension_n: q.installation_tension_n,
        error: None,
        fom_mean_slip_pct: truth_mean,
        rom_mean_slip_pct: pred.mean_slip_pct,
        mean_slip_error_pct: err,
        within_tolerance: err.abs() <= mean_slip_tolerance_pct(truth_mean),
        wasserstein1_pct: w1,
        startup_rmse_pct: rmse,
        interval90_pct: interval,
        covered: truth_mean >= interval[0] && truth_mean <= interval[1],
        fom_wall_s: 0.0,
    })
}

/// Runs the full-order model at `points` fresh Latin-hypercube points (seed `seed`, which must
/// differ from the training seed) and compares. `on_done` is called after each run.
pub fn validate(
    s: &Surrogate,
    points: usize,
    seed: u64,
    on_done: &(dyn Fn(usize) + Sync),
) -> Result<ValidationReport, RomError> {
    let st = &s.settings;
    if seed == st.seed {
        return Err(RomError::Predict(format!(
            "validation seed {seed} is the training seed: the points would be the training points"
        )));
    }
    if points == 0 {
        return Err(RomError::InvalidArgument {
            name: "validation points",
            message: "must be at least 1, got 0".into(),
        });
    }
    let cfg = s.config()?;
    let design = latin_hypercube(&st.ranges(), points, seed);
    let results: Vec<ValidationPoint> = design
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let q = *p;
            let wall = std::time::Instant::now();
            let out = point_config(&cfg, st, p)
                .and_then(|c| fom::simulate(&c, RunOptions::default()))
                .map_err(RomError::from)
                .and_then(|run| compare(s, &cfg, &q, &to_series(&run.rows)));
            on_done(i);
            match out {
                Ok(mut v) => {
                    v.fom_wall_s = wall.elapsed().as_secs_f64();
                    v
                }
                Err(e) => ValidationPoint {
                    center_distance_m: q.center_distance_m,
                    friction: q.friction,
                    installation_tension_n: q.installation_tension_n,
                    error: Some(e.to_string()),
                    fom_mean_slip_pct: f64::NAN,
                    rom_mean_slip_pct: f64::NAN,
                    mean_slip_error_pct: f64::NAN,
                    within_tolerance: false,
                    wasserstein1_pct: f64::NAN,
                    startup_rmse_pct: f64::NAN,
                    interval90_pct: [f64::NAN; 2],
                    covered: false,
                    fom_wall_s: wall.elapsed().as_secs_f64(),
                },
            }
        })
        .collect();
    let ok: Vec<&ValidationPoint> = results.iter().filter(|p| p.error.is_none()).collect();
    let share = |f: &dyn Fn(&ValidationPoint) -> bool| {
        ok.iter().filter(|p| f(p)).count() as f64 / ok.len().max(1) as f64
    };
    Ok(ValidationReport {
        seed,
        within_tolerance_share: share(&|p| p.within_tolerance),
        coverage90_share: share(&|p| p.covered),
        median_wasserstein1_pct: median(ok.iter().map(|p| p.wasserstein1_pct).collect()),
        max_abs_mean_error_pct: ok
            .iter()
            .map(|p| p.mean_slip_error_pct.abs())
            .fold(0.0, f64::max),
        median_startup_rmse_pct: median(ok.iter().map(|p| p.startup_rmse_pct).collect()),
        points: results,
    })
}

impl ValidationReport {
    pub fn to_text(&self) -> String {
        let mut t = String::from(
            "    d (m)     mu   T (N) | FOM mean  ROM mean   error  tol? |   W1   start-up RMSE | \
             90% interval        in?\n",
        );
        for p in &self.points {
            if let Some(e) = &p.error {
                t += &format!(
                    "{:.5} {:.4} {:7.2} | full-order run failed: {e}\n",
                    p.center_distance_m, p.friction, p.installation_tension_n
                );
                continue;
            }
            t += &format!(
                "{:.5} {:.4} {:7.2} | {:8.4} {:8.4} {:+8.4} {:>4} | {:6.4} {:8.4}      | \
                 [{:.4}, {:.4}] {:>4}\n",
                p.center_distance_m,
                p.friction,
                p.installation_tension_n,
                p.fom_mean_slip_pct,
                p.rom_mean_slip_pct,
                p.mean_slip_error_pct,
                if p.within_tolerance { "yes" } else { "NO" },
                p.wasserstein1_pct,
                p.startup_rmse_pct,
                p.interval90_pct[0],
                p.interval90_pct[1],
                if p.covered { "yes" } else { "NO" }
            );
        }
        let failed = self.points.iter().filter(|p| p.error.is_some()).count();
        t += &format!(
            "summary: {} points ({} failed), mean slip within max(0.05 pp, 2 %) at {:.0} % \
             (target >= 90 %), 90 % intervals cover {:.0} % (target >= 80 %), largest error \
             {:.4} pp, median W1 {:.4} %, median start-up RMSE {:.4} %",
            self.points.len(),
            failed,
            100.0 * self.within_tolerance_share,
            100.0 * self.coverage90_share,
            self.max_abs_mean_error_pct,
            self.median_wasserstein1_pct,
            self.median_startup_rmse_pct
        );
        t
    }
}
