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
//!
//! One file per step: `options` (targets and free parameters), `targets` (from a table or a
//! data set), `layout` (the search space), this module (the fit: global search, local search
//! with full-order confirmation), `posterior` (Markov-chain sampling and intervals),
//! `misfit`, `confirm` (full-order runs), `predictive` (posterior predictive, leave-one-out),
//! `result` and `report` (what is reported).

mod confirm;
mod layout;
mod misfit;
pub use misfit::{bound_parameters, tension_reading_side};
mod options;
mod posterior;
mod predictive;
mod report;
mod result;
mod targets;

use egobox_doe::{Lhs, LhsKind, SamplingMethod};
use fom::DriveConfig;
use ndarray::Array2;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;
use rayon::prelude::*;
use rom::Surrogate;

use crate::error::{Result, TwinError};
use crate::inference::likelihood::misfit_variance;
use crate::inference::optimise::nelder_mead;
use layout::{misfit, predict, Layout, Point};

pub use options::{Distances, FreeSet, StartupTarget, Target};
pub use predictive::{
    leave_one_out, leave_one_out_text, predict_condition, LeftOut, Predictive, PREDICTIVE_FOM_RUNS,
};
pub use report::{calibrated_config_toml, CalibrationReport};
pub use result::{Calibration, ConditionResult, Draw, Fitted, TensionPrior};
pub use targets::{read_slip_table, target_of_label, targets_from_dataset};

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
    calibrate_inner(s, cfg, targets, &[], free, (tolerance_pct, confirm), prior)
}

/// The steady slips' and the start-up slips' chi-square at a calibration's point (no prior;
/// the likelihood a `LocalFit` with start-up targets maximises, in two parts); infinite
/// outside the surrogate's range.
pub fn chi2_at(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    startup: &[StartupTarget],
    cal: &Calibration,
) -> [f64; 2] {
    let p = Point {
        d: cal.distances_m.clone(),
        mu: cal.friction,
        t: cal.installation_tension_n,
        offset: cal.slip_offset_pct,
        ea: cal.axial_stiffness_n,
    };
    chi2_parts_at(s, cfg, targets, startup, &p)
}

/// `likelihood_parts` at `p` without a full-order bias; infinite outside the surrogate's range.
fn chi2_parts_at(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    startup: &[StartupTarget],
    p: &Point,
) -> [f64; 2] {
    likelihood_parts(s, cfg, targets, startup, &vec![0.0; targets.len()], p)
        .unwrap_or([f64::INFINITY; 2])
}

/// -2 ln likelihood at `p` in two parts, the steady slips' (with the full-order minus
/// surrogate slip `bias` per condition added to the prediction) and the start-up slips'; None
/// outside the surrogate's range.
fn likelihood_parts(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    startup: &[StartupTarget],
    bias: &[f64],
    p: &Point,
) -> Option<[f64; 2]> {
    let pred = predict(s, cfg, p).ok()??;
    let steady = pred
        .iter()
        .zip(targets)
        .zip(bias)
        .map(|(((m, v), t), b)| {
            let var = misfit_variance(t.mean_se_pct, *v, t.mean_slip_pct);
            (m + b - t.mean_slip_pct).powi(2) / var
        })
        .sum::<f64>();
    let qs: Vec<fom::DesignPoint> = p.design_points().collect();
    let run_up = startup
        .iter()
        .map(|u| {
            let m = s.predict_startup_mean_pct(cfg, &qs[u.condition], u.until_s) + p.offset;
            ((m - u.mean_slip_pct) / u.sd_pct).powi(2)
        })
        .sum::<f64>();
    Some([steady, run_up])
}

fn calibrate_inner(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    startup: &[StartupTarget],
    free: FreeSet,
    (tolerance_pct, confirm): (f64, bool),
    prior: Prior,
) -> Result<Calibration> {
    check_tolerance(tolerance_pct)?;
    let search = GlobalSearch::new(s, cfg, targets, free)?;
    let fit = LocalFit::new(
        &search,
        s,
        cfg,
        targets,
        startup,
        (tolerance_pct, confirm),
        prior,
    )?;
    fit.finish()
}

fn check_tolerance(tolerance_pct: f64) -> Result<()> {
    if tolerance_pct.is_finite() && tolerance_pct > 0.0 {
        return Ok(());
    }
    Err(TwinError::InvalidArgument {
        input: rom::Input::CalibrationTolerance,
        message: format!("must be positive, got {tolerance_pct}"),
    })
}

/// The calibration's global stage, which depends on the steady slips and the free parameters
/// alone: the search space, and its Latin-hypercube points inside the surrogate's range, best
/// first. Calibrations to the same steady slips share it (`rom gap`'s baseline with and
/// without the run-ups), and get the same points from it.
pub struct GlobalSearch {
    layout: Layout,
    xs: Vec<Vec<f64>>,
    order: Vec<usize>,
}

impl GlobalSearch {
    /// The global stage for `targets` with `free` parameters.
    pub fn new(
        s: &Surrogate,
        cfg: &DriveConfig,
        targets: &[Target],
        free: FreeSet,
    ) -> Result<Self> {
        if targets.is_empty() {
            return Err(TwinError::Calibration(
                "nothing to calibrate to (no conditions)".into(),
            ));
        }
        let layout = Layout::new(s, cfg, targets, free)?;
        let (xs, order) = global_search(s, cfg, targets, &layout)?;
        Ok(Self { layout, xs, order })
    }
}

/// A calibration's fitted point before its posterior is sampled (`finish`): where a caller
/// keeps a fit only if its point passes a test, a fit set aside costs its local search alone.
pub struct LocalFit<'a> {
    search: &'a GlobalSearch,
    objective: Objective<'a>,
    fit: Fit,
    tolerance_pct: f64,
    confirm: bool,
}

impl<'a> LocalFit<'a> {
    /// The local stage from `search`'s five best points: the steady slips of `targets`, the
    /// start-up slips of `startup` as well (none: the steady slips alone), under `prior`;
    /// `confirm` runs the full-order model at the fitted point (seed paper Figure 1). `targets`
    /// are those `search` was made for.
    pub fn new(
        search: &'a GlobalSearch,
        s: &'a Surrogate,
        cfg: &'a DriveConfig,
        targets: &'a [Target],
        startup: &'a [StartupTarget],
        (tolerance_pct, confirm): (f64, bool),
        prior: Prior,
    ) -> Result<Self> {
        check_tolerance(tolerance_pct)?;
        if targets.len() != search.layout.n {
            return Err(TwinError::Calibration(format!(
                "{} conditions against a global search made for {}",
                targets.len(),
                search.layout.n
            )));
        }
        let objective = Objective {
            s,
            cfg,
            targets,
            startup,
            layout: &search.layout,
            prior,
            reading: None,
        };
        let starts: Vec<Vec<f64>> = search
            .order
            .iter()
            .take(5)
            .map(|&i| search.xs[i].clone())
            .collect();
        let fit = fit_and_confirm(&objective, starts, confirm, tolerance_pct)?;
        Ok(Self {
            search,
            objective,
            fit,
            tolerance_pct,
            confirm,
        })
    }

    /// The steady slips' chi-square and that of the start-up slips `startup` at the fitted
    /// point, as `chi2_at` gives them for the finished calibration.
    pub fn chi2_parts(&self, startup: &[StartupTarget]) -> [f64; 2] {
        let o = &self.objective;
        chi2_parts_at(o.s, o.cfg, o.targets, startup, &self.fit.p)
    }

    /// The fitted friction coefficient and installation tension (N).
    pub fn friction_and_tension(&self) -> (f64, f64) {
        (self.fit.p.mu, self.fit.p.t)
    }

    /// The calibration: the posterior sampled about the fitted point, the intervals, the
    /// conditions and the signs of misfit. Where the targets' tension readings give an
    /// installation tension (`layout::tension_from_readings`) that this calibration from the
    /// speeds agrees with (no `misfit::tension_reading_flag`), it is made again with the
    /// readings as the tension's prior, in place of the nominal one, and that is kept
    /// (`Calibration::tension_prior` says so): creep slip leaves the tension free, the meter
    /// pins it. Where they disagree, the readings stay a check, as the flag
    /// (docs/decisions/tension-reading.md, "Where the speeds agree").
    pub fn finish(self) -> Result<Calibration> {
        let (cal, read) = self.sample()?;
        let Some((read_n, read_sd_n)) = read.filter(|_| self.search.layout.free.tension) else {
            return Ok(cal);
        };
        if misfit::tension_reading_side(&cal.misfit).is_some() {
            return Ok(cal);
        }
        let objective = Objective {
            reading: Some((read_n, read_sd_n)),
            ..self.objective
        };
        let starts: Vec<Vec<f64>> = std::iter::once(self.fit.best.clone())
            .chain(
                self.search
                    .order
                    .iter()
                    .take(5)
                    .map(|&i| self.search.xs[i].clone()),
            )
            .collect();
        let fit = fit_and_confirm(&objective, starts, self.confirm, self.tolerance_pct)?;
        let again = Self {
            objective,
            fit,
            ..self
        };
        let (mut with_reading, _) = again.sample()?;
        with_reading.tension_prior = Some(TensionPrior {
            read_n,
            read_sd_n,
            speeds_only_n: cal.installation_tension_n,
            speeds_only_interval90: cal
                .interval90("installation_tension_n", cal.installation_tension_n),
        });
        Ok(with_reading)
    }

    /// The posterior sampled about the fitted point, the intervals, the conditions and the
    /// signs of misfit; with the installation tension and sd the targets' tension readings give
    /// (`layout::tension_from_readings`), against which the misfit checks the fitted one.
    fn sample(&self) -> Result<(Calibration, Option<(f64, f64)>)> {
        let Self {
            search,
            objective,
            fit,
            tolerance_pct,
            ..
        } = self;
        let tolerance_pct = *tolerance_pct;
        let (layout, targets) = (&search.layout, objective.targets);
        // Several chains from the fit and from the best distinct Latin-hypercube points,
        // pooled: along the looseness ridge (distance against tension) one random walk mixes
        // slowly.
        let chain_starts: Vec<Vec<f64>> = std::iter::once(fit.best.clone())
            .chain(search.order.iter().take(7).map(|&i| search.xs[i].clone()))
            .collect();
        let chain = posterior::sample(
            &|x: &[f64]| objective.chi2(&fit.bias, x),
            &chain_starts,
            &layout.bounds,
        );
        let parameters = posterior::fitted_parameters(layout, &chain, &fit.best);
        let conditions = result::conditions(targets, &fit.p, &fit.pred, fit.fom.as_deref());
        let within_tolerance = conditions
            .iter()
            .all(|c| c.fom_error_pct.unwrap_or(c.error_pct) <= tolerance_pct);
        let mut misfit = misfit::misfit_flags(
            objective.s.max_trained_slip_pct,
            &parameters,
            &layout.bounds,
            &conditions,
            targets,
            &fit.pred,
        );
        let read = layout::tension_from_readings(objective.cfg, targets, fit.p.ea)?;
        misfit.extend(misfit::tension_reading_flag(&parameters, fit.p.t, read));
        let free = layout.free;
        let posterior = posterior::draws(layout, &chain, free);
        let p = fit.p.clone();
        let cal = Calibration {
            posterior,
            parameters,
            conditions,
            friction: p.mu,
            installation_tension_n: p.t,
            slip_offset_pct: p.offset,
            axial_stiffness_n: p.ea,
            spacing_m: (free.distances == Distances::EquallySpaced)
                .then(|| [fit.best[0], fit.best[1]]),
            distances_m: p.d,
            tension_prior: None,
            within_tolerance,
            tolerance_pct,
            confirmations: fit.confirmations,
            misfit,
        };
        Ok((cal, read))
    }
}

/// Global stage: a Latin hypercube of 20,000 points over the box, scored by the relative
/// misfit; the points and the indices of those inside the surrogate's range, best first.
fn global_search(
    s: &Surrogate,
    cfg: &DriveConfig,
    targets: &[Target],
    layout: &Layout,
) -> Result<(Vec<Vec<f64>>, Vec<usize>)> {
    let dim = layout.bounds.len();
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
    Ok((xs, order))
}

/// The calibration's objective: -2 ln of the likelihood (`misfit_variance`) and the prior.
#[derive(Clone, Copy)]
struct Objective<'a> {
    s: &'a Surrogate,
    cfg: &'a DriveConfig,
    targets: &'a [Target],
    startup: &'a [StartupTarget],
    layout: &'a Layout,
    prior: Prior,
    /// The installation tension the tension readings give and its sd, N, as the tension's
    /// prior in place of `prior`'s (`LocalFit::finish`).
    reading: Option<(f64, f64)>,
}

impl Objective<'_> {
    /// -2 ln prior (a constant dropped), over the free parameters: zero for the flat prior;
    /// the tension's term from the readings where they are taken in (`reading`).
    fn prior_term(&self, p: &Point) -> f64 {
        let (st, l) = (&self.s.settings, self.layout);
        let z2 = |free: bool, v: f64, v0: f64, sd: f64| {
            if free {
                ((v - v0) / sd).powi(2)
            } else {
                0.0
            }
        };
        let nominal_sd = |[lo, hi]: [f64; 2]| NOMINAL_PRIOR_SHARE * (hi - lo);
        let nominal = self.prior == Prior::Nominal;
        let friction = z2(
            nominal && l.free.friction,
            p.mu,
            l.mu0,
            nominal_sd(st.friction),
        );
        let tension = match self.reading {
            Some((t_n, sd_n)) => z2(l.free.tension, p.t, t_n, sd_n),
            None => z2(
                nominal && l.free.tension,
                p.t,
                l.t0,
                nominal_sd(st.installation_tension_n),
            ),
        };
        friction + tension
    }

    /// The chi-square at `x` with the full-order minus surrogate slip `bias` per condition
    /// added to the prediction; infinite outside the surrogate's range.
    fn chi2(&self, bias: &[f64], x: &[f64]) -> f64 {
        let p = self.layout.decode(x);
        match likelihood_parts(self.s, self.cfg, self.targets, self.startup, bias, &p) {
            Some([steady, run_up]) => steady + run_up + self.prior_term(&p),
            None => f64::INFINITY,
        }
    }
}

/// The fitted point and what the fit loop leaves for the posterior.
struct Fit {
    best: Vec<f64>,
    p: Point,
    pred: Vec<(f64, f64)>,
    fom: Option<Vec<f64>>,
    bias: Vec<f64>,
    confirmations: usize,
}

/// Local stage: Nelder-Mead from each start, the best kept. `bias`: the full-order minus
/// surrogate slip per condition at the last confirmed point (zero at first). Figure 1 of the
/// seed paper: update, confirm, repeat while the full model misses the tolerance (at most three
/// confirmations).
fn fit_and_confirm(
    o: &Objective,
    mut starts: Vec<Vec<f64>>,
    confirm: bool,
    tolerance_pct: f64,
) -> Result<Fit> {
    let (s, cfg, targets) = (o.s, o.cfg, o.targets);
    let mut bias = vec![0.0; targets.len()];
    let mut confirmations = 0;
    let (best, p, pred, fom) = loop {
        let chi2 = |x: &[f64]| o.chi2(&bias, x);
        // The fitted point maximises the likelihood the intervals come from. The starts run in
        // parallel; the best is taken in start order, so the result does not depend on threads.
        let best = starts
            .par_iter()
            .map(|x0| nelder_mead(&|x: &[f64]| chi2(x).min(1e12), x0, &o.layout.bounds, 400))
            .collect::<Vec<_>>()
            .into_iter()
            .min_by(|a, b| chi2(a).total_cmp(&chi2(b)))
            .expect("five starts");
        let p = o.layout.decode(&best);
        let pred = predict(s, cfg, &p)?.ok_or_else(|| {
            TwinError::Calibration("the fitted point left the surrogate's range".into())
        })?;
        if !confirm {
            break (best, p, pred, None);
        }
        let fom = confirm::confirm_with_fom(s, cfg, &p)?;
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
    Ok(Fit {
        best,
        p,
        pred,
        fom,
        bias,
        confirmations,
    })
}
