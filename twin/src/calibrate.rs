//! Calibration (model updating, seed paper Figure 1): free parameters are moved until the
//! twin's mean slip matches the measured one per condition. The surrogate does the search;
//! the full-order model confirms the final point.
//!
//! Free parameters: `friction`, `tension` (installation tension), `ratio` (a correction of the
//! speed ratio between what the tachometers see and the pitch-line kinematics, i.e. a slip
//! offset: V-belts run on an effective pitch diameter that differs from the datum diameter the
//! slip formula uses, by about 1 % per 1 % slip), and `distances` (one centre distance per
//! condition whose distance is unknown), or `spaced-distances` (d_i = d_0 - i Delta for the
//! conditions in manifest order: equally spaced and decreasing).

use egobox_doe::{Lhs, LhsKind, SamplingMethod};
use fom::{DesignPoint, DriveConfig, RunOptions};
use ndarray::Array2;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use rayon::prelude::*;
use rom::Surrogate;
use serde::Serialize;

use crate::error::{Result, TwinError};
use crate::inference::likelihood::misfit_variance;
use crate::inference::mcmc::metropolis;
use crate::inference::optimise::nelder_mead;
use crate::measured::DataSet;
use crate::signal::measured_slip;

/// One condition to match.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Target {
    pub label: String,
    pub mean_slip_pct: f64,
    /// Standard error of the measured mean, % (0 when only the mean is known).
    pub mean_se_pct: f64,
    pub known_center_distance_m: Option<f64>,
    /// Position i in d_i = d_0 - i Delta for equally spaced distances (the order of the
    /// conditions; kept when a condition is left out).
    pub position: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Distances {
    /// Use the known distances (every target must have one).
    Known,
    /// One free distance per target.
    Free,
    /// d_i = d_0 - i Delta, Delta >= 0.
    EquallySpaced,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FreeSet {
    pub friction: bool,
    pub tension: bool,
    pub ratio: bool,
    /// Effective axial stiffness EA (needs a surrogate trained over a stiffness range).
    pub stiffness: bool,
    pub distances: Distances,
}

impl FreeSet {
    /// What `rom calibrate` frees without `--free`: friction and tension, and the distances
    /// unless every target gives its own.
    pub fn default_for(targets: &[Target]) -> Self {
        FreeSet {
            friction: true,
            tension: true,
            ratio: false,
            stiffness: false,
            distances: if targets.iter().all(|t| t.known_center_distance_m.is_some()) {
                Distances::Known
            } else {
                Distances::Free
            },
        }
    }
}

impl std::str::FromStr for FreeSet {
    type Err = String;
    /// A comma-separated list of friction, tension, ratio, stiffness, distances,
    /// spaced-distances.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let mut f = FreeSet {
            friction: false,
            tension: false,
            ratio: false,
            stiffness: false,
            distances: Distances::Known,
        };
        for item in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
            match item {
                "friction" => f.friction = true,
                "tension" => f.tension = true,
                "ratio" => f.ratio = true,
                "stiffness" => f.stiffness = true,
                "distances" if f.distances == Distances::Known => f.distances = Distances::Free,
                "spaced-distances" if f.distances == Distances::Known => {
                    f.distances = Distances::EquallySpaced
                }
                "distances" | "spaced-distances" => {
                    return Err("give one of distances, spaced-distances".into())
                }
                other => {
                    return Err(format!(
                        "unknown free parameter `{other}` (choose from friction, tension, ratio, \
                         stiffness, distances, spaced-distances)"
                    ))
                }
            }
        }
        Ok(f)
    }
}

/// Reads a table of mean slips per condition (columns `condition`, `experiment_mean_slip_pct`;
/// `#` comments), such as the seed paper's Table 2; positions follow the row order.
pub fn read_slip_table(path: &std::path::Path) -> Result<Vec<Target>> {
    read_slip_table_inner(path).map_err(TwinError::Calibration)
}

fn read_slip_table_inner(path: &std::path::Path) -> std::result::Result<Vec<Target>, String> {
    let name = path.display();
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| format!("{name}: {e}"))?;
    let h = rd.headers().map_err(|e| format!("{name}: {e}"))?.clone();
    let col = |c: &str| {
        h.iter()
            .position(|x| x == c)
            .ok_or_else(|| format!("{name}: missing column `{c}`"))
    };
    let (ci, si) = (col("condition")?, col("experiment_mean_slip_pct")?);
    let mut out = Vec::new();
    for r in rd.records() {
        let r = r.map_err(|e| format!("{name}: {e}"))?;
        let line = r.position().map_or(0, |p| p.line());
        let v: f64 = r[si]
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v > 0.0)
            .ok_or_else(|| format!("{name}: line {line}: `{}` is not a positive slip", &r[si]))?;
        out.push(Target {
            label: r[ci].to_string(),
            mean_slip_pct: v,
            mean_se_pct: 0.0,
            known_center_distance_m: None,
            position: out.len() as f64,
        });
    }
    if out.is_empty() {
        return Err(format!("{name}: no conditions"));
    }
    Ok(out)
}

/// One target per label of a measured data set: its steady mean slip and standard error (as
/// `rom diagnose` measures them) and the known distance of its first run.
pub fn targets_from_dataset(set: &DataSet, cfg: &fom::DriveConfig) -> Result<Vec<Target>> {
    let ratio = set.speed_ratio(cfg);
    set.labels()
        .into_iter()
        .enumerate()
        .map(|(k, label)| {
            target_of_label(set, &label, k as f64, ratio).map_err(|e| {
                TwinError::Unusable(format!("condition {label}: cannot calibrate: {e}"))
            })
        })
        .collect()
}

/// The target of one label: its measured steady mean slip and standard error (R_t `ratio`),
/// the known distance of its first run, at `position` in the spacing of the conditions.
pub fn target_of_label(set: &DataSet, label: &str, position: f64, ratio: f64) -> Result<Target> {
    let ms = measured_slip(&set.recordings_of(label), ratio)?;
    Ok(Target {
        known_center_distance_m: set.known_center_distance_m(label),
        label: label.to_string(),
        mean_slip_pct: ms.mean_pct,
        mean_se_pct: ms.mean_se_pct,
        position,
    })
}

/// Fitted values with 90 % intervals.
#[derive(Debug, Clone, Serialize)]
pub struct Fitted {
    pub name: String,
    pub value: f64,
    pub interval90: [f64; 2],
}

#[derive(Debug, Clone, Serialize)]
pub struct ConditionResult {
    pub label: String,
    pub center_distance_m: f64,
    pub measured_mean_slip_pct: f64,
    pub twin_mean_slip_pct: f64,
    pub error_pct: f64,
    /// The full-order model's slip at the fitted point (with the ratio correction), if run.
    pub fom_mean_slip_pct: Option<f64>,
    pub fom_error_pct: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    pub parameters: Vec<Fitted>,
    pub conditions: Vec<ConditionResult>,
    pub friction: f64,
    pub installation_tension_n: f64,
    pub slip_offset_pct: f64,
    /// Fitted effective axial stiffness, N (when free).
    pub axial_stiffness_n: Option<f64>,
    pub distances_m: Vec<f64>,
    /// (d_0, Delta) when the distances are equally spaced.
    pub spacing_m: Option<[f64; 2]>,
    pub within_tolerance: bool,
    pub tolerance_pct: f64,
    /// Full-order confirmations run (the update loop of the seed paper's Figure 1).
    pub confirmations: usize,
    /// Signs of misfit (see `misfit_flags`); empty when none.
    pub misfit: Vec<String>,
    /// Draws from the posterior (the Metropolis chains, thinned), for predictions with their
    /// spread (`predictive`).
    #[serde(skip)]
    pub posterior: Vec<Draw>,
}

/// One posterior draw of a calibration's parameters.
#[derive(Debug, Clone, Copy)]
pub struct Draw {
    /// (d_0, Delta) when the distances are equally spaced.
    pub spacing_m: Option<[f64; 2]>,
    pub friction: f64,
    pub installation_tension_n: f64,
    pub slip_offset_pct: f64,
    pub axial_stiffness_n: Option<f64>,
}

/// Decodes a parameter vector.
struct Layout {
    n: usize,
    free: FreeSet,
    known: Vec<Option<f64>>,
    positions: Vec<f64>,
    mu0: f64,
    t0: f64,
    names: Vec<String>,
    bounds: Vec<[f64; 2]>,
}

/// A decoded parameter vector: the design point of each condition plus the slip offset.
struct Point {
    d: Vec<f64>,
    mu: f64,
    t: f64,
    offset: f64,
    ea: Option<f64>,
}

impl Point {
    /// The design point of each condition.
    fn design_points(&self) -> impl Iterator<Item = DesignPoint> + '_ {
        self.d
            .iter()
            .map(|&d| DesignPoint::drive(d, self.mu, self.t, self.ea))
    }
}

impl Layout {
    fn new(s: &Surrogate, cfg: &DriveConfig, targets: &[Target], free: FreeSet) -> Result<Self> {
        let st = &s.settings;
        let [dlo, dhi] = st.center_distance_m;
        let mut names = Vec::new();
        let mut bounds = Vec::new();
        match free.distances {
            Distances::Known => {
                if let Some(t) = targets.iter().find(|t| t.known_center_distance_m.is_none()) {
                    return Err(TwinError::Calibration(format!(
                        "condition {} has no known centre distance; free `distances` or \
                         `spaced-distances`",
                        t.label
                    )));
                }
                // A known distance the surrogate was not trained at cannot be calibrated to
                // (every candidate would be refused, and the search would say only that).
                if let Some((t, why)) = targets.iter().find_map(|t| {
                    let d = t.known_center_distance_m?;
                    Some((
                        t,
                        s.outside_range(fom::params::Variable::CenterDistance, d)?,
                    ))
                }) {
                    return Err(TwinError::Calibration(format!(
                        "condition {} lies outside the surrogate's trained range: {why}; leave \
                         it out, or train a surrogate that covers it",
                        t.label
                    )));
                }
            }
            Distances::Free => {
                for t in targets {
                    names.push(format!("center_distance_m[{}]", t.label));
                    bounds.push([dlo, dhi]);
                }
            }
            Distances::EquallySpaced => {
                names.push("center_distance_m[first]".into());
                bounds.push([dlo, dhi]);
                names.push("spacing_m".into());
                let span = targets.iter().map(|t| t.position).fold(1.0, f64::max);
                bounds.push([0.0, (dhi - dlo) / span]);
            }
        }
        if free.friction {
            names.push("friction".into());
            bounds.push(st.friction);
        }
        if free.tension {
            names.push("installation_tension_n".into());
            bounds.push(st.installation_tension_n);
        }
        if free.ratio {
            names.push("slip_offset_pct".into());
            bounds.push([-5.0, 5.0]);
        }
        if free.stiffness {
            let r = st.axial_stiffness_n.ok_or_else(|| {
                TwinError::Calibration(
                    "`stiffness` is free but this surrogate was trained at one belt stiffness; \
                     train one over a range (`axial_stiffness_n = [lo, hi]` in the campaign \
                     settings)"
                        .into(),
                )
            })?;
            names.push("axial_stiffness_n".into());
            bounds.push(r);
        }
        if names.is_empty() {
            return Err(TwinError::Calibration("no free parameters".into()));
        }
        Ok(Self {
            n: targets.len(),
            free,
            known: targets.iter().map(|t| t.known_center_distance_m).collect(),
            positions: targets.iter().map(|t| t.position).collect(),
            mu0: cfg.effective_friction(),
            t0: cfg
                .belt
                .installation_tension_n
                .unwrap_or(0.5 * (st.installation_tension_n[0] + st.installation_tension_n[1])),
            names,
            bounds,
        })
    }

    fn decode(&self, x: &[f64]) -> Point {
        let mut k = 0;
        let d = match self.free.distances {
            Distances::Known => self.known.iter().map(|d| d.unwrap_or(0.0)).collect(),
            Distances::Free => {
                k = self.n;
                x[..self.n].to_vec()
            }
            Distances::EquallySpaced => {
                k = 2;
                self.positions.iter().map(|i| x[0] - i * x[1]).collect()
            }
        };
        let mut next = |on: bool, default: f64| {
            if on {
                k += 1;
                x[k - 1]
            } else {
                default
            }
        };
        let mu = next(self.free.friction, self.mu0);
        let t = next(self.free.tension, self.t0);
        let offset = next(self.free.ratio, 0.0);
        let ea = self.free.stiffness.then(|| next(true, 0.0));
        Point {
            d,
            mu,
            t,
            offset,
            ea,
        }
    }
}

/// Twin mean slip (with the offset) per condition and its variance; None if outside the
/// surrogate's range.
fn predict(s: &Surrogate, cfg: &DriveConfig, p: &Point) -> Result<Option<Vec<(f64, f64)>>> {
    let mut out = Vec::with_capacity(p.d.len());
    for q in p.design_points() {
        if s.extrapolation(cfg, &q).is_some() {
            return Ok(None);
        }
        let pp = s.predict_point(cfg, &q)?;
        if s.beyond_trained_slip(pp.mean_slip_pct).is_some() {
            return Ok(None);
        }
        out.push((pp.mean_slip_pct + p.offset, pp.likelihood_std_pct.powi(2)));
    }
    Ok(Some(out))
}

fn misfit(pred: &[(f64, f64)], targets: &[Target]) -> f64 {
    pred.iter()
        .zip(targets)
        .map(|((m, _), t)| ((m - t.mean_slip_pct) / t.mean_slip_pct).powi(2))
        .sum()
}

/// Calibrates the surrogate's free parameters to the targets. `confirm` runs the full-order
/// model at the fitted point (one run per condition, in parallel).
pub fn calibrate(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    free: FreeSet,
    tolerance_pct: f64,
    confirm: bool,
) -> Result<Calibration> {
    calibrate_with_prior(s, cfg, targets, free, tolerance_pct, confirm, Prior::Flat)
}

/// What the calibration assumes of friction and tension before the data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prior {
    /// Any value in the surrogate's trained box alike: the maximum-likelihood fit
    /// (`rom calibrate`, the seed paper's procedure).
    Flat,
    /// Gaussian about the configuration's nominal friction and installation tension, with a
    /// standard deviation of a quarter of the trained range each (`NOMINAL_PRIOR_SHARE`): the
    /// maximum a posteriori fit. Where the data pin a parameter the likelihood outweighs it;
    /// where they do not (steady creep slip barely depends on friction or tension, so four
    /// healthy labels leave both free along a ridge), the fit stays at the installed values
    /// instead of wherever the optimiser's start lands. Used by `rom gap`'s baseline.
    Nominal,
}

/// Standard deviation of the nominal prior as a share of the trained range.
pub const NOMINAL_PRIOR_SHARE: f64 = 0.25;

/// Calibrates as `calibrate` does, with the prior `prior` (see `Prior`).
pub fn calibrate_with_prior(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    free: FreeSet,
    tolerance_pct: f64,
    confirm: bool,
    prior: Prior,
) -> Result<Calibration> {
    if !(tolerance_pct.is_finite() && tolerance_pct > 0.0) {
        return Err(TwinError::InvalidArgument {
            input: rom::Input::CalibrationTolerance,
            message: format!("must be positive, got {tolerance_pct}"),
        });
    }
    if targets.is_empty() {
        return Err(TwinError::Calibration(
            "nothing to calibrate to (no conditions)".into(),
        ));
    }
    let layout = Layout::new(s, cfg, targets, free)?;
    let dim = layout.bounds.len();
    // Global stage: a Latin hypercube over the box, then Nelder-Mead from the five best.
    let lim = Array2::from_shape_fn((dim, 2), |(i, j)| layout.bounds[i][j]);
    let samples = 20_000;
    let xs: Vec<Vec<f64>> = Lhs::new_with_rng(&lim, Xoshiro256Plus::seed_from_u64(3))
        .kind(LhsKind::Classic)
        .sample(samples)
        .rows()
        .into_iter()
        .map(|r| r.to_vec())
        .collect();
    let scored: Vec<f64> = xs
        .par_iter()
        .map(|x| match predict(s, cfg, &layout.decode(x)) {
            Ok(Some(pred)) => misfit(&pred, targets),
            _ => f64::INFINITY,
        })
        .collect();
    let mut order: Vec<usize> = (0..samples).filter(|&i| scored[i].is_finite()).collect();
    if order.is_empty() {
        return Err(TwinError::Calibration(
            "no parameter set inside the surrogate's ranges reproduces these conditions".into(),
        ));
    }
    order.sort_by(|&a, &b| scored[a].total_cmp(&scored[b]));
    // -2 ln prior (a constant dropped), over the free parameters: zero for the flat prior.
    let st = &s.settings;
    let z2 = |free: bool, v: f64, v0: f64, [lo, hi]: [f64; 2]| {
        let z = (v - v0) / (NOMINAL_PRIOR_SHARE * (hi - lo));
        if free {
            z * z
        } else {
            0.0
        }
    };
    let prior_term = |p: &Point| -> f64 {
        match prior {
            Prior::Flat => 0.0,
            Prior::Nominal => {
                z2(free.friction, p.mu, layout.mu0, st.friction)
                    + z2(free.tension, p.t, layout.t0, st.installation_tension_n)
            }
        }
    };
    // `bias`: the full-order minus surrogate slip per condition at the last confirmed point
    // (zero at first). Figure 1 of the seed paper: update, confirm, repeat while the full model
    // misses the tolerance (at most three confirmations).
    let chi2_with = |bias: &[f64], x: &[f64]| -> f64 {
        let p = layout.decode(x);
        match predict(s, cfg, &p) {
            Ok(Some(pred)) => {
                pred.iter()
                    .zip(targets)
                    .zip(bias)
                    .map(|(((m, v), t), b)| {
                        let var = misfit_variance(t.mean_se_pct, *v, t.mean_slip_pct);
                        (m + b - t.mean_slip_pct).powi(2) / var
                    })
                    .sum::<f64>()
                    + prior_term(&p)
            }
            _ => f64::INFINITY,
        }
    };
    let mut bias = vec![0.0; targets.len()];
    let mut starts: Vec<Vec<f64>> = order.iter().take(5).map(|&i| xs[i].clone()).collect();
    let mut confirmations = 0;
    let (best, p, pred, fom) = loop {
        let chi2 = |x: &[f64]| chi2_with(&bias, x);
        // The fitted point maximises the likelihood the intervals come from.
        let best = starts
            .iter()
            .map(|x0| nelder_mead(&|x: &[f64]| chi2(x).min(1e12), x0, &layout.bounds, 400))
            .min_by(|a, b| chi2(a).total_cmp(&chi2(b)))
            .expect("five starts");
        let p = layout.decode(&best);
        let pred = predict(s, cfg, &p)?.ok_or_else(|| {
            TwinError::Calibration("the fitted point left the surrogate's range".into())
        })?;
        if !confirm {
            break (best, p, pred, None);
        }
        let fom = confirm_with_fom(s, cfg, &p)?;
        confirmations += 1;
        let ok = fom.iter().zip(targets).all(|(f, t)| {
            100.0 * (f + p.offset - t.mean_slip_pct).abs() / t.mean_slip_pct <= tolerance_pct
        });
        if ok || confirmations == 3 {
            break (best, p, pred, Some(fom));
        }
        bias = fom
            .iter()
            .zip(&pred)
            .map(|(f, (m, _))| f + p.offset - m)
            .collect();
        starts = vec![best];
    };
    // Several chains from the fit and from the best distinct Latin-hypercube points, pooled:
    // along the looseness ridge (distance against tension) one random walk mixes slowly.
    let chain_starts: Vec<Vec<f64>> = std::iter::once(best.clone())
        .chain(order.iter().take(7).map(|&i| xs[i].clone()))
        .collect();
    let chi2_final = |x: &[f64]| chi2_with(&bias, x);
    let chain: Vec<Vec<f64>> = chain_starts
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, x0)| metropolis(&chi2_final, x0, &layout.bounds, 6000, 11 + k as u64))
        .collect();
    let parameters: Vec<Fitted> = (0..dim)
        .map(|j| {
            let mut v: Vec<f64> = chain.iter().map(|x| x[j]).collect();
            v.sort_by(f64::total_cmp);
            Fitted {
                name: layout.names[j].clone(),
                value: best[j],
                interval90: [
                    fom::stats::quantile(&v, 0.05),
                    fom::stats::quantile(&v, 0.95),
                ],
            }
        })
        .collect();
    let conditions: Vec<ConditionResult> = targets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let err = |v: f64| 100.0 * (v - t.mean_slip_pct).abs() / t.mean_slip_pct;
            let f = fom.as_ref().map(|f| f[i] + p.offset);
            ConditionResult {
                label: t.label.clone(),
                center_distance_m: p.d[i],
                measured_mean_slip_pct: t.mean_slip_pct,
                twin_mean_slip_pct: pred[i].0,
                error_pct: err(pred[i].0),
                fom_mean_slip_pct: f,
                fom_error_pct: f.map(err),
            }
        })
        .collect();
    let within_tolerance = conditions
        .iter()
        .all(|c| c.fom_error_pct.unwrap_or(c.error_pct) <= tolerance_pct);
    let misfit = misfit_flags(
        s.max_trained_slip_pct,
        &parameters,
        &layout.bounds,
        &conditions,
        targets,
        &pred,
    );
    // Thinned to about 400 draws: enough for a 90 % predictive interval.
    let thin = (chain.len() / 400).max(1);
    let posterior = chain
        .iter()
        .step_by(thin)
        .map(|x| {
            let q = layout.decode(x);
            Draw {
                spacing_m: (free.distances == Distances::EquallySpaced).then(|| [x[0], x[1]]),
                friction: q.mu,
                installation_tension_n: q.t,
                slip_offset_pct: q.offset,
                axial_stiffness_n: q.ea,
            }
        })
        .collect();
    Ok(Calibration {
        posterior,
        parameters,
        conditions,
        friction: p.mu,
        installation_tension_n: p.t,
        slip_offset_pct: p.offset,
        axial_stiffness_n: p.ea,
        spacing_m: (free.distances == Distances::EquallySpaced).then(|| [best[0], best[1]]),
        distances_m: p.d,
        within_tolerance,
        tolerance_pct,
        confirmations,
        misfit,
    })
}

/// Signs that the twin cannot reproduce the targets (issue 11), each with what it means: a
/// fitted parameter at its bound (within 0.5 % of the range) while its posterior lies inside
/// (a ridge) or at it (the data want more); a measured slip beyond every training run's (with
/// the offset) or below the least; a residual beyond three standard deviations of the
/// calibration's own likelihood.
fn misfit_flags(
    max_trained_slip_pct: Option<f64>,
    parameters: &[Fitted],
    bounds: &[[f64; 2]],
    conditions: &[ConditionResult],
    targets: &[Target],
    pred: &[(f64, f64)],
) -> Vec<String> {
    let mut flags = Vec::new();
    for (p, [lo, hi]) in parameters.iter().zip(bounds) {
        let edge = 0.005 * (hi - lo);
        for (bound, name) in [(*lo, "lower"), (*hi, "upper")] {
            if (p.value - bound).abs() <= edge {
                let inside = p.interval90[0] > lo + edge && p.interval90[1] < hi - edge;
                flags.push(format!(
                    "{} = {:.5} sits at its {name} bound {bound}{}",
                    p.name,
                    p.value,
                    if inside {
                        " while its 90 % interval lies inside: the data leave it free along a \
                         ridge"
                    } else {
                        ": the data ask for more than the trained box holds"
                    }
                ));
            }
        }
    }
    let offset = parameters
        .iter()
        .find(|p| p.name == "slip_offset_pct")
        .map_or(0.0, |p| p.value);
    for ((c, t), (m, var)) in conditions.iter().zip(targets).zip(pred) {
        if let Some(max) = max_trained_slip_pct {
            if t.mean_slip_pct > max + offset {
                flags.push(format!(
                    "{}: measured slip {:.3} % is beyond every training run ({:.3} % with the \
                     offset): out of the twin's reach",
                    c.label,
                    t.mean_slip_pct,
                    max + offset
                ));
            }
        }
        let sd = misfit_variance(t.mean_se_pct, *var, t.mean_slip_pct).sqrt();
        let z = (t.mean_slip_pct - m) / sd;
        if z.abs() > 3.0 {
            flags.push(format!(
                "{}: the residual {:+.3} pp is {z:+.1} sd of what noise and the surrogate explain",
                c.label,
                t.mean_slip_pct - m
            ));
        }
    }
    flags
}

/// Steady mean slip (%) of the full-order model at each fitted condition, without the offset.
fn confirm_with_fom(s: &Surrogate, cfg: &DriveConfig, p: &Point) -> Result<Vec<f64>> {
    let points: Vec<DesignPoint> = p.design_points().collect();
    points.par_iter().map(|q| fom_slip_pct(s, cfg, q)).collect()
}

/// Steady mean slip (%) of the full-order model at `point`, run as a training run of `s` is
/// (until settled); an error when the run is no steady result.
fn fom_slip_pct(s: &Surrogate, cfg: &DriveConfig, point: &DesignPoint) -> Result<f64> {
    let st = &s.settings;
    // A surrogate without a stiffness range was trained at the configuration's EA.
    let point = DesignPoint {
        axial_stiffness_n: point
            .axial_stiffness_n
            .filter(|_| st.axial_stiffness_n.is_some()),
        ..*point
    };
    let c = training::point_config(cfg, st, &point)?;
    let run = fom::simulate(&c, RunOptions::default())?;
    // Only a settled, energy-balanced run confirms (fom::output::RunSummary::steady_data).
    run.summary.steady_data().map_err(|why| {
        TwinError::Calibration(format!(
            "the full-order run at d = {:.5} m is no steady result: {why}",
            point.center_distance_m
        ))
    })?;
    Ok(run.summary.mean_slip_pct)
}

/// Full-order runs that stand in for a predictive's draws where the surrogate is not trusted
/// (outside its box, or in its knee band or onset), by default (`rom calibrate
/// --predictive-runs`): at most this many, one per stratum of those draws ordered by traction
/// capacity. 48: Table 2's d4 left out came out 15.26 / 17.59 / 17.98 % off with 12 / 48 / 96
/// runs (README, "rom calibrate"); 12 was 2.7 points from the 96-run figure, 48 is 0.4.
pub const PREDICTIVE_FOM_RUNS: usize = 48;

/// Whether a predictive's draw inside the surrogate's box is stood in for by the full-order
/// model (with stand-ins on): a draw outside the creep plateau, in the knee band or at the
/// knee's onset (`rom::surrogate::interval_part`, the parts whose held-out errors are largest:
/// README, "Calibrated intervals"). The draws of a condition at the knee then get the twin's
/// physics, not the surrogate's fit of it, so the prediction does not move with the
/// surrogate's knee (Table 2's d4 left out: 8.1 % on the shipped model, 22 % on a
/// knee-aligned retrain, surrogate inside the box).
fn stood_in_inside_box(band_n: f64, capacity_n: f64, mean_pct: f64) -> bool {
    rom::surrogate::interval_part(band_n, capacity_n, mean_pct)
        != rom::surrogate::IntervalPart::Creep
}

/// Twin slip (surrogate, with the offset) at a condition of a calibration, for leave-one-out.
pub fn predict_condition(s: &Surrogate, cfg: &DriveConfig, c: &Calibration, d: f64) -> Result<f64> {
    Ok(s.predict_point(cfg, &c.design_point(d))?.mean_slip_pct + c.slip_offset_pct)
}

/// One condition's leave-one-out check: calibrated on the others (surrogate only), predicted
/// at its distance.
#[derive(Debug, Clone, Serialize)]
pub struct LeftOut {
    pub label: String,
    /// The condition's distance under the others' calibration; `None` when the distance was a
    /// free parameter of its own (not predictable).
    pub center_distance_m: Option<f64>,
    pub measured_mean_slip_pct: f64,
    pub predicted_mean_slip_pct: Option<f64>,
    pub error_pct: Option<f64>,
    /// The posterior predictive of the others' calibration at this condition (`None` when its
    /// distance is a free parameter of its own, or no draw lies inside the surrogate's box).
    pub predictive: Option<Predictive>,
    /// Error of the predictive median, %.
    pub predictive_error_pct: Option<f64>,
}

/// A prediction over a calibration's posterior draws: the twin's mean slip (with the offset)
/// at each draw's parameters, through the surrogate.
#[derive(Debug, Clone, Serialize)]
pub struct Predictive {
    pub median_pct: f64,
    pub interval90_pct: [f64; 2],
    /// Draws whose point lies outside the surrogate's box: left out of the quantiles, or
    /// stood in for by full-order runs (`fom_runs`).
    pub draws_outside_box: usize,
    pub draws: usize,
    /// Draws the full-order runs stood in for: those outside the box and, inside it, those
    /// in the knee band or at the knee's onset (0 without full-order runs).
    pub draws_stood_in: usize,
    /// Full-order runs that stood in for those draws (0: the outside draws were left out and
    /// the surrogate predicted the others): one per stratum of the stood-in draws ordered by
    /// traction capacity, weighted by its size.
    pub fom_runs: usize,
    /// Of those, runs that gave no steady result (a belt too slack to run, or a run that does
    /// not settle): their strata count above every settled value, and a quantile among them
    /// is NaN.
    pub fom_runs_failed: usize,
}

impl Predictive {
    /// Whether the 90 % interval holds `x`; an end among unsettled runs' draws (NaN) is open.
    pub fn holds(&self, x: f64) -> bool {
        let [lo, hi] = self.interval90_pct;
        (lo.is_nan() || lo <= x) && (hi.is_nan() || x <= hi)
    }
}

/// Leave-one-out: for each condition, calibrate on all the others through the surrogate (no
/// full-order confirmation) and predict the one left out; `fom_runs`: at most this many
/// full-order runs stand in for the predictive's draws outside the box and at the knee (0:
/// none; `Calibration::predictive`).
pub fn leave_one_out(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    free: FreeSet,
    tolerance_pct: f64,
    fom_runs: usize,
) -> Result<Vec<LeftOut>> {
    (0..targets.len())
        .map(|i| {
            let rest: Vec<Target> = targets
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, t)| t.clone())
                .collect();
            let ci = calibrate(s, cfg, &rest, free, tolerance_pct, false)?;
            let t = &targets[i];
            let d = match (ci.spacing_m, free.distances) {
                (Some([d0, step]), _) => Some(d0 - t.position * step),
                (None, Distances::Known) => t.known_center_distance_m,
                _ => None,
            };
            let pred = d.map(|d| predict_condition(s, cfg, &ci, d)).transpose()?;
            let predictive = ci.predictive(
                s,
                cfg,
                |draw| match draw.spacing_m {
                    Some([d0, step]) => Some(d0 - t.position * step),
                    None => d,
                },
                fom_runs,
            )?;
            let err = |p: f64| 100.0 * (p - t.mean_slip_pct).abs() / t.mean_slip_pct;
            Ok(LeftOut {
                label: t.label.clone(),
                center_distance_m: d,
                measured_mean_slip_pct: t.mean_slip_pct,
                predicted_mean_slip_pct: pred,
                error_pct: pred.map(err),
                predictive_error_pct: predictive.as_ref().map(|p| err(p.median_pct)),
                predictive,
            })
        })
        .collect()
}

/// Readable lines of a leave-one-out check.
pub fn leave_one_out_text(rows: &[LeftOut]) -> String {
    let mut text = String::from(
        "leave-one-out (calibrate on the others, predict this one: at the fit, and the \
         posterior predictive's median and 90 % interval):\n",
    );
    for r in rows {
        text += &match (r.center_distance_m, r.predicted_mean_slip_pct, r.error_pct) {
            (Some(d), Some(pred), Some(err)) => {
                let mut line = format!(
                    "  {:<8} d {:.5} m  measured {:.4}  at the fit {:.4} ({err:.2} %)",
                    r.label, d, r.measured_mean_slip_pct, pred
                );
                if let (Some(p), Some(perr)) = (&r.predictive, r.predictive_error_pct) {
                    let [lo, hi] = p.interval90_pct;
                    let holds = p.holds(r.measured_mean_slip_pct);
                    let end = |x: f64| {
                        if x.is_nan() {
                            "unsettled".to_string()
                        } else {
                            format!("{x:.4}")
                        }
                    };
                    line += &format!(
                        "  posterior {:.4} ({perr:.2} %) [{}, {}]{}",
                        p.median_pct,
                        end(lo),
                        end(hi),
                        if holds { "" } else { " misses it" }
                    );
                    if p.fom_runs > 0 {
                        line += &format!(
                            "; {} of {} draws outside the surrogate's box and {} at its knee, \
                             stood in for by {} full-order runs{}",
                            p.draws_outside_box,
                            p.draws,
                            p.draws_stood_in - p.draws_outside_box,
                            p.fom_runs,
                            if p.fom_runs_failed > 0 {
                                format!(
                                    " ({} without a steady result, such as a slack belt: their \
                                     draws counted above the settled ones)",
                                    p.fom_runs_failed
                                )
                            } else {
                                String::new()
                            }
                        );
                    } else if p.draws_outside_box > 0 {
                        line += &format!(
                            "; {} of {} draws outside the surrogate's box, left out",
                            p.draws_outside_box, p.draws
                        );
                    }
                }
                line + "\n"
            }
            _ => format!(
                "  {:<8} not predictable: its distance is a free parameter of its own\n",
                r.label
            ),
        };
    }
    text
}

/// The calibrated configuration as TOML: the surrogate's configuration with the fitted friction
/// and installation tension; the distances and the slip offset (not model inputs) as comments.
pub fn calibrated_config_toml(
    cfg: &DriveConfig,
    c: &Calibration,
    labels: &[String],
) -> Result<String> {
    let out = c.design_point(cfg.center_distance_m()).apply(cfg)?;
    let mut head = String::from("# Calibrated by `rom calibrate` (beltwin).\n");
    for (l, d) in labels.iter().zip(&c.distances_m) {
        head += &format!("# condition {l}: centre distance {d:.5} m\n");
    }
    head += &format!(
        "# slip offset (speed-ratio correction) {:+.4} % : add it to the model's slip to compare \
         with the measurements\n",
        c.slip_offset_pct
    );
    Ok(head + &out.to_toml_string())
}

impl Calibration {
    /// The posterior predictive of the twin's mean slip (with the offset) at the distance
    /// `distance` gives for each draw: median and 90 % interval. Surrogate only
    /// (`fom_runs` 0), over the draws inside the surrogate's box; otherwise at most `fom_runs`
    /// full-order runs stand in for the draws outside the box and for those inside it where
    /// the surrogate is least accurate (`stood_in_inside_box`). `None` when no draw is
    /// predicted (or `distance` gives none).
    pub fn predictive(
        &self,
        s: &Surrogate,
        cfg: &DriveConfig,
        distance: impl Fn(&Draw) -> Option<f64>,
        fom_runs: usize,
    ) -> Result<Option<Predictive>> {
        let fom_stand_ins = fom_runs > 0;
        let band_n = s.knee_band_upper_n(cfg);
        let mut stood_in: Vec<(DesignPoint, f64)> = Vec::new();
        let mut draws_outside_box = 0;
        let mut v: Vec<f64> = Vec::with_capacity(self.posterior.len());
        for draw in &self.posterior {
            let Some(d) = distance(draw) else {
                return Ok(None);
            };
            let q = DesignPoint::drive(
                d,
                draw.friction,
                draw.installation_tension_n,
                draw.axial_stiffness_n,
            );
            if s.extrapolation(cfg, &q).is_some() {
                draws_outside_box += 1;
                stood_in.push((q, draw.slip_offset_pct));
                continue;
            }
            let mean_pct = s.predict_point(cfg, &q)?.mean_slip_pct;
            if fom_stand_ins
                && stood_in_inside_box(band_n, rom::features::capacity_feature_n(cfg, &q), mean_pct)
            {
                stood_in.push((q, draw.slip_offset_pct));
                continue;
            }
            v.push(mean_pct + draw.slip_offset_pct);
        }
        // Draws past the box, and with stand-ins the knee draws inside it (`stood_in`),
        // predicted by full-order runs: ordered by traction capacity (the slip's main driver;
        // rom::features), cut into equal strata, the draw at each stratum's middle run and
        // counted as many times as its stratum holds. Left out, the outside draws bias the
        // quantiles towards the box (Table 2's d4, predicted from the others: 278 of 400 draws
        // past the box's smallest distance, all of them looser).
        let (mut runs_done, mut fom_failed) = (0, 0);
        let mut draws_stood_in = 0;
        if fom_stand_ins && !stood_in.is_empty() {
            draws_stood_in = stood_in.len();
            stood_in.sort_by(|a, b| {
                rom::features::capacity_feature_n(cfg, &a.0)
                    .total_cmp(&rom::features::capacity_feature_n(cfg, &b.0))
            });
            let n = stood_in.len();
            let k = n.min(fom_runs);
            let strata: Vec<(usize, usize)> = (0..k)
                .map(|i| {
                    let (lo, hi) = (i * n / k, (i + 1) * n / k);
                    ((lo + hi) / 2, hi - lo)
                })
                .collect();
            let runs: Vec<(Result<f64>, usize)> = strata
                .par_iter()
                .map(|&(mid, size)| {
                    let (q, offset) = &stood_in[mid];
                    (fom_slip_pct(s, cfg, q).map(|x| x + offset), size)
                })
                .collect();
            runs_done = runs.len();
            // A run without a steady result keeps its draws' ranks but not a value: it is
            // counted above every settled one (a draw looser than the box that gives none is a
            // belt too slack to run or one in gross slip that does not settle), so a quantile
            // that falls among such draws is not determined (NaN), and the others are not
            // biased by leaving them out.
            for (r, size) in runs {
                let x = r.unwrap_or_else(|_| {
                    fom_failed += 1;
                    f64::INFINITY
                });
                v.extend(std::iter::repeat_n(x, size));
            }
        }
        if v.is_empty() {
            return Ok(None);
        }
        v.sort_by(f64::total_cmp);
        // Among unsettled runs' draws (infinite): not determined.
        let q = |p: f64| Some(fom::stats::quantile(&v, p)).filter(|x| x.is_finite());
        Ok(Some(Predictive {
            median_pct: q(0.5).unwrap_or(f64::NAN),
            interval90_pct: [q(0.05).unwrap_or(f64::NAN), q(0.95).unwrap_or(f64::NAN)],
            draws_outside_box,
            draws: self.posterior.len(),
            draws_stood_in,
            fom_runs: runs_done,
            fom_runs_failed: fom_failed,
        }))
    }

    /// The calibrated design point at centre distance `d` (friction, tension, stiffness).
    pub fn design_point(&self, d: f64) -> DesignPoint {
        DesignPoint::drive(
            d,
            self.friction,
            self.installation_tension_n,
            self.axial_stiffness_n,
        )
    }

    pub fn to_text(&self) -> String {
        let mut t = String::from(
            "condition | centre distance (m) | measured mean slip (%) | surrogate slip (%) | \
             error (%) | twin (FOM) slip (%) | twin error (%)\n",
        );
        for c in &self.conditions {
            t += &format!(
                "{:<9} | {:>19.5} | {:>22.4} | {:>18.4} | {:>9.2} | {:>19} | {:>14}\n",
                c.label,
                c.center_distance_m,
                c.measured_mean_slip_pct,
                c.twin_mean_slip_pct,
                c.error_pct,
                c.fom_mean_slip_pct
                    .map_or("-".into(), |v| format!("{v:.4}")),
                c.fom_error_pct.map_or("-".into(), |v| format!("{v:.2}")),
            );
        }
        t += "fitted parameters (value, 90 % interval):\n";
        for p in &self.parameters {
            t += &format!(
                "  {:<28} {:.5}  [{:.5}, {:.5}]\n",
                p.name, p.value, p.interval90[0], p.interval90[1]
            );
        }
        t += &format!(
            "full-order confirmations: {}; all errors within {:.1} %: {}",
            self.confirmations,
            self.tolerance_pct,
            if self.within_tolerance { "yes" } else { "NO" }
        );
        if !self.misfit.is_empty() {
            t += "\nmisfit:";
            for f in &self.misfit {
                t += &format!("\n  - {f}");
            }
            t += "\n  what the model misses: `rom gap --measured DIR` (recordings needed)";
        }
        t
    }
}

#[cfg(test)]
mod misfit_tests {
    use super::*;

    #[test]
    fn a_parameter_at_its_bound_a_slip_out_of_reach_and_a_large_residual_are_flagged() {
        let fitted = |name: &str, value, interval90| Fitted {
            name: name.into(),
            value,
            interval90,
        };
        let params = [
            fitted("friction", 0.7, [0.65, 0.75]),
            fitted("installation_tension_n", 150.0, [152.0, 190.0]),
            fitted("slip_offset_pct", 0.0, [-0.1, 0.1]),
        ];
        let bounds = [[0.6, 0.8], [150.0, 300.0], [-5.0, 5.0]];
        let target = |label: &str, slip| Target {
            label: label.into(),
            mean_slip_pct: slip,
            mean_se_pct: 0.001,
            known_center_distance_m: None,
            position: 0.0,
        };
        let condition = |label: &str, slip, twin| ConditionResult {
            label: label.into(),
            center_distance_m: 0.42,
            measured_mean_slip_pct: slip,
            twin_mean_slip_pct: twin,
            error_pct: 0.0,
            fom_mean_slip_pct: None,
            fom_error_pct: None,
        };
        let targets = [target("a", 0.70), target("b", 40.0), target("c", 1.0)];
        let conditions = [
            condition("a", 0.70, 0.70),
            condition("b", 40.0, 30.0),
            condition("c", 1.0, 0.8),
        ];
        let pred = [(0.70, 1e-6), (30.0, 1e-6), (0.8, 1e-6)];
        let flags = misfit_flags(Some(32.0), &params, &bounds, &conditions, &targets, &pred);
        // The tension at its lower bound with its interval inside: a ridge.
        assert!(flags[0].contains("installation_tension_n") && flags[0].contains("ridge"));
        assert!(flags
            .iter()
            .any(|f| f.starts_with("b:") && f.contains("reach")));
        // c misses by 0.2 pp against an sd of ~0.02 pp (2 % of 1 %).
        assert!(flags
            .iter()
            .any(|f| f.starts_with("c:") && f.contains("sd")));
        assert!(!flags
            .iter()
            .any(|f| f.starts_with("a:") || f.contains("friction")));
    }
}

/// What `rom calibrate` reports (`--format json`; Python's `beltwin.calibrate`): the
/// calibration and, when asked, the leave-one-out predictions.
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationReport {
    pub calibration: Calibration,
    pub leave_one_out: Option<Vec<LeftOut>>,
}

impl CalibrationReport {
    /// Calibrates (`calibrate`) and, with `leave_one_out`, predicts each condition from the
    /// others (`leave_one_out`); with `confirm`, at most `predictive_runs` full-order runs
    /// stand in for each predictive's draws where the surrogate is not trusted.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        s: &Surrogate,
        cfg: &DriveConfig,
        targets: &[Target],
        free: FreeSet,
        tolerance_pct: f64,
        confirm: bool,
        leave_one_out: bool,
        predictive_runs: usize,
    ) -> Result<Self> {
        let calibration = calibrate(s, cfg, targets, free, tolerance_pct, confirm)?;
        let leave_one_out = if leave_one_out {
            Some(self::leave_one_out(
                s,
                cfg,
                targets,
                free,
                tolerance_pct,
                if confirm { predictive_runs } else { 0 },
            )?)
        } else {
            None
        };
        Ok(Self {
            calibration,
            leave_one_out,
        })
    }

    /// The report as text (the calibration, then the leave-one-out table when run).
    pub fn to_text(&self) -> String {
        let mut text = self.calibration.to_text() + "\n";
        if let Some(rows) = &self.leave_one_out {
            text += &leave_one_out_text(rows);
        }
        text
    }
}
