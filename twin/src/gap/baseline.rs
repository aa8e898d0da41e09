//! Stage "baseline": the twin at each label. The surrogate calibrated to the fitted labels
//! (`calibration`) gives each label's design point and slip level; a reduced-resolution
//! full-order run there (plus two friction-spread runs and one run per candidate variant at
//! its reference magnitude) is read like the measurement (`twin_runs`, `features`).

use fom::stats::Z90;
use fom::{DesignPoint, DriveConfig};
use rayon::prelude::*;
use rom::Surrogate;

use super::cells::{slip_mean_cell, t90_cell};
use super::features::{
    blade_line, features, pool, steady_speeds, BandContext, Features, Read, SteadySpeeds, CELLS,
};
use super::reading::{tachometer_sensor, twin_features, variant_features};
use super::report::{FailedRun, UnsettledLabel};
use super::twin_runs::{run, run_config, Variant};
use super::Diagnosis;
use crate::calibrate::{target_of_label, Calibration, Draw, Target};
use crate::error::{Result, TwinError};
use crate::measured::DataSet;
use crate::sensor::{SensorModel, NOISE_TAPS};

/// What a label's twin needs before its runs: the calibrated point, the measured cells and the
/// surrogate's view of it.
struct Prelim {
    label: String,
    q: DesignPoint,
    measured: Features,
    /// The recordings' common sample interval, s.
    dt: f64,
    /// The surrogate's mean slip at the point (without the offset) and its sd, %.
    surrogate_slip_pct: f64,
    likelihood_std_pct: f64,
    friction_sd: f64,
    posterior_slip_sd: f64,
    startup_share: f64,
    tension_elasticity: f64,
    /// On the knee's cliff, the ends of the installation tension's 90 % posterior interval,
    /// N, at which the twin runs twice more (`tension_sd`).
    tension_ends_n: Option<[f64; 2]>,
}

/// The label's calibrated design point: a fitted label's fitted distance, else its known
/// distance, else the distance whose twin slip matches its measured slip.
fn point_of(d: &Diagnosis, fit_targets: &[Target], t: &Target) -> Result<DesignPoint> {
    let dist = match fit_targets.iter().position(|x| x.label == t.label) {
        Some(k) => d.cal.distances_m[k],
        None => match t.known_center_distance_m {
            Some(dist) => dist,
            None => invert_distance(d.s, d.cfg, &d.cal, t.mean_slip_pct)?,
        },
    };
    Ok(d.cal.design_point(dist))
}

/// The surrogate's side of a label's twin: its point, its measured cells, the calibrated slip
/// and its friction sd, the start-up spread and the slip's elasticity to the tension.
fn prelim(d: &Diagnosis, targets: &[Target], fit_targets: &[Target], l: &str) -> Result<Prelim> {
    let (s, cfg, cal) = (d.s, d.cfg, &d.cal);
    let t = targets
        .iter()
        .find(|t| t.label == l)
        .expect("a usable label has a target");
    let q = point_of(d, fit_targets, t)?;
    let (measured, dt) = measured_features(d.set, l, d.ratio, &d.ctx)?;
    let pred = |q: &DesignPoint| -> Result<f64> {
        Ok(s.predict_mean_slip_pct(cfg, q) + cal.slip_offset_pct)
    };
    let p = s.predict_point(cfg, &q)?;
    let shifted = |f: &dyn Fn(&mut DesignPoint)| -> Result<f64> {
        let mut x = q;
        f(&mut x);
        pred(&x)
    };
    let mu = q.friction;
    let friction_sd =
        (shifted(&|x| x.friction = mu * 1.01)? - shifted(&|x| x.friction = mu * 0.99)?).abs()
            / (2.0 * 3f64.sqrt());
    let startup_share = startup_spread(s, cfg, cal, &q, measured.cells[t90_cell()].value);
    let tension_elasticity = tension_elasticity(s, cfg, &q, cal.slip_offset_pct)?;
    let fitted_position = fit_targets
        .iter()
        .any(|x| x.label == l)
        .then_some(t.position);
    let posterior_slip_sd = posterior_slip_sd(s, cfg, &cal.posterior, &q, fitted_position);
    let tension_ends_n = (tension_elasticity.abs() > KNEE_ELASTICITY)
        .then(|| cal.interval90("installation_tension_n", q.installation_tension_n));
    Ok(Prelim {
        label: l.to_string(),
        q,
        measured,
        dt,
        surrogate_slip_pct: p.mean_slip_pct,
        likelihood_std_pct: p.likelihood_std_pct,
        friction_sd,
        posterior_slip_sd,
        startup_share,
        tension_elasticity,
        tension_ends_n,
    })
}

/// d ln(slip) / d ln(installation tension) of the calibrated surrogate (slip with the offset
/// `offset_pct`) at `q`: a central difference over +-5 % of the tension; 0 where a slip is not
/// positive.
pub(super) fn tension_elasticity(
    s: &Surrogate,
    cfg: &DriveConfig,
    q: &DesignPoint,
    offset_pct: f64,
) -> Result<f64> {
    let at = |factor: f64| -> Result<f64> {
        let mut x = *q;
        x.installation_tension_n *= factor;
        Ok(s.predict_mean_slip_pct(cfg, &x) + offset_pct)
    };
    let (lo, hi) = (at(0.95)?, at(1.05)?);
    Ok(if lo > 0.0 && hi > 0.0 {
        (hi / lo).ln() / (1.05f64 / 0.95).ln()
    } else {
        0.0
    })
}

/// Most posterior draws propagated per label.
const POSTERIOR_DRAWS: usize = 200;

/// The sd of the calibrated slip at a label over the calibration's posterior (its Metropolis
/// draws, thinned to `POSTERIOR_DRAWS`): each draw's friction, tension and slip offset, and
/// for a fitted label (`position`) with equally spaced free distances its distance, through
/// the surrogate at `q`'s other settings. In creep it is about the fitted slip's own error; on
/// the knee's cliff, where the slip moves ~10 % for 1 % of tension, it carries where on the
/// cliff the calibration may have put the twin. Draws the surrogate refuses (past its box) are
/// skipped; 0 with fewer than two left.
pub(super) fn posterior_slip_sd(
    s: &Surrogate,
    cfg: &DriveConfig,
    draws: &[Draw],
    q: &DesignPoint,
    position: Option<f64>,
) -> f64 {
    let step = (draws.len() / POSTERIOR_DRAWS).max(1);
    let slips: Vec<f64> = draws
        .iter()
        .step_by(step)
        .filter_map(|dr| {
            let mut x = *q;
            if let (Some([d0, spacing]), Some(p)) = (dr.spacing_m, position) {
                x.center_distance_m = d0 - p * spacing;
            }
            x.friction = dr.friction;
            x.installation_tension_n = dr.installation_tension_n;
            x.axial_stiffness_n = dr.axial_stiffness_n.or(q.axial_stiffness_n);
            let slip = s.predict_mean_slip_pct(cfg, &x) + dr.slip_offset_pct;
            slip.is_finite().then_some(slip)
        })
        .collect();
    if slips.len() < 2 {
        0.0
    } else {
        fom::stats::sample_std(&slips)
    }
}

/// One full-order run of a label's twin: at the calibrated point with the friction scaled by a
/// factor (1: the baseline run), at another installation tension (N), or with a variant at its
/// reference magnitude.
#[derive(Clone, Copy)]
enum Job {
    Friction(f64),
    Tension(f64),
    Variant(usize),
}

/// The label twins and the sensitivity runs that failed. Per label: the baseline run, the two
/// friction-spread runs (`FRICTION_SPREAD`), on the knee's cliff the two tension runs
/// (`tension_sd`), then one run per variant at its reference magnitude, all in parallel.
pub(super) fn label_twins(
    d: &Diagnosis,
    targets: &[Target],
    fit_targets: &[Target],
    vars: &[Variant],
) -> Result<(Vec<LabelTwin>, Vec<FailedRun>)> {
    let mut prelims = Vec::new();
    for l in &d.labels {
        prelims.push(prelim(d, targets, fit_targets, l)?);
    }
    let jobs: Vec<(usize, Job)> = prelims
        .iter()
        .enumerate()
        .flat_map(|(l, p)| {
            [1.0, 1.0 + FRICTION_SPREAD, 1.0 - FRICTION_SPREAD]
                .map(Job::Friction)
                .into_iter()
                .chain(p.tension_ends_n.into_iter().flatten().map(Job::Tension))
                .chain((0..vars.len()).map(Job::Variant))
                .map(move |j| (l, j))
        })
        .collect();
    let runs: Vec<Result<Vec<fom::OutputRow>>> = jobs
        .par_iter()
        .map(|&(l, job)| {
            let p = &prelims[l];
            let mut q = p.q;
            let mut spec = None;
            match job {
                Job::Friction(factor) => q.friction *= factor,
                Job::Tension(t) => q.installation_tension_n = t,
                Job::Variant(v) => spec = Some(vars[v].spec(vars[v].reference)),
            }
            let c = run_config(
                d.cfg,
                &q,
                &d.opts.resolution,
                p.dt,
                twin_run_s(&p.measured, d.s),
                spec.as_deref(),
            )?;
            run(&c)
        })
        .collect();
    let mut per_label: Vec<Vec<_>> = (0..prelims.len()).map(|_| Vec::new()).collect();
    for (&(l, _), r) in jobs.iter().zip(runs) {
        per_label[l].push(r);
    }
    // The settled labels first: an unsettled label's twin takes its slip level's resolution
    // shift from the nearest of them (`label_twin`).
    let mut order: Vec<usize> = (0..prelims.len()).collect();
    order.sort_by_key(|&k| prelims[k].measured.unsettled);
    // The sensor's noise, one for the data set (docs/decisions/correlated-sensor-noise.md).
    let noise = super::sensor_noise::DataSetNoise::of(prelims.iter().map(|p| &p.measured));
    let mut prelims: Vec<Option<Prelim>> = prelims.into_iter().map(Some).collect();
    let mut twins: Vec<Option<LabelTwin>> = (0..prelims.len()).map(|_| None).collect();
    let mut failed = Vec::new();
    for k in order {
        let p = prelims[k].take().expect("each label once");
        let shift = p
            .measured
            .unsettled
            .then(|| nearest_resolution_shift(d, &p.q, &twins))
            .transpose()?;
        let runs = &mut std::mem::take(&mut per_label[k]).into_iter();
        twins[k] = Some(label_twin(d, p, runs, vars, &mut failed, shift, noise)?);
    }
    Ok((twins.into_iter().flatten().collect(), failed))
}

/// The reduced run's slip level below the surrogate's (full resolution), pp, at the settled
/// label twin nearest to `q` in centre distance: what an unsettled label's twin, which has no
/// settled level of its own to move, is moved by besides the calibration's slip offset
/// (docs/decisions/gap-unsettled-labels.md).
fn nearest_resolution_shift(
    d: &Diagnosis,
    q: &DesignPoint,
    twins: &[Option<LabelTwin>],
) -> Result<f64> {
    twins
        .iter()
        .flatten()
        .filter(|lt| !lt.measured.unsettled)
        .min_by(|a, b| {
            let gap = |lt: &LabelTwin| (lt.q.center_distance_m - q.center_distance_m).abs();
            gap(a).total_cmp(&gap(b))
        })
        .map(|lt| lt.slip_shift_pct - d.cal.slip_offset_pct)
        .ok_or_else(|| TwinError::Gap("no settled label to take the twin's slip level from".into()))
}

/// One label's twin from its prelim and its runs (taken from `runs` in job order). The
/// reduced run's slip is moved to the surrogate's calibrated level over the window, or, at an
/// unsettled label, by the calibration's slip offset and `resolution_shift_pct`.
fn label_twin(
    d: &Diagnosis,
    p: Prelim,
    runs: &mut impl Iterator<Item = Result<Vec<fom::OutputRow>>>,
    vars: &[Variant],
    failed: &mut Vec<FailedRun>,
    resolution_shift_pct: Option<f64>,
    noise: super::sensor_noise::DataSetNoise,
) -> Result<LabelTwin> {
    let (model_ratio, ratio, ctx) = (d.model_ratio, d.ratio, &d.ctx);
    let ratios = (model_ratio, ratio);
    let label = p.label;
    let tension_ends_n = p.tension_ends_n;
    let run_s = twin_run_s(&p.measured, d.s);
    let baseline_rows = runs
        .next()
        .expect("one run per job")
        .map_err(|e| TwinError::Gap(format!("the twin's run at label {label} failed: {e}")))?;
    let slip_pct = p.surrogate_slip_pct + d.cal.slip_offset_pct;
    let lattice_read = d.sensor.pulses_x_timer_s.is_some();
    let mut lt = LabelTwin {
        // Readings on a lattice jump between its levels, which first differences take for
        // noise: there the sensor stage's white noise about the levels.
        noise_rpm: if lattice_read {
            d.sensor.speed_noise_rpm
        } else {
            [0, 1].map(|j| match noise.correlated[j] {
                true => p.measured.scatter_rpm[j].max(p.measured.noise_rpm[j]),
                false => p.measured.noise_rpm[j],
            })
        },
        noise_correlated: noise.correlated.map(|c| c && !lattice_read),
        noise_taps: match lattice_read {
            true => [None; 2],
            false => noise.taps,
        },
        label,
        measured: p.measured,
        q: p.q,
        slip_pct,
        slip_sd_pct: p.likelihood_std_pct,
        friction_sd_pct: p.friction_sd,
        posterior_slip_sd_pct: p.posterior_slip_sd,
        startup_share: p.startup_share,
        startup_shift_pct: 0.0,
        run_s,
        sample_interval_s: p.dt,
        slip_shift_pct: 0.0,
        baseline_rows,
        baseline: Features::default(),
        variant: Vec::new(),
        run_spread: Vec::new(),
        sensor: SensorModel::default(),
        tension_elasticity: p.tension_elasticity,
        tension_ends_n,
        tension_sd: vec![0.0; CELLS.len()],
        lattice_read,
        synchronous_rpm: d.cfg.driver.motor.as_ref().map(|m| m.synchronous_rpm),
    };
    lt.startup_shift_pct = startup_resolution_shift(d.s, d.cfg, &lt, model_ratio);
    // The sensor identified from the recordings (the configuration's where they say nothing).
    let id = &d.sensor;
    lt.sensor = tachometer_sensor(
        &lt,
        (id.twin_pulses_per_rev, id.twin_timer_resolution_s),
        id,
        (model_ratio, ratio),
    )
    .ok_or_else(|| {
        TwinError::Gap(format!(
            "the twin's sensor ({} pulses per revolution) gives no steady reading at label {}",
            id.twin_pulses_per_rev, lt.label
        ))
    })?;
    // The twin's slip level: the surrogate's (full resolution, calibrated); the reduced
    // run's own level over its window is moved there.
    let unshifted = twin_features(&lt, &lt.baseline_rows, &lt.sensor, model_ratio, ratio, ctx)
        .map_err(|e| TwinError::Gap(format!("the twin's run at label {}: {e}", lt.label)))?;
    lt.slip_shift_pct = match resolution_shift_pct {
        None => slip_pct - unshifted.cells[slip_mean_cell()].value,
        Some(r) => d.cal.slip_offset_pct + r,
    };
    lt.baseline = twin_features(&lt, &lt.baseline_rows, &lt.sensor, model_ratio, ratio, ctx)?;
    // The next run's cells, or an error naming the run (`what`).
    let mut next_cells = |lt: &LabelTwin, what: String| -> Result<Features> {
        let rows = runs.next().expect("one run per job").map_err(|e| {
            TwinError::Gap(format!(
                "the twin's run at label {} {what} failed: {e}",
                lt.label
            ))
        })?;
        twin_features(lt, &rows, &lt.sensor, model_ratio, ratio, ctx)
    };
    let mut spread_runs = Vec::new();
    for sign in ["+", "-"] {
        let what = format!("with friction {sign}{:.0} %", 100.0 * FRICTION_SPREAD);
        spread_runs.push(next_cells(&lt, what)?);
    }
    lt.run_spread = run_spread(&lt.baseline, &spread_runs);
    if let Some([lo, hi]) = tension_ends_n {
        let at_lo = next_cells(&lt, format!("at installation tension {lo:.1} N"))?;
        let at_hi = next_cells(&lt, format!("at installation tension {hi:.1} N"))?;
        lt.tension_sd = tension_sd(&at_lo, &at_hi);
    }
    for v in vars {
        let rows = runs.next().expect("one run per job");
        let f = rows.and_then(|r| variant_features(&lt, &r, &v.line_cells(), ratios, ctx));
        let spec = v.spec(v.reference);
        let f = record_failure(f, failed, &lt.label, &spec, "sensitivity");
        lt.variant.push(f);
    }
    Ok(lt)
}

/// Twin cells at a label with variant `v` on as `spec`, at tension `tension_n` (None: calibrated).
pub(super) fn effect_features_at(
    d: &Diagnosis,
    lt: &LabelTwin,
    tension_n: Option<f64>,
    v: &Variant,
    spec: &str,
) -> Result<Features> {
    let mut q = lt.q;
    if let Some(t) = tension_n {
        q.installation_tension_n = t;
    }
    let c = run_config(
        d.cfg,
        &q,
        &d.opts.resolution,
        lt.sample_interval_s,
        lt.run_s,
        Some(spec),
    )?;
    let ratios = (d.model_ratio, d.ratio);
    variant_features(lt, &run(&c)?, &v.line_cells(), ratios, &d.ctx)
}

/// |d ln slip / d ln T0| above which a label's calibrated twin counts as sitting in its
/// looseness knee: a 1 % error of the installation tension there moves the slip by more than
/// 1 %. In creep the slip is the transmitted force over EA (Johnson, Contact Mechanics, 1985,
/// sec. 8.7), nearly free of T0 (elasticity ~0.05 on the default drive); on the knee's cliff
/// it reaches ~10. There every cell of the twin depends on where on the cliff the calibration
/// put it: the slip cells carry the posterior's spread through the surrogate
/// (`posterior_slip_sd`), every other cell the tension's through two more runs (`tension_sd`).
/// A drive whose knee has another shape also answers an effect differently in every cell:
/// another simulator's 1.5 N m of drag was "unexplained" because the twin's knee label
/// answered 1 N m with 3.5 pp of slip where that drive's answered 0.2 pp, and ranked with
/// both spreads it still was (docs/decisions/knee-labels-take-part.md). Such labels are left
/// out of the effects' ranking and gap figures, and their gap is reported apart.
pub(super) const KNEE_ELASTICITY: f64 = 1.0;

/// The twin at one label.
pub(super) struct LabelTwin {
    pub label: String,
    pub measured: Features,
    pub q: DesignPoint,
    /// Calibrated surrogate mean slip (with offset), its sd and the friction uncertainty's sd,
    /// %.
    pub slip_pct: f64,
    pub slip_sd_pct: f64,
    pub friction_sd_pct: f64,
    /// The calibrated slip's sd over the calibration's posterior, % (`posterior_slip_sd`).
    pub posterior_slip_sd_pct: f64,
    /// Relative sd of the start-up slip from the calibration's posterior (friction and tension
    /// at the ends of their 90 % intervals, through the surrogate's start-up series).
    pub startup_share: f64,
    /// The surrogate's start-up slip (full resolution, calibrated) minus the reduced run's over
    /// the same start-up grid up to t90, pp: added to the twin's start-up slip, as the steady
    /// level is moved to the surrogate's.
    pub startup_shift_pct: f64,
    /// The measured white noise per shaft, rpm: from first differences, about the levels of
    /// a timer lattice the sensor stage read, or, on a shaft whose noise is correlated over a
    /// few readings (`noise_correlated`), the recordings' scatter about 20 ms.
    pub noise_rpm: [f64; 2],
    /// Per shaft, whether the data set's noise is correlated over a few readings
    /// (`features::correlated_noise`; never beside a read lattice).
    pub noise_correlated: [bool; 2],
    /// Per shaft where it is, the taps of the filter that gives the twin's noise the
    /// recordings' autocorrelation (`crate::sensor::noise_taps_for`).
    pub noise_taps: [Option<[f64; NOISE_TAPS]>; 2],
    /// The twin's sensor: the one identified from the recordings (`sensor_id`; the
    /// configuration's tachometer, `[effects.tachometer]` or the default 60-pulse wheel, where
    /// they say nothing) with the white noise the recording shows beyond its own scatter.
    pub sensor: SensorModel,
    pub sample_interval_s: f64,
    /// Length of the twin's runs at this label, s (`twin_run_s`).
    pub run_s: f64,
    pub slip_shift_pct: f64,
    pub baseline_rows: Vec<fom::OutputRow>,
    pub baseline: Features,
    /// Per mechanical variant: cells at its reference magnitude.
    pub variant: Vec<Option<Features>>,
    /// Per cell, the twin's own spread under the friction uncertainty, 1 sd (`run_spread`).
    pub run_spread: Vec<f64>,
    /// d ln(slip) / d ln(installation tension) of the calibrated surrogate at the label.
    pub tension_elasticity: f64,
    /// On the knee's cliff (`KNEE_ELASTICITY`), the ends of the installation tension's 90 %
    /// posterior interval, N, at which the twin ran twice more.
    pub tension_ends_n: Option<[f64; 2]>,
    /// Per cell, the twin's spread under the tension's posterior, 1 sd (`tension_sd`; zero off
    /// the knee's cliff).
    pub tension_sd: Vec<f64>,
    /// Whether the sensor stage read a timer's lattice in the recordings: the cells that the
    /// lattice shapes are then read at the measured speeds (`reading::at_measured_speeds`).
    pub lattice_read: bool,
    /// The driver's induction motor's synchronous speed, rpm (None: a prescribed speed), for
    /// the reduced resolution's tolerance on the driver's speed level (`cells::twin_tolerance`).
    pub synchronous_rpm: Option<f64>,
}

impl LabelTwin {
    /// How the twin's runs at this label are read to compare like with like with its
    /// measurement (`Read::like`).
    pub fn read(&self) -> Read {
        Read::like(&self.measured, self.run_s)
    }
}

/// Relative friction change of the two spread runs at each label: the friction uncertainty
/// (+-1 %, seed paper section 4.2), as for the slip level through the surrogate.
const FRICTION_SPREAD: f64 = 0.01;

/// Per cell, the sample sd of the twin's baseline run and its two friction-spread runs (the
/// same sensor noise, so their differences are the drive's): the friction uncertainty of the
/// steady cells that only runs give (spectral lines, broadband content, slip spread,
/// kurtosis), which batch means within one run do not see. The tension's uncertainty adds
/// `tension_sd` on the knee's cliff.
pub(super) fn run_spread(baseline: &Features, others: &[Features]) -> Vec<f64> {
    (0..CELLS.len())
        .map(|i| {
            let v: Vec<f64> = std::iter::once(baseline.cells[i].value)
                .chain(others.iter().map(|f| f.cells[i].value))
                .collect();
            if v.iter().all(|x| x.is_finite()) {
                fom::stats::sample_std(&v)
            } else {
                0.0
            }
        })
        .collect()
}

/// Per cell, the spread of the twin over the installation tension's posterior from its runs
/// at the two ends of the 90 % interval: half their difference over the normal 90 % quantile
/// (`Z90`), the sd of a normal whose 90 % interval they span (a linear response within the
/// interval, as the surrogate's start-up spread takes it: `startup_spread`). Zero where a run
/// has no value.
pub(super) fn tension_sd(lo: &Features, hi: &Features) -> Vec<f64> {
    lo.cells
        .iter()
        .zip(&hi.cells)
        .map(|(a, b)| {
            let half = 0.5 * (b.value - a.value).abs();
            if half.is_finite() {
                half / Z90
            } else {
                0.0
            }
        })
        .collect()
}

/// The features of a run with an effect, or its failure recorded in `failed` (`None`).
pub(super) fn record_failure(
    r: Result<Features>,
    failed: &mut Vec<FailedRun>,
    label: &str,
    spec: &str,
    purpose: &'static str,
) -> Option<Features> {
    r.map_err(|e| {
        failed.push(FailedRun {
            label: label.to_string(),
            effect: spec.to_string(),
            purpose,
            reason: e.to_string(),
        })
    })
    .ok()
}

/// Features of a label's recordings pooled; the recordings' common sample interval. Where one
/// of them still drifts at its end, every one is read over its last minimum window, so that
/// the pooled cells and the twin's window are one (docs/decisions/gap-unsettled-labels.md).
pub(super) fn measured_features(
    set: &DataSet,
    label: &str,
    ratio: f64,
    ctx: &BandContext,
) -> Result<(Features, f64)> {
    let runs = set.runs_of(label);
    let read = |i: usize, how: Read| {
        features(&set.recordings[i], ratio, ctx, how)
            .map_err(|e| TwinError::Unusable(format!("{}: {e}", set.manifest.runs[i].file)))
    };
    let mut f = runs
        .iter()
        .map(|&i| read(i, Read::Own))
        .collect::<Result<Vec<Features>>>()?;
    if f.iter().any(|x| x.unsettled) {
        for (x, &i) in f.iter_mut().zip(&runs) {
            if !x.unsettled {
                *x = read(i, Read::Window(x.running_s - fom::steady::MIN_WINDOW_S))?;
            }
        }
    }
    let dt: f64 = runs
        .iter()
        .map(|&i| {
            let rec = &set.recordings[i];
            (rec.time_s[rec.len() - 1] - rec.time_s[0]) / (rec.len() - 1) as f64
        })
        .sum();
    Ok((pool(f), dt / runs.len() as f64))
}

/// Blade count of the blade-pass band: the z in 3..=16 whose line at z x fan speed stands
/// highest above its noise floor over all recordings of the labels (summed (A / floor)^2).
pub(super) fn blade_count(set: &DataSet, labels: &[String], ratio: f64) -> u32 {
    let windows: Vec<SteadySpeeds> = labels
        .iter()
        .flat_map(|l| set.runs_of(l))
        .filter_map(|i| steady_speeds(&set.recordings[i], ratio, Read::Own).ok())
        .collect();
    (3..=16u32)
        .map(|z| {
            let score: f64 = windows
                .iter()
                .map(|w| blade_line(w, z))
                .map(|m| (m.value / m.se).powi(2))
                .sum();
            (z, score)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(8, |x| x.0)
}

/// How long the twin runs from standstill at a label: as long as the recording (its steady
/// window then sits as long after the start); a recording that starts in steady running (no
/// start-up cells) gets the surrogate's start-up horizon in front, so that the twin's compared
/// window is settled running too, not its run-up.
pub(super) fn twin_run_s(measured: &Features, s: &Surrogate) -> f64 {
    let startup_s = if measured.cells[t90_cell()].value.is_nan() {
        s.settings.min_duration_s
    } else {
        0.0
    };
    measured.running_s + startup_s
}

/// See `LabelTwin::startup_shift_pct`; zero when the run is shorter than the grid.
fn startup_resolution_shift(
    s: &Surrogate,
    cfg: &DriveConfig,
    lt: &LabelTwin,
    model_ratio: f64,
) -> f64 {
    let t90 = lt.measured.cells[t90_cell()].value;
    let grid: Vec<f64> = s
        .startup_time_s
        .iter()
        .copied()
        .filter(|&t| t <= t90)
        .collect();
    let rows: Vec<training::SeriesRow> = lt
        .baseline_rows
        .iter()
        .map(|r| training::SeriesRow {
            time_s: r.time_s,
            driver_rpm: r.driver_rpm,
            driven_rpm: r.driven_rpm,
            slip_pct: r.slip_pct,
        })
        .collect();
    let Ok(own) = rom::snapshots::startup_series(&rows, &grid, model_ratio) else {
        return 0.0;
    };
    let full = s.predict_startup(cfg, &lt.q);
    if grid.is_empty() {
        return 0.0;
    }
    let k = grid.len() as f64;
    (full.iter().take(grid.len()).sum::<f64>() - own.iter().sum::<f64>()) / k
}

/// Relative spread (1 sd) of the start-up slip mean over the first `t90_s` between the ends of
/// the calibration's 90 % intervals of friction and tension (the four corners through the
/// surrogate's start-up series; half the range over Z90).
fn startup_spread(
    s: &Surrogate,
    cfg: &DriveConfig,
    cal: &Calibration,
    q: &DesignPoint,
    t90_s: f64,
) -> f64 {
    let mu = cal.interval90("friction", q.friction);
    let t = cal.interval90("installation_tension_n", q.installation_tension_n);
    let means: Vec<f64> = mu
        .iter()
        .flat_map(|&m| t.iter().map(move |&tt| (m, tt)))
        .map(|(m, tt)| {
            let mut x = *q;
            x.friction = m;
            x.installation_tension_n = tt;
            s.predict_startup_mean_pct(cfg, &x, t90_s)
        })
        .collect();
    let lo = means.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = means.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let centre = 0.5 * (lo + hi);
    if centre.abs() > 0.0 && (hi - lo).is_finite() {
        0.5 * (hi - lo) / Z90 / centre.abs()
    } else {
        0.0
    }
}

/// Targets of the usable labels only: a settled label's steady slip; an unsettled label's
/// mean slip over its window, which only places a twin without a known distance (it is never
/// fitted).
pub(super) fn usable_targets(
    set: &DataSet,
    labels: &[String],
    ratio: f64,
    unsettled: &[UnsettledLabel],
) -> Result<Vec<Target>> {
    labels
        .iter()
        .enumerate()
        .map(
            |(k, label)| match unsettled.iter().find(|u| &u.label == label) {
                Some(u) => Ok(Target {
                    label: label.clone(),
                    mean_slip_pct: u.mean_slip_pct,
                    mean_se_pct: u.mean_slip_se_pct,
                    known_center_distance_m: set.known_center_distance_m(label),
                    tension_reading: set.tension_reading(label),
                    position: k as f64,
                }),
                None => target_of_label(set, label, k as f64, ratio),
            },
        )
        .collect()
}

/// An unsettled label's entry of the report from its measured cells.
pub(super) fn unsettled_label(label: &str, measured: &Features) -> UnsettledLabel {
    let slip = measured.cells[slip_mean_cell()];
    UnsettledLabel {
        label: label.to_string(),
        window_s: [
            measured.startup_s,
            measured.startup_s + fom::steady::MIN_WINDOW_S,
        ],
        mean_slip_pct: slip.value,
        mean_slip_se_pct: slip.se,
    }
}

/// The distance whose calibrated twin slip matches `slip_pct` (a withheld label with no known
/// distance), by bisection over the trained range (slip falls as d grows).
pub(super) fn invert_distance(
    s: &Surrogate,
    cfg: &DriveConfig,
    cal: &Calibration,
    slip_pct: f64,
) -> Result<f64> {
    let [mut lo, mut hi] = s.settings.center_distance_m;
    let f = |d: f64| -> Result<f64> {
        Ok(s.predict_mean_slip_pct(cfg, &cal.design_point(d)) + cal.slip_offset_pct - slip_pct)
    };
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if f(mid)? > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::twin_runs::{twin_recording, Resolution};
    use super::*;

    /// A label twin whose measurement is `measured` and whose baseline is unset.
    pub(in crate::gap) fn label_twin_of(measured: Features, lattice_read: bool) -> LabelTwin {
        let cfg = DriveConfig::default_hvac();
        LabelTwin {
            label: "d0".into(),
            // The white noise `SensorModel::default` adds.
            noise_rpm: [1.0; 2],
            noise_correlated: [false; 2],
            noise_taps: [None; 2],
            measured,
            q: DesignPoint::nominal(&cfg),
            slip_pct: 0.5,
            slip_sd_pct: 0.01,
            friction_sd_pct: 0.01,
            posterior_slip_sd_pct: 0.0,
            startup_share: 0.0,
            startup_shift_pct: 0.0,
            sensor: SensorModel::default(),
            sample_interval_s: 1e-3,
            run_s: 6.0,
            slip_shift_pct: 0.0,
            baseline_rows: Vec::new(),
            baseline: Features::default(),
            variant: Vec::new(),
            run_spread: vec![0.0; CELLS.len()],
            tension_elasticity: 0.0,
            tension_ends_n: None,
            tension_sd: vec![0.0; CELLS.len()],
            lattice_read,
            synchronous_rpm: None,
        }
    }

    /// 64 draws on a grid about `q`: friction +-0.5 %, installation tension +-2 % (a
    /// calibration's spread on healthy labels), no offset, the distance fixed.
    fn draws_about(q: &DesignPoint) -> Vec<Draw> {
        (0..64)
            .map(|k| {
                let a = ((k % 8) as f64 - 3.5) / 3.5;
                let b = ((k / 8) as f64 - 3.5) / 3.5;
                Draw {
                    spacing_m: None,
                    friction: q.friction * (1.0 + 0.005 * a),
                    installation_tension_n: q.installation_tension_n * (1.0 + 0.02 * b),
                    slip_offset_pct: 0.0,
                    axial_stiffness_n: None,
                }
            })
            .collect()
    }

    /// The first tension going down from the installed 250 N at the loosest sample label's
    /// 0.4165 m where the shipped surrogate's slip elasticity to the tension passes
    /// `KNEE_ELASTICITY`: the twin on its knee's cliff.
    fn knee_point(s: &Surrogate, cfg: &DriveConfig) -> DesignPoint {
        (0..60)
            .map(|k| {
                DesignPoint::nominal_with(cfg, Some(0.4165), None, Some(250.0 - 2.0 * k as f64))
            })
            .find(|q| tension_elasticity(s, cfg, q, 0.0).is_ok_and(|e| e.abs() > KNEE_ELASTICITY))
            .expect("a knee on the shipped surrogate")
    }

    /// The tension's spread per cell from two reduced twin runs (5 s from standstill, half
    /// the diagnosis's segments at twice its step to stay cheap) at +-2 % of `q`'s tension (a
    /// calibration's 90 % interval on healthy labels), read without sensor noise.
    fn tension_spread_at(cfg: &DriveConfig, q: &DesignPoint) -> Vec<f64> {
        let res = Resolution {
            segments: 60,
            step_s: 4.0e-5,
            ..Resolution::default()
        };
        let sensor = SensorModel {
            speed_noise_rpm: [0.0; 2],
            ..SensorModel::default()
        };
        let ctx = BandContext {
            blades: 8,
            belt_length_m: 1.6,
            driver_diameter_m: cfg.driver.pitch_diameter_m,
        };
        let ratio = cfg.transmission_ratio();
        let at: Vec<Features> = [0.98, 1.02]
            .par_iter()
            .map(|f| {
                let mut x = *q;
                x.installation_tension_n *= f;
                let c = run_config(cfg, &x, &res, 1e-3, 5.0, None).unwrap();
                let rec = twin_recording(&run(&c).unwrap(), ratio, ratio, 0.0, &sensor);
                features(&rec, ratio, &ctx, Read::Own).unwrap()
            })
            .collect();
        tension_sd(&at[0], &at[1])
    }

    /// On the knee's cliff the tension's spread through the twin's runs is large where in
    /// creep it is near zero (the diagnosis runs it on the cliff only): the steady slip level
    /// and the start-up time move over +-2 % of tension more than 5 times as much at the knee
    /// as in creep (slip nearly free of T0 there: Johnson, Contact Mechanics, 1985, sec.
    /// 8.7; the start-up ends when the belt grips). The start-up time is a cell whose sd takes
    /// this spread (`cells::tension_term`).
    #[test]
    fn the_tension_spread_is_wide_on_the_knee_cliff_and_near_zero_in_creep() {
        use crate::gap::cells::{slip_mean_cell, t90_cell};
        let s = rom::shipped::slip_model().unwrap().surrogate;
        let cfg = DriveConfig::default_hvac();
        let creep = DesignPoint::nominal_with(&cfg, Some(0.424), None, Some(250.0));
        let knee = knee_point(&s, &cfg);
        let sd_knee = tension_spread_at(&cfg, &knee);
        let sd_creep = tension_spread_at(&cfg, &creep);
        for i in [slip_mean_cell(), t90_cell()] {
            let (k, c) = (sd_knee[i], sd_creep[i]);
            assert!(k > 5.0 * c, "{}: sd knee {k}, creep {c}", CELLS[i].name());
        }
    }

    /// From the surrogate alone: the twin on its knee's cliff (the first tension, going down
    /// from the installed 250 N at the loosest sample label's 0.4165 m, where the slip's
    /// elasticity to the tension passes `KNEE_ELASTICITY`) carries the calibration's spread
    /// on its slip cells, many times the creep label's. In creep the slip is nearly free of
    /// T0 (elasticity below 0.2), on the cliff it moves more than 1 % per 1 % of T0: the
    /// tension's share of the relative spread is over 5 times larger there.
    #[test]
    fn a_knee_label_carries_the_posterior_spread_of_its_cliff() {
        let s = rom::shipped::slip_model().unwrap().surrogate;
        let cfg = DriveConfig::default_hvac();
        let creep = DesignPoint::nominal_with(&cfg, Some(0.424), None, Some(250.0));
        let e_creep = tension_elasticity(&s, &cfg, &creep, 0.0).unwrap();
        assert!(e_creep.abs() < 0.2, "creep elasticity {e_creep}");
        let knee = knee_point(&s, &cfg);
        let sd_creep = posterior_slip_sd(&s, &cfg, &draws_about(&creep), &creep, None);
        let sd_knee = posterior_slip_sd(&s, &cfg, &draws_about(&knee), &knee, None);
        let slip = |q: &DesignPoint| s.predict_point(&cfg, q).unwrap().mean_slip_pct;
        let (rel_creep, rel_knee) = (sd_creep / slip(&creep), sd_knee / slip(&knee));
        assert!(sd_knee > 0.0 && sd_creep >= 0.0);
        assert!(
            rel_knee > 5.0 * rel_creep,
            "relative slip sd: knee {rel_knee} (T0 {} N), creep {rel_creep}",
            knee.installation_tension_n
        );
    }
}
