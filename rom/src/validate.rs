//! `rom validate`: the surrogate against fresh full-order runs at Latin-hypercube points that
//! were not in its training set.

use fom::stats::median;
use fom::{DesignPoint, DriveConfig, RunOptions};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use training::{latin_hypercube, point_config, SeriesRow};

use crate::snapshots::{quantile_function, startup_series, steady_samples};
use crate::surrogate::{
    interval_part, on_gross_slip_branch, HeldOutRun, IntervalPart, Surrogate, GROSS_SLIP_PCT,
};
use crate::RomError;

/// Settled full-order slip from which a point counts as the looseness knee, % (the default
/// drive creeps at 0.69 %; creep theory stays below 1 % on the trained box's tight half).
pub const KNEE_SLIP_PCT: f64 = 1.0;

/// Where a validation point lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Region {
    /// Settled slip below `KNEE_SLIP_PCT`.
    Creep,
    /// Settled slip from `KNEE_SLIP_PCT` up: the looseness knee and beyond.
    Knee,
}

impl Region {
    pub fn of(truth_pct: f64) -> Self {
        if truth_pct >= KNEE_SLIP_PCT {
            Region::Knee
        } else {
            Region::Creep
        }
    }

    /// Mean-slip accuracy target (`docs/surrogate.md`, "Where it is trusted"): creep
    /// max(0.05 pp, 2 %), knee max(0.1 pp, 5 %).
    pub fn mean_tolerance_pct(self, truth_pct: f64) -> f64 {
        match self {
            Region::Creep => (0.02 * truth_pct.abs()).max(0.05),
            Region::Knee => (0.05 * truth_pct.abs()).max(0.1),
        }
    }

    /// Quantile accuracy target at the knee (`docs/surrogate.md`, "Where it is trusted"):
    /// max(0.2 pp, 10 %) at p05-p95.
    pub fn quantile_tolerance_pct(truth_pct: f64) -> f64 {
        (0.1 * truth_pct.abs()).max(0.2)
    }
}

/// Mean-slip accuracy target at a settled slip `truth_pct`, %, for its region.
pub fn mean_slip_tolerance_pct(truth_pct: f64) -> f64 {
    Region::of(truth_pct).mean_tolerance_pct(truth_pct)
}

/// One validation point.
#[derive(Debug, Clone, Serialize)]
pub struct ValidationPoint {
    pub center_distance_m: f64,
    pub friction: f64,
    pub installation_tension_n: f64,
    /// Set when the full-order run failed or did not settle; the other figures are then NaN.
    pub error: Option<String>,
    /// Region by the settled full-order slip (`None` when the run failed).
    pub region: Option<Region>,
    /// Largest error of the p05..p95 quantiles (5 % steps), %, and whether each is within
    /// `Region::quantile_tolerance_pct`.
    pub max_quantile_error_pct: f64,
    pub quantiles_within: bool,
    pub fom_mean_slip_pct: f64,
    /// Standard error of the full-order steady mean, percentage points: the truth's own noise
    /// over its steady window (`fom::steady::DriftTest::mean_se_pp`; NaN when the run failed).
    /// Reported beside the error, not used to widen the tolerance.
    pub fom_mean_se_pct: f64,
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
    /// The same shares per region (creep, knee).
    pub regions: Vec<RegionSummary>,
    /// SHA-256 of the drive configuration the surrogate was trained on (its file header's
    /// `config_sha256`): what `rom validate --calibrate-intervals` checks the file against.
    /// Files written before it existed lack it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config_sha256: Option<String>,
}

/// A `rom validate --json` file as read back for interval calibration: only the fields that
/// calibration needs (other fields are ignored).
#[derive(Debug, Deserialize)]
struct StoredReport {
    seed: u64,
    #[serde(default)]
    config_sha256: Option<String>,
    points: Vec<StoredPoint>,
}

#[derive(Debug, Deserialize)]
struct StoredPoint {
    center_distance_m: f64,
    friction: f64,
    installation_tension_n: f64,
    error: Option<String>,
    fom_mean_slip_pct: Option<f64>,
}

/// The settled full-order runs of a `rom validate --json` file `path` (failed or unsettled
/// points left out) and its design seed, for a surrogate trained on the configuration with
/// SHA-256 `config_sha256`: a file that names another configuration is refused. The third
/// value says whether the file named its configuration (files before that field did not).
pub fn read_held_out(
    path: &std::path::Path,
    config_sha256: &str,
) -> Result<(u64, Vec<HeldOutRun>, bool), RomError> {
    let origin = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| RomError::Data(format!("{origin}: cannot read: {e}")))?;
    let r: StoredReport = serde_json::from_str(&text).map_err(|e| {
        RomError::Data(format!(
            "{origin}: not a `rom validate --json` file of the slip surrogate: {e}"
        ))
    })?;
    if let Some(sha) = &r.config_sha256 {
        if sha != config_sha256 {
            return Err(RomError::Data(format!(
                "{origin}: its runs are of another drive configuration (sha256 {sha}) than \
                 the surrogate's ({config_sha256})"
            )));
        }
    }
    let mut runs = Vec::new();
    for (i, p) in r.points.iter().enumerate() {
        if p.error.is_some() {
            continue;
        }
        match p.fom_mean_slip_pct {
            // A run on the gross-slip branch is no truth for the traction-branch surrogate.
            Some(m) if on_gross_slip_branch(m) => {}
            Some(m) if m.is_finite() => runs.push(HeldOutRun {
                point: DesignPoint::drive(
                    p.center_distance_m,
                    p.friction,
                    p.installation_tension_n,
                    None,
                ),
                mean_slip_pct: m,
            }),
            _ => {
                return Err(RomError::Data(format!(
                    "{origin}: point {} (0-based) has no error and no finite full-order mean \
                     slip `fom_mean_slip_pct`",
                    i
                )))
            }
        }
    }
    Ok((r.seed, runs, r.config_sha256.is_some()))
}

/// Accuracy of the points of one region.
#[derive(Debug, Clone, Serialize)]
pub struct RegionSummary {
    pub region: Region,
    pub points: usize,
    /// Share with the mean slip within the region's tolerance.
    pub within_tolerance_share: f64,
    /// Share whose p05..p95 are all within max(0.2 pp, 10 %).
    pub quantiles_within_share: f64,
    pub coverage90_share: f64,
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

/// Quantile at probability `p` of a quantile function given at `levels`, linear between levels
/// and held at the ends.
fn interpolate_quantile(levels: &[f64], q: &[f64], p: f64) -> f64 {
    let k = levels.partition_point(|&l| l < p);
    if k == 0 {
        return q[0];
    }
    if k == levels.len() {
        return q[q.len() - 1];
    }
    let w = (p - levels[k - 1]) / (levels[k] - levels[k - 1]);
    q[k - 1] + w * (q[k] - q[k - 1])
}

/// Compares the surrogate at `q` with a settled full-order run: its `rows`, steady from
/// `steady_start_s`, whose mean has the standard error `truth_se_pp`.
fn compare(
    s: &Surrogate,
    cfg: &DriveConfig,
    q: &DesignPoint,
    rows: &[SeriesRow],
    steady_start_s: f64,
    truth_se_pp: f64,
) -> Result<ValidationPoint, RomError> {
    let truth = steady_samples(rows, steady_start_s);
    if truth.len() < 10 {
        return Err(RomError::Data(
            "too few steady samples in the full-order run".into(),
        ));
    }
    let truth_q = quantile_function(&truth, &s.probability_levels);
    let truth_mean = truth.iter().sum::<f64>() / truth.len() as f64;
    let pred = s.predict_point(cfg, q)?;
    if let Some(why) = s.beyond_trained_slip(pred.mean_slip_pct) {
        // What `rom predict` refuses is not a prediction to score.
        return Err(RomError::Extrapolation {
            reason: format!("refused by the surrogate: {why}"),
        });
    }
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
    // p05..p95 in 5 % steps, from both quantile functions (same probability levels).
    let (mut max_q_err, mut q_within) = (0.0f64, true);
    for k in 1..=19 {
        let p = k as f64 * 0.05;
        let truth_p = fom::stats::quantile(&truth, p);
        let pred_p = interpolate_quantile(&s.probability_levels, &pred.quantiles_pct, p);
        let e = (pred_p - truth_p).abs();
        max_q_err = max_q_err.max(e);
        q_within &= e <= Region::quantile_tolerance_pct(truth_p);
    }
    let err = pred.mean_slip_pct - truth_mean;
    let interval = crate::predict::mean_interval90_pct(pred.mean_slip_pct, pred.surrogate_std_pct);
    Ok(ValidationPoint {
        center_distance_m: q.center_distance_m,
        friction: q.friction,
        installation_tension_n: q.installation_tension_n,
        error: None,
        region: Some(Region::of(truth_mean)),
        max_quantile_error_pct: max_q_err,
        quantiles_within: q_within,
        fom_mean_slip_pct: truth_mean,
        fom_mean_se_pct: truth_se_pp,
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
    check_request(s, points, seed)?;
    let design = latin_hypercube(&s.settings.ranges(), points, seed);
    validate_at(s, &design, seed, on_done)
}

/// Refuses the training seed (the points would be the training points) and zero points.
/// Also refuses a seed whose runs calibrated the surrogate's intervals: coverage there is not a
/// fresh check.
fn check_request(s: &Surrogate, points: usize, seed: u64) -> Result<(), RomError> {
    check_validation_request(&s.settings, points, seed)?;
    if let Some(c) = s
        .interval_calibration
        .as_ref()
        .filter(|c| c.seeds.contains(&seed))
    {
        return Err(RomError::Predict(format!(
            "validation seed {seed} made held-out runs that the surrogate's 90 % intervals were \
             calibrated on (seeds {:?}): coverage at its points is no fresh check; use another \
             seed",
            c.seeds
        )));
    }
    Ok(())
}

/// Refuses the training seed of `settings` (the points would be the training points) and zero
/// points; for the slip and the tooth-load surrogate alike.
pub fn check_validation_request(
    settings: &training::CampaignSettings,
    points: usize,
    seed: u64,
) -> Result<(), RomError> {
    if seed == settings.seed {
        return Err(RomError::Predict(format!(
            "validation seed {seed} is the training seed: the points would be the training points"
        )));
    }
    if points == 0 {
        return Err(RomError::InvalidArgument {
            input: crate::Input::ValidationPoints,
            message: "must be at least 1, got 0".into(),
        });
    }
    Ok(())
}

/// Candidates drawn per point of a knee design.
pub const KNEE_CANDIDATES_PER_POINT: usize = 50;

/// `points` fresh points at the looseness knee, chosen by physics and not by the surrogate
/// under test: a Latin hypercube of `KNEE_CANDIDATES_PER_POINT` x `points` over the trained
/// box (seed `seed`), of which those in the knee band (traction capacity below
/// `features::knee_band_capacity_n`, the loosest `features::KNEE_CAPACITY_SHARE` of the box)
/// that the surrogate accepts, in design order. Each point's region (creep or knee) is still
/// decided by its full-order run. Fewer points when fewer qualify.
pub fn knee_design(s: &Surrogate, points: usize, seed: u64) -> Result<Vec<DesignPoint>, RomError> {
    let (cfg, candidates, band) = candidates_and_band(s, points, seed)?;
    Ok(candidates
        .into_iter()
        .filter(|q| {
            crate::features::capacity_feature_n(&cfg, q) <= band
                && s.extrapolation(&cfg, q).is_none()
        })
        .take(points)
        .collect())
}

/// The checked request's configuration, the `KNEE_CANDIDATES_PER_POINT` x `points` candidates
/// of a Latin hypercube over the trained box (seed `seed`), and the knee band's upper traction
/// capacity, N: what the knee and the onset designs choose from.
fn candidates_and_band(
    s: &Surrogate,
    points: usize,
    seed: u64,
) -> Result<(fom::ValidConfig, Vec<DesignPoint>, f64), RomError> {
    check_request(s, points, seed)?;
    let cfg = s.config()?;
    let candidates = latin_hypercube(
        &s.settings.ranges(),
        KNEE_CANDIDATES_PER_POINT * points.max(1),
        seed,
    );
    let band = s.knee_band_upper_n(&cfg);
    Ok((cfg, candidates, band))
}

/// `points` fresh points at the knee's onset outside the knee band: those of a Latin hypercube
/// of `KNEE_CANDIDATES_PER_POINT` x `points` over the trained box (seed `seed`) whose traction
/// capacity lies above the knee band and whose predicted mean slip reaches
/// `surrogate::ONSET_SLIP_PCT`, accepted by the surrogate, in design order: the population of
/// the interval calibration's onset part (`surrogate::IntervalPart::Onset`), which a uniform
/// design meets at 1-2 points in 40. Fewer points when fewer qualify.
pub fn onset_design(s: &Surrogate, points: usize, seed: u64) -> Result<Vec<DesignPoint>, RomError> {
    let (cfg, candidates, band) = candidates_and_band(s, points, seed)?;
    let mut out = Vec::new();
    for q in candidates {
        if out.len() == points {
            break;
        }
        let u = crate::features::capacity_feature_n(&cfg, &q);
        if u <= band || s.extrapolation(&cfg, &q).is_some() {
            continue;
        }
        let p = s.predict_point(&cfg, &q)?;
        if interval_part(band, u, p.mean_slip_pct) == IntervalPart::Onset
            && s.beyond_trained_slip(p.mean_slip_pct).is_none()
        {
            out.push(q);
        }
    }
    Ok(out)
}

/// A compared point whose full-order run settled on the gross-slip branch is no truth for
/// the traction-branch surrogate (`rom::surrogate::GROSS_SLIP_PCT`; `read_held_out` skips such
/// stored runs).
fn on_traction_branch(v: ValidationPoint) -> Result<ValidationPoint, RomError> {
    if on_gross_slip_branch(v.fom_mean_slip_pct) {
        return Err(RomError::Data(format!(
            "the full-order run settled on the gross-slip branch at {:.2} % mean slip (above \
             {GROSS_SLIP_PCT} %), which the surrogate does not model",
            v.fom_mean_slip_pct
        )));
    }
    Ok(v)
}

/// Runs the full-order model at the points of `design` (made with `seed`) and compares.
pub fn validate_at(
    s: &Surrogate,
    design: &[DesignPoint],
    seed: u64,
    on_done: &(dyn Fn(usize) + Sync),
) -> Result<ValidationReport, RomError> {
    let st = &s.settings;
    let cfg = s.config()?;
    let results: Vec<ValidationPoint> = design
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let q = *p;
            let wall = std::time::Instant::now();
            let out = point_config(&cfg, st, p)
                .and_then(|c| fom::simulate(&c, RunOptions::default()))
                .map_err(RomError::from)
                .and_then(|run| match run.summary.steady_data() {
                    Ok(start_s) => compare(
                        s,
                        &cfg,
                        &q,
                        &to_series(&run.rows),
                        start_s,
                        run.summary.mean_slip_se_pp().unwrap_or(f64::NAN),
                    ),
                    Err(why) => Err(RomError::Data(format!(
                        "the full-order run is no steady truth: {why}"
                    ))),
                })
                .and_then(on_traction_branch);
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
                    region: None,
                    max_quantile_error_pct: f64::NAN,
                    quantiles_within: false,
                    fom_mean_slip_pct: f64::NAN,
                    fom_mean_se_pct: f64::NAN,
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
        regions: [Region::Creep, Region::Knee]
            .into_iter()
            .map(|region| {
                let of: Vec<&&ValidationPoint> =
                    ok.iter().filter(|p| p.region == Some(region)).collect();
                let share = |f: &dyn Fn(&ValidationPoint) -> bool| {
                    of.iter().filter(|p| f(p)).count() as f64 / of.len().max(1) as f64
                };
                RegionSummary {
                    region,
                    points: of.len(),
                    within_tolerance_share: share(&|p| p.within_tolerance),
                    quantiles_within_share: share(&|p| p.quantiles_within),
                    coverage90_share: share(&|p| p.covered),
                }
            })
            .collect(),
        points: results,
        config_sha256: None,
    })
}

impl ValidationReport {
    pub fn to_text(&self) -> String {
        let mut t = String::from(
            "    d (m)     mu   T (N) region | FOM mean (its se)  ROM mean   error  tol? | \
             quantiles | W1   start-up RMSE | 90% interval        in?\n",
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
                "{:.5} {:.4} {:7.2} {:>6} | {:8.4} ({:6.4}) {:8.4} {:+8.4} {:>4} | {:9} | {:6.4} \
                 {:8.4}      | [{:.4}, {:.4}] {:>4}\n",
                p.center_distance_m,
                p.friction,
                p.installation_tension_n,
                match p.region {
                    Some(Region::Knee) => "knee",
                    _ => "creep",
                },
                p.fom_mean_slip_pct,
                p.fom_mean_se_pct,
                p.rom_mean_slip_pct,
                p.mean_slip_error_pct,
                if p.within_tolerance { "yes" } else { "NO" },
                format!(
                    "{:.3}{}",
                    p.max_quantile_error_pct,
                    if p.quantiles_within { "" } else { "!" }
                ),
                p.wasserstein1_pct,
                p.startup_rmse_pct,
                p.interval90_pct[0],
                p.interval90_pct[1],
                if p.covered { "yes" } else { "NO" }
            );
        }
        let failed = self.points.iter().filter(|p| p.error.is_some()).count();
        for r in &self.regions {
            let (name, tol) = match r.region {
                Region::Creep => ("creep", "max(0.05 pp, 2 %)"),
                Region::Knee => ("knee ", "max(0.1 pp, 5 %)"),
            };
            t += &format!(
                "{name} (settled slip {} {KNEE_SLIP_PCT} %): {} points, mean within {tol} at \
                 {:.0} %, p05-p95 within max(0.2 pp, 10 %) at {:.0} %, 90 % intervals cover \
                 {:.0} %\n",
                if r.region == Region::Knee { ">=" } else { "<" },
                r.points,
                100.0 * r.within_tolerance_share,
                100.0 * r.quantiles_within_share,
                100.0 * r.coverage90_share
            );
        }
        t += &format!(
            "summary: {} points ({} failed, unsettled, unbalanced, on the gross-slip branch or refused), mean slip within its region's \
             tolerance at {:.0} % \
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
