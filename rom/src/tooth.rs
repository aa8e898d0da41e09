//! The tooth-load surrogate of a toothed belt (`docs/surrogate.md`, "The tooth-load
//! surrogate"): POD + one Gaussian process per
//! coefficient over side gap, load torque and shaft load, predicting the distribution of the
//! maximum tooth load (the tooth-root load's peak of every tooth pass through a wrap in the
//! tooth-load window, `fom::belt_kind::tooth_record::tooth_load_window_start_s`) and the run's
//! largest tooth load. The same POD and Gaussian-process machinery as the slip surrogate
//! (`surrogate::PodGp`), its own file (`beltwin-tooth-surrogate/1`, the same header-and-checksum
//! layout).

use std::path::Path;

use fom::params::Variable;
use fom::{DesignPoint, DriveConfig};
use ndarray::{Array1, Array2};
use serde::{Deserialize, Serialize};
use training::{CampaignSettings, Dataset};

use crate::gp;
use crate::model_file::{
    checked_drive_config, file_sha256, now_utc, open_model, read_header_line, read_payload,
    save_sealed,
};
use crate::snapshots::quantile_function;
use crate::stats::Z90;
use crate::surrogate::{PodGp, DEFAULT_ENERGY};
use crate::RomError;

/// Format of a tooth-load surrogate file.
pub const FORMAT: &str = "beltwin-tooth-surrogate/1";

/// Probability levels of the pass-peak quantile function: (j + 1/2) / 20. The shipped drive's
/// window holds 46 complete passes (two 22-tooth pulleys at 1000 r/min over 0.1 s, less the
/// passes not complete by the end); a run needs at least one pass per level.
pub const TOOTH_LEVELS: usize = 20;

/// The fitted tooth-load surrogate (the payload of its file). Outputs are learnt as natural
/// logarithms of loads in newtons: loads are positive and their errors relative.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ToothSurrogate {
    /// The campaign it was trained on ([tooth] ranges, sample count, seed).
    pub settings: CampaignSettings,
    /// The full-order configuration of the campaign (canonical TOML).
    pub config_toml: String,
    /// Probability levels of the pass-peak quantile function.
    pub probability_levels: Vec<f64>,
    /// POD + processes of the snapshot [ln q(p_1), ..., ln q(p_P), ln max]: the pass-peak
    /// quantile function and the run's largest instantaneous flank load.
    pub model: PodGp,
    /// Mean square POD truncation error of each snapshot entry over the training runs.
    pub truncation_var: Vec<f64>,
    /// Factor on the processes' standard deviation from the leave-one-out check (root mean
    /// square of the leave-one-out z-scores of ln(mean peak) and ln(max), at least 1).
    pub std_calibration: f64,
    /// Leave-one-out relative errors over the training runs, root mean square: the mean pass
    /// peak and the run's largest load.
    pub loo_rms_rel: [f64; 2],
    pub training_runs: usize,
    pub failed_runs: usize,
}

/// The surrogate's answer at one point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ToothPrediction {
    pub side_gap_m: f64,
    pub load_torque_nm: f64,
    pub shaft_load_n: f64,
    /// Mean of the pass peaks, N, with its 90 % interval.
    pub mean_peak_n: f64,
    pub mean_peak_interval_n: [f64; 2],
    /// Quantiles of the pass peaks, N: p05, p25, p50, p75, p95.
    pub peak_quantiles_n: [f64; 5],
    /// The run's largest instantaneous flank load (seed paper's maximum root load), N, with
    /// its 90 % interval.
    pub max_n: f64,
    pub max_interval_n: [f64; 2],
    /// True when a request outside the trained ranges was allowed (`--allow-extrapolation`).
    pub extrapolated: bool,
    /// The inputs outside their trained ranges.
    pub outside: Vec<crate::physical::Outside>,
}

/// The snapshot of one toothed training run: ln of the pass-peak quantile function at
/// `levels`, then ln of the run's largest flank load.
pub fn tooth_snapshot(peaks_n: &[f64], max_n: f64, levels: &[f64]) -> Result<Vec<f64>, RomError> {
    if peaks_n.len() < levels.len() {
        return Err(RomError::Data(format!(
            "{} tooth passes in the tooth-load window (need at least {}, one per probability \
             level; run longer)",
            peaks_n.len(),
            levels.len()
        )));
    }
    let mut sorted = peaks_n.to_vec();
    sorted.sort_by(f64::total_cmp);
    // A pass that never touched its flank has zero load: the floor keeps its log finite.
    let floor = 1e-3 * max_n.max(1e-9);
    let mut z: Vec<f64> = quantile_function(&sorted, levels)
        .into_iter()
        .map(|q| q.max(floor).ln())
        .collect();
    z.push(max_n.max(floor).ln());
    Ok(z)
}

/// The design variables of a tooth campaign, in input order.
fn inputs(settings: &CampaignSettings) -> Result<training::DesignRanges, RomError> {
    if settings.tooth.is_none() {
        return Err(RomError::Data(
            "not a toothed-belt campaign (its settings have no [tooth] ranges)".into(),
        ));
    }
    Ok(settings.ranges())
}

/// The point's inputs scaled onto the unit cube of the trained ranges.
fn unit_inputs(ranges: &[(Variable, [f64; 2])], cfg: &DriveConfig, q: &DesignPoint) -> Vec<f64> {
    ranges
        .iter()
        .map(|(v, [lo, hi])| (q.value_or_config(*v, cfg) - lo) / (hi - lo))
        .collect()
}

impl ToothSurrogate {
    /// Fits the surrogate to a complete toothed campaign.
    pub fn fit(ds: &Dataset) -> Result<Self, RomError> {
        let settings = ds.header.settings.clone();
        let ranges = inputs(&settings)?;
        let ok = crate::surrogate::usable_runs(ds)?;
        let levels = crate::snapshots::mid_levels(TOOTH_LEVELS);
        let snaps = ok
            .iter()
            .map(|p| {
                let max = p.status.max_tooth_load_n.ok_or_else(|| {
                    RomError::Data(format!("training point {}: no tooth load", p.index))
                })?;
                tooth_snapshot(&ds.tooth_peaks(p.index)?, max, &levels)
                    .map_err(|e| RomError::Data(format!("training point {}: {e}", p.index)))
            })
            .collect::<Result<Vec<_>, RomError>>()?;
        let n = ok.len();
        let rows: Vec<Vec<f64>> = ok
            .iter()
            .map(|p| unit_inputs(&ranges, &ds.config, &p.point))
            .collect();
        let x = Array2::from_shape_fn((n, ranges.len()), |(i, j)| rows[i][j]);
        let (model, coef) = PodGp::fit(&x, &snaps, DEFAULT_ENERGY, true)?;
        let m = snaps[0].len();
        let mut truncation_var = vec![0.0; m];
        let mut buf = vec![0.0; m];
        for z in &snaps {
            model
                .basis
                .reconstruct_into(&model.basis.project(z), &mut buf);
            for (t, (a, b)) in truncation_var.iter_mut().zip(z.iter().zip(&buf)) {
                *t += (a - b).powi(2) / n as f64;
            }
        }
        let mut s = Self {
            settings,
            config_toml: ds.config.to_toml_string(),
            probability_levels: levels,
            model,
            truncation_var,
            std_calibration: 1.0,
            loo_rms_rel: [0.0; 2],
            training_runs: n,
            failed_runs: ds.points.len() - n,
        };
        s.leave_one_out(&x, &snaps, &coef)?;
        s.model.gps.clear();
        Ok(s)
    }

    /// Leave-one-out over the training runs, each coefficient's process refitted without the
    /// run with the fitted length scales held (`gp::fit_fixed`): the relative errors of the
    /// mean pass peak and the largest load, and the factor that makes their z-scores' root
    /// mean square 1 (never below 1).
    fn leave_one_out(
        &mut self,
        x: &Array2<f64>,
        snaps: &[Vec<f64>],
        coef: &[Vec<f64>],
    ) -> Result<(), RomError> {
        let n = snaps.len();
        let (mut e_mean, mut e_max, mut z2) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let keep: Vec<usize> = (0..n).filter(|&j| j != i).collect();
            let xi = x.select(ndarray::Axis(0), &keep);
            let mut a = Vec::new();
            let mut v = Vec::new();
            for (k, g) in self.model.gps.iter().enumerate() {
                let y: Array1<f64> = keep.iter().map(|&j| coef[j][k]).collect();
                let refit = gp::fit_fixed(&xi, &y, g)?;
                let (mean, var) = gp::direct_predictors(&refit, true)?;
                let row = x.row(i).to_vec();
                a.push(mean.predict(&row));
                v.push(var.map_or(0.0, |var| var.variance(&mean, &row)));
            }
            let (z, zvar) = self.moments(&a, &v);
            let truth_mean = mean_of_exp(&snaps[i][..snaps[i].len() - 1]);
            let (pred_mean, sd_mean) = self.mean_peak(&z, &zvar);
            let last = z.len() - 1;
            let truth_max = snaps[i][last].exp();
            let pred_max = z[last].exp();
            e_mean += ((pred_mean - truth_mean) / truth_mean).powi(2);
            e_max += ((pred_max - truth_max) / truth_max).powi(2);
            let sd_max = zvar[last].sqrt();
            z2 += ((pred_mean.ln() - truth_mean.ln()) / sd_mean.max(1e-12)).powi(2);
            z2 += ((z[last] - snaps[i][last]) / sd_max.max(1e-12)).powi(2);
        }
        self.loo_rms_rel = [(e_mean / n as f64).sqrt(), (e_max / n as f64).sqrt()];
        self.std_calibration = (z2 / (2 * n) as f64).sqrt().max(1.0);
        Ok(())
    }

    /// Snapshot mean and variance (ln N, ln^2) from coefficient means and variances:
    /// independent processes through the modes, plus the POD truncation.
    fn moments(&self, coef: &[f64], coef_var: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut z = vec![0.0; self.model.basis.mean.len()];
        self.model.basis.reconstruct_into(coef, &mut z);
        let var: Vec<f64> = (0..z.len())
            .map(|j| {
                self.truncation_var[j]
                    + self
                        .model
                        .basis
                        .modes
                        .iter()
                        .zip(coef_var)
                        .map(|(phi, vk)| phi[j] * phi[j] * vk)
                        .sum::<f64>()
            })
            .collect();
        (z, var)
    }

    /// Mean pass peak, N, and the standard deviation of its logarithm (delta method; the
    /// quantile entries taken as fully correlated, an upper bound).
    fn mean_peak(&self, z: &[f64], zvar: &[f64]) -> (f64, f64) {
        let p = self.probability_levels.len();
        let mean = mean_of_exp(&z[..p]);
        let sd = z[..p]
            .iter()
            .zip(&zvar[..p])
            .map(|(zj, vj)| zj.exp() * vj.sqrt())
            .sum::<f64>()
            / (p as f64 * mean);
        (mean, sd)
    }

    /// The configuration it was trained on.
    pub fn config(&self) -> Result<fom::ValidConfig, RomError> {
        Ok(DriveConfig::from_toml_str(
            &self.config_toml,
            "tooth surrogate file (embedded configuration)",
        )?)
    }

    /// Names the first input outside the trained ranges, if any.
    pub fn outside_ranges(&self, cfg: &DriveConfig, q: &DesignPoint) -> Option<String> {
        self.settings
            .ranges()
            .first_outside(|v| Some(q.value_or_config(v, cfg)))
            .map(|(v, x, [lo, hi])| {
                let n = fom::readable::readable;
                format!(
                    "{} = {} is outside the trained range [{}, {}]",
                    v.key(),
                    n(x),
                    n(lo),
                    n(hi)
                )
            })
    }

    /// The prediction at `q`; refused outside the trained ranges unless `allow_extrapolation`.
    pub fn predict(
        &self,
        cfg: &DriveConfig,
        q: &DesignPoint,
        allow_extrapolation: bool,
    ) -> Result<ToothPrediction, RomError> {
        let ranges = inputs(&self.settings)?;
        for (v, _) in &ranges {
            let x = q.value_or_config(*v, cfg);
            if !x.is_finite() {
                return Err(RomError::Data(format!("{} = {x} is not a number", v.key())));
            }
        }
        crate::physical::check_physical(cfg, q, &crate::Kind::ToothLoad.inputs())?;
        let extrapolation = self.outside_ranges(cfg, q);
        if let (Some(why), false) = (&extrapolation, allow_extrapolation) {
            // The front end words how to ask for it anyway (`rom`: a flag; Python: a keyword).
            return Err(RomError::Extrapolation {
                reason: why.clone(),
            });
        }
        let x = unit_inputs(&ranges, cfg, q);
        let a: Vec<f64> = self.model.means.iter().map(|m| m.predict(&x)).collect();
        let v: Vec<f64> = self
            .model
            .means
            .iter()
            .zip(&self.model.variances)
            .map(|(m, var)| var.variance(m, &x))
            .collect();
        let (z, zvar) = self.moments(&a, &v);
        let p = self.probability_levels.len();
        let (mean_peak_n, sd_mean) = self.mean_peak(&z, &zvar);
        let k = self.std_calibration * Z90;
        let mut q_n: Vec<f64> = z[..p].iter().map(|v| v.exp()).collect();
        // Monotone rearrangement (Chernozhukov, Fernández-Val & Galichon, Econometrica 78,
        // 2010): a quantile function cannot decrease.
        q_n.sort_by(f64::total_cmp);
        // The values at mid-point levels are an equally weighted sample of the distribution
        // (as `predict::predict_distribution` pools them).
        let at = |pr: f64| fom::stats::quantile(&q_n, pr);
        let sd_max = zvar[p].sqrt();
        Ok(ToothPrediction {
            side_gap_m: q.value_or_config(Variable::SideGap, cfg),
            load_torque_nm: q.value_or_config(Variable::LoadTorque, cfg),
            shaft_load_n: q.value_or_config(Variable::ShaftLoad, cfg),
            mean_peak_n,
            mean_peak_interval_n: [
                mean_peak_n * (-k * sd_mean).exp(),
                mean_peak_n * (k * sd_mean).exp(),
            ],
            peak_quantiles_n: [at(0.05), at(0.25), at(0.5), at(0.75), at(0.95)],
            max_n: z[p].exp(),
            max_interval_n: [(z[p] - k * sd_max).exp(), (z[p] + k * sd_max).exp()],
            extrapolated: extrapolation.is_some(),
            outside: crate::physical::outside_ranges(&self.settings.ranges(), |v| {
                Some(q.value_or_config(v, cfg))
            }),
        })
    }
}

/// One fresh full-order run against the surrogate (`validate_tooth`).
#[derive(Debug, Clone, Serialize)]
pub struct ToothCheck {
    pub side_gap_m: f64,
    pub load_torque_nm: f64,
    pub shaft_load_n: f64,
    /// Mean pass peak of the full-order run and the surrogate's, N, with the 90 % interval.
    pub fom_mean_peak_n: f64,
    pub rom_mean_peak_n: f64,
    pub rom_mean_peak_interval_n: [f64; 2],
    /// Largest tooth load of the full-order run and the surrogate's, N, with the interval.
    pub fom_max_n: f64,
    pub rom_max_n: f64,
    pub rom_max_interval_n: [f64; 2],
    /// Wall time of the full-order run and of the prediction, s.
    pub fom_wall_s: f64,
    pub rom_wall_s: f64,
}

/// The surrogate against `points` fresh full-order runs: a Latin hypercube of the trained box
/// with `seed` (pass another seed than the training one), run in parallel (rayon).
pub fn validate_tooth(
    s: &ToothSurrogate,
    points: usize,
    seed: u64,
    on_done: &(dyn Fn(usize) + Sync),
) -> Result<Vec<ToothCheck>, RomError> {
    use rayon::prelude::*;
    crate::validate::check_validation_request(&s.settings, points, seed)?;
    let cfg = s.config()?;
    let design = training::latin_hypercube_about(
        &DesignPoint::nominal(&cfg),
        &inputs(&s.settings)?,
        points,
        seed,
    );
    design
        .par_iter()
        .enumerate()
        .map(|(i, q)| {
            let point_cfg = training::point_config(&cfg, &s.settings, q)?;
            let t = std::time::Instant::now();
            let run = fom::simulate(&point_cfg, fom::RunOptions::default())?;
            let fom_wall_s = t.elapsed().as_secs_f64();
            let teeth = run
                .record::<fom::belt_kind::tooth_record::ToothRecord>()
                .ok_or_else(|| RomError::Data("the run recorded no tooth loads".into()))?;
            let peaks = teeth.window_pass_peaks_n();
            if peaks.is_empty() {
                return Err(RomError::Data(format!(
                    "validation point {i}: no tooth pass in the tooth-load window"
                )));
            }
            let t = std::time::Instant::now();
            let p = s.predict(&cfg, q, false)?;
            let rom_wall_s = t.elapsed().as_secs_f64();
            on_done(i);
            Ok(ToothCheck {
                side_gap_m: p.side_gap_m,
                load_torque_nm: p.load_torque_nm,
                shaft_load_n: p.shaft_load_n,
                fom_mean_peak_n: peaks.iter().sum::<f64>() / peaks.len() as f64,
                rom_mean_peak_n: p.mean_peak_n,
                rom_mean_peak_interval_n: p.mean_peak_interval_n,
                fom_max_n: teeth.max_flank_load_n(),
                rom_max_n: p.max_n,
                rom_max_interval_n: p.max_interval_n,
                fom_wall_s,
                rom_wall_s,
            })
        })
        .collect()
}

/// Text table of a tooth validation, with the error and coverage summary.
pub fn validation_text(checks: &[ToothCheck]) -> String {
    let mut t = String::from(
        "gap (mm)  torque (N m)  shaft (N)  mean peak FOM / ROM (N)   err     max FOM / ROM (N)   err\n",
    );
    let rel = |a: f64, b: f64| 100.0 * (b - a) / a;
    let inside = |x: f64, [lo, hi]: [f64; 2]| (lo..=hi).contains(&x);
    for c in checks {
        t += &format!(
            "{:8.4}  {:12.3}  {:9.1}  {:10.2} / {:<10.2}  {:+6.1} %  {:8.2} / {:<8.2}  {:+6.1} %{}\n",
            1e3 * c.side_gap_m,
            c.load_torque_nm,
            c.shaft_load_n,
            c.fom_mean_peak_n,
            c.rom_mean_peak_n,
            rel(c.fom_mean_peak_n, c.rom_mean_peak_n),
            c.fom_max_n,
            c.rom_max_n,
            rel(c.fom_max_n, c.rom_max_n),
            if inside(c.fom_mean_peak_n, c.rom_mean_peak_interval_n) {
                ""
            } else {
                "  (mean outside its 90 % interval)"
            }
        );
    }
    let n = checks.len().max(1) as f64;
    let rms = |f: &dyn Fn(&ToothCheck) -> f64| {
        (checks.iter().map(|c| f(c).powi(2)).sum::<f64>() / n).sqrt()
    };
    let worst =
        |f: &dyn Fn(&ToothCheck) -> f64| checks.iter().map(|c| f(c).abs()).fold(0.0, f64::max);
    let e_mean = |c: &ToothCheck| rel(c.fom_mean_peak_n, c.rom_mean_peak_n);
    let e_max = |c: &ToothCheck| rel(c.fom_max_n, c.rom_max_n);
    let cover_mean = checks
        .iter()
        .filter(|c| inside(c.fom_mean_peak_n, c.rom_mean_peak_interval_n))
        .count();
    let cover_max = checks
        .iter()
        .filter(|c| inside(c.fom_max_n, c.rom_max_interval_n))
        .count();
    let fom_s: f64 = checks.iter().map(|c| c.fom_wall_s).sum::<f64>() / n;
    let rom_s: f64 = checks.iter().map(|c| c.rom_wall_s).sum::<f64>() / n;
    t += &format!(
        "mean pass peak: rms error {:.1} %, worst {:.1} %, 90 % interval held the full-order value at {cover_mean} of {}\n\
         largest load:   rms error {:.1} %, worst {:.1} %, 90 % interval held the full-order value at {cover_max} of {}\n\
         time per point: full-order {:.2} s, surrogate {:.3} ms",
        rms(&e_mean),
        worst(&e_mean),
        checks.len(),
        rms(&e_max),
        worst(&e_max),
        checks.len(),
        fom_s,
        1e3 * rom_s
    );
    t
}

/// Mean of exp(z) over a slice.
fn mean_of_exp(z: &[f64]) -> f64 {
    z.iter().map(|v| v.exp()).sum::<f64>() / z.len() as f64
}

impl ToothPrediction {
    /// Text for `rom predict`.
    pub fn to_text(&self) -> String {
        let [p05, p25, p50, p75, p95] = self.peak_quantiles_n;
        let mut t = format!(
            "tooth-load surrogate at side gap {:.4} mm, load torque {:.3} N m, shaft load {:.1} N\n\
             maximum tooth load per pass (tooth-root load, N): mean {:.2} (90 % interval {:.2}-{:.2}), \
             p05 {p05:.2}, p25 {p25:.2}, p50 {p50:.2}, p75 {p75:.2}, p95 {p95:.2}\n\
             largest tooth load of the run: {:.2} N (90 % interval {:.2}-{:.2})",
            1e3 * self.side_gap_m,
            self.load_torque_nm,
            self.shaft_load_n,
            self.mean_peak_n,
            self.mean_peak_interval_n[0],
            self.mean_peak_interval_n[1],
            self.max_n,
            self.max_interval_n[0],
            self.max_interval_n[1],
        );
        for o in &self.outside {
            t += &format!("\nEXTRAPOLATED: {}", o.to_text());
        }
        t
    }

    /// CSV for `rom predict --format csv`: one row per quantity.
    pub fn to_csv(&self) -> String {
        let [p05, p25, p50, p75, p95] = self.peak_quantiles_n;
        format!(
            "quantity,value_n,lower_90_n,upper_90_n\n\
             mean_peak,{:.4},{:.4},{:.4}\n\
             peak_p05,{p05:.4},,\npeak_p25,{p25:.4},,\npeak_p50,{p50:.4},,\n\
             peak_p75,{p75:.4},,\npeak_p95,{p95:.4},,\n\
             run_max,{:.4},{:.4},{:.4}\n",
            self.mean_peak_n,
            self.mean_peak_interval_n[0],
            self.mean_peak_interval_n[1],
            self.max_n,
            self.max_interval_n[0],
            self.max_interval_n[1]
        )
    }
}

/// The header line of a tooth-load surrogate file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToothHeader {
    pub format: String,
    pub crate_version: String,
    pub created_utc: String,
    /// SHA-256 of the full-order configuration's canonical TOML.
    pub config_sha256: String,
    pub samples: usize,
    pub seed: u64,
    pub training_runs: usize,
    pub failed_runs: usize,
    pub ranges: training::DesignRanges,
    pub modes: usize,
    pub payload_bytes: usize,
    /// SHA-256 of the header line with this field empty, a newline and the payload.
    pub sha256: String,
}

/// A tooth-load surrogate with its header.
#[derive(Debug, Clone)]
pub struct ToothSurrogateFile {
    pub header: ToothHeader,
    pub surrogate: ToothSurrogate,
}

impl ToothSurrogateFile {
    /// Wraps a fitted surrogate with a header stamped now.
    pub fn new(surrogate: ToothSurrogate, config_sha256: String) -> Self {
        let st = &surrogate.settings;
        let header = ToothHeader {
            format: FORMAT.into(),
            crate_version: env!("CARGO_PKG_VERSION").into(),
            created_utc: now_utc(),
            config_sha256,
            samples: st.samples,
            seed: st.seed,
            training_runs: surrogate.training_runs,
            failed_runs: surrogate.failed_runs,
            ranges: st.ranges(),
            modes: surrogate.model.means.len(),
            payload_bytes: 0,
            sha256: String::new(),
        };
        Self { header, surrogate }
    }

    /// Writes the file atomically.
    pub fn save(&self, path: &Path) -> Result<(), RomError> {
        let payload = serde_json::to_vec(&self.surrogate)
            .map_err(|e| RomError::Model(format!("serialising the tooth surrogate: {e}")))?;
        save_sealed(path, self.header.clone(), &payload, |h, bytes, sha| {
            h.payload_bytes = bytes;
            h.sha256 = sha;
        })
    }

    /// Whether the file at `path` is a tooth-load surrogate (its header line says so); false
    /// for anything else, including unreadable files (their loader names the problem).
    pub fn is_tooth_file(path: &Path) -> bool {
        let Ok(file) = std::fs::File::open(path) else {
            return false;
        };
        let mut reader = std::io::BufReader::new(file);
        read_header_line(&mut reader, "")
            .ok()
            .and_then(|(h, _)| {
                h.get("format")
                    .and_then(|f| f.as_str())
                    .map(|f| f == FORMAT)
            })
            .unwrap_or(false)
    }

    /// Reads and checks a tooth-load surrogate file.
    pub fn load(path: &Path) -> Result<Self, RomError> {
        let (reader, file_len) = open_model(path)?;
        Self::read(reader, file_len, &path.display().to_string())
    }

    /// Reads and checks a tooth-load surrogate held in memory (a file's bytes); `origin` names
    /// it in errors (Python's embedded shipped model).
    pub fn from_bytes(bytes: &[u8], origin: &str) -> Result<Self, RomError> {
        Self::read(bytes, bytes.len() as u64, origin)
    }

    /// Reads and checks a tooth-load surrogate of `file_len` bytes from `reader`.
    fn read(
        mut reader: impl std::io::BufRead,
        file_len: u64,
        origin: &str,
    ) -> Result<Self, RomError> {
        let (head, nl) = read_header_line(&mut reader, origin)?;
        Self::read_after(head, nl, reader, file_len, origin)
    }

    /// Checks a file of this kind whose header line `head` (of `nl` bytes) is read; the
    /// payload follows in `reader` (`kind::ModelFile` reads the header once for every kind).
    pub(crate) fn read_after(
        head: serde_json::Value,
        nl: usize,
        reader: impl std::io::BufRead,
        file_len: u64,
        origin: &str,
    ) -> Result<Self, RomError> {
        let bad = |m: String| RomError::Model(format!("{origin}: {m}"));
        let format = head.get("format").and_then(|f| f.as_str()).unwrap_or("");
        if format != FORMAT {
            return Err(bad(format!(
                "format `{format}` is not `{FORMAT}`, the tooth-load surrogate this build reads"
            )));
        }
        let header: ToothHeader =
            serde_json::from_value(head).map_err(|e| bad(format!("header is malformed: {e}")))?;
        let payload = read_payload(reader, file_len, nl, header.payload_bytes, origin)?;
        let mut blank = header.clone();
        blank.sha256 = String::new();
        if file_sha256(&blank, &payload) != header.sha256 {
            return Err(bad(
                "checksum does not match the header (the file was edited or corrupted)".into(),
            ));
        }
        let surrogate: ToothSurrogate = serde_json::from_slice(&payload)
            .map_err(|e| bad(format!("payload is malformed: {e}")))?;
        let m = &surrogate.model;
        if m.variances.len() != m.means.len()
            || m.basis.modes.len() != m.means.len()
            || surrogate.truncation_var.len() != m.basis.mean.len()
            || surrogate.probability_levels.len() + 1 != m.basis.mean.len()
        {
            return Err(bad(
                "payload is malformed: its processes, modes and levels do not agree".into(),
            ));
        }
        Ok(Self { header, surrogate })
    }

    /// The drive configuration: the file `config`, refused unless the surrogate was trained on
    /// it, or the surrogate's own.
    pub fn drive_config(&self, config: Option<&Path>) -> Result<fom::ValidConfig, RomError> {
        checked_drive_config(&self.header.config_sha256, config, || {
            self.surrogate.config()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshot_is_the_log_quantile_function_then_the_log_maximum() {
        let levels = crate::snapshots::mid_levels(4);
        let peaks: Vec<f64> = (1..=8).map(f64::from).collect();
        let z = tooth_snapshot(&peaks, 20.0, &levels).unwrap();
        assert_eq!(z.len(), 5);
        assert!((z[4] - 20f64.ln()).abs() < 1e-12);
        assert!(z.windows(2).take(3).all(|w| w[0] <= w[1]), "{z:?}");
        assert!(tooth_snapshot(&peaks[..3], 20.0, &levels).is_err());
    }
}
