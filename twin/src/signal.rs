//! Signal processing of measured speeds: the steady part of a recording, its slip samples and
//! the standard error of their mean. One definition, used by calibration and diagnosis.

use fom::slip::slip_pct;
use fom::stats::{median, quantile};
use fom::steady::{
    batch_means_se, is_running, max_driver_rpm, DRIFT_BATCHES, DRIFT_FLOOR_PP, DRIFT_FLOOR_SHARE,
    MIN_WINDOW_S,
};
use serde::Serialize;

use crate::error::{Result, TwinError};
use crate::measured::Recording;

/// Least steady samples after start-up (the least steady running is the one minimum window
/// of simulated and measured records, `fom::steady::MIN_WINDOW_S`,
/// docs/decisions/steady-window.md).
pub const MIN_STEADY_SAMPLES: usize = 100;

/// The measured steady slip of one label.
#[derive(Debug, Clone, Serialize)]
pub struct MeasuredSlip {
    pub samples: usize,
    pub steady_s: f64,
    pub mean_pct: f64,
    pub std_pct: f64,
    /// Standard error of the mean from batch means (10 batches per run), %.
    pub mean_se_pct: f64,
    /// p05, p25, p50, p75, p95, %.
    pub quantiles_pct: [f64; 5],
    /// The runs still settling at their end whose steady slip was extrapolated (none for a
    /// label that settled).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub settling: Vec<crate::settling::SettlingFit>,
    /// The runs still drifting a little at their end, taken as steady (none for a label that
    /// settled).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub drifting: Vec<SmallDrift>,
}

/// Steady slip samples of one run after discarding standstill and start-up, and the steady
/// window's length, s. Steady is the one definition of `fom::steady` (the same as for simulated
/// runs) on the slip of the running samples, with a window of at least `fom::steady::MIN_WINDOW_S`; a
/// recording still drifting at its end is refused with the drift it shows.
pub fn steady_slip(rec: &Recording, ratio: f64) -> Result<(Vec<f64>, f64)> {
    steady_part(rec, ratio).map(|p| (p.slip_pct, p.steady_s))
}

/// The steady part of a recording (see [`steady_slip`]).
#[derive(Debug, Clone)]
pub struct SteadyPart {
    /// Where the start-up ends, s (samples after it are steady).
    pub start_s: f64,
    /// Time of the first running sample (driver above the standstill share), s.
    pub running_from_s: f64,
    /// Slip of the steady samples, %.
    pub slip_pct: Vec<f64>,
    /// Length of the steady window, s.
    pub steady_s: f64,
}

/// The part of a recording after `startup_s` from its first running sample, or after its own
/// start-up where the one steady-state definition puts that later, taken as steady without the
/// drift test (a twin recording compared over a measured recording's steady window).
pub fn part_after(rec: &Recording, ratio: f64, startup_s: f64) -> Result<SteadyPart> {
    let samples = rec.slip_samples(ratio);
    let t0 = samples.first().map_or(0.0, |p| p.0);
    let (t, v): (Vec<f64>, Vec<f64>) = samples.iter().copied().unzip();
    let own = match fom::steady::settle(&t, &v, MIN_WINDOW_S, None) {
        fom::steady::Settling::Settled { window } => Some(window.start_s),
        fom::steady::Settling::Unsettled { last, .. } => last.map(|w| w.start_s),
    };
    let start_s = (t0 + startup_s).max(own.unwrap_or(f64::NEG_INFINITY));
    part_between(&samples, start_s, f64::INFINITY)
}

/// The minimum steady window (`fom::steady::MIN_WINDOW_S`) `startup_s` after a recording's
/// first running sample, taken as it is, without the drift test: the last window of a
/// recording that still drifts at its end, and a twin recording read over that same window
/// (docs/decisions/gap-unsettled-labels.md).
pub fn min_window_after(rec: &Recording, ratio: f64, startup_s: f64) -> Result<SteadyPart> {
    let samples = rec.slip_samples(ratio);
    let start_s = samples.first().map_or(0.0, |p| p.0) + startup_s;
    part_between(&samples, start_s, start_s + MIN_WINDOW_S)
}

/// Whether a recording's slip still drifts at its end by the one steady-state definition (it
/// is long enough to judge and its last window fails the drift test).
pub fn still_drifting(rec: &Recording, ratio: f64) -> bool {
    if turning(rec).is_err() {
        return false;
    }
    let (t, v): (Vec<f64>, Vec<f64>) = rec.slip_samples(ratio).into_iter().unzip();
    matches!(
        fom::steady::settle(&t, &v, MIN_WINDOW_S, None),
        fom::steady::Settling::Unsettled { last: Some(_), .. }
    )
}

/// The slip samples (time, %) in (`start_s`, `end_s`], at least `MIN_STEADY_SAMPLES` of them.
fn part_between(samples: &[(f64, f64)], start_s: f64, end_s: f64) -> Result<SteadyPart> {
    let slip: Vec<f64> = samples
        .iter()
        .filter(|p| p.0 > start_s && p.0 <= end_s)
        .map(|p| p.1)
        .collect();
    if slip.len() < MIN_STEADY_SAMPLES {
        return Err(TwinError::Unusable(format!(
            "only {} samples after {start_s:.2} s (need {MIN_STEADY_SAMPLES})",
            slip.len()
        )));
    }
    let last_s = samples.last().map_or(0.0, |p| p.0).min(end_s);
    Ok(SteadyPart {
        start_s,
        running_from_s: samples.first().map_or(0.0, |p| p.0),
        steady_s: last_s - start_s,
        slip_pct: slip,
    })
}

/// The steady part of a recording, by the rules of [`steady_slip`].
pub fn steady_part(rec: &Recording, ratio: f64) -> Result<SteadyPart> {
    steady_part_within(rec, ratio, 0.0).map(|p| p.0)
}

/// [`steady_part`], also taking a window whose slip still drifts (fails the drift test) by
/// no more than `small_drift_pp` between its halves, with every other check; with that window's
/// test, if it drifts.
fn steady_part_within(
    rec: &Recording,
    ratio: f64,
    small_drift_pp: f64,
) -> Result<(SteadyPart, Option<fom::steady::DriftTest>)> {
    turning(rec)?;
    let Running {
        time_s: t,
        slip_pct: all,
        driver_rpm,
    } = running(rec, ratio);
    let (start_s, drifting) = match fom::steady::settle(&t, &all, MIN_WINDOW_S, None) {
        fom::steady::Settling::Settled { window } => (window.start_s, None),
        fom::steady::Settling::Unsettled {
            last: Some(test), ..
        } if test.drift_pp.abs() <= small_drift_pp => (test.start_s, Some(test)),
        fom::steady::Settling::Unsettled { reason, .. } => {
            return Err(TwinError::Unusable(format!("not steady: {reason}")));
        }
    };
    // The motor at its running speed over the window: in a short recording the slip can pass
    // the drift test with the run-up inside its window, the motor still gaining speed.
    motor_at_speed(&t, &driver_rpm, start_s).map_err(|why| {
        TwinError::Unusable(format!("not steady: {why}; record until it runs at speed"))
    })?;
    // The slip settled at the start of a window MSER could not shorten (no more than a batch
    // beyond the minimum): a recording whose steady running is shorter than `MIN_WINDOW_S`
    // has the tail of the fan's spin-up in it, and that tail inflates the drift test's own
    // noise estimate enough to pass it. A longer window is MSER's own choice, as for
    // simulated runs.
    let in_window = t.len() - t.partition_point(|&x| x <= start_s);
    if in_window < fom::steady::min_window_len(&t, MIN_WINDOW_S) + fom::steady::BATCH {
        slip_settled_from(&t, &all, start_s).map_err(|why| {
            TwinError::Unusable(format!(
                "not steady: {why}; record until the slip has settled for {MIN_WINDOW_S} s"
            ))
        })?;
    }
    let slip: Vec<f64> = t
        .iter()
        .zip(&all)
        .filter(|p| *p.0 > start_s)
        .map(|p| *p.1)
        .collect();
    let steady_s = t.last().map_or(0.0, |e| e - start_s);
    if slip.len() < MIN_STEADY_SAMPLES || steady_s < MIN_WINDOW_S {
        return Err(TwinError::Unusable(format!(
            "too short: {steady_s:.3} s and {} samples of steady running after start-up \
             (need {MIN_WINDOW_S} s and {MIN_STEADY_SAMPLES} samples)",
            slip.len()
        )));
    }
    let first = slip[0];
    if slip.iter().all(|&s| s == first) {
        return Err(TwinError::Unusable(
            "the speed signals are constant (a stuck or disconnected sensor?)".into(),
        ));
    }
    let part = SteadyPart {
        start_s,
        running_from_s: t.first().copied().unwrap_or(0.0),
        slip_pct: slip,
        steady_s,
    };
    Ok((part, drifting))
}

/// Both pulleys turn: the driver runs somewhere (running samples by the one rule,
/// docs/decisions/running-sample.md; none: standstill) and the driven pulley at the end.
fn turning(rec: &Recording) -> Result<()> {
    let max = max_driver_rpm(&rec.driver_rpm);
    if !rec.driver_rpm.iter().any(|&n| is_running(n, max)) {
        return Err(TwinError::Unusable(format!(
            "the driver is at standstill (largest speed {max:.1} rpm)"
        )));
    }
    let n = rec.len();
    if median(rec.driven_rpm[n - (n / 4).max(1)..].to_vec()) <= 0.0 {
        return Err(TwinError::Unusable(
            "the driven pulley does not turn at the end of the record".into(),
        ));
    }
    Ok(())
}

/// Variance of the mean from batch means (autocorrelated samples, the one definition of
/// docs/decisions/batch-means.md), %^2.
fn batch_mean_variance(slip: &[f64]) -> f64 {
    batch_means_se(slip, fom::stats::mean).powi(2)
}

/// What [`measured_slip`] does with a recording still drifting at its end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Unsettled {
    /// Refuse it, with the drift it shows.
    Refuse,
    /// Use what it holds (docs/decisions/settling-extrapolation.md): a drift between its
    /// window's halves of no more than `small_drift_pp` stands, the drift added to its mean's
    /// standard error; a settle that heads for gross slip, from `gross_slip_from_pct` up, is
    /// extrapolated (`crate::settling`); anything else is refused.
    Use {
        small_drift_pp: f64,
        gross_slip_from_pct: f64,
    },
}

/// How far a window's mean lies from the end of an exponential settle whose time constant is
/// the window's length, per unit of the difference between its halves' means:
/// (1 - e^-1) / (2 (1 - e^-1/2)^2) (derived in docs/decisions/settling-extrapolation.md,
/// "A small drift"); settles of shorter time constants lie closer.
const SETTLE_OFFSET_PER_DRIFT: f64 = 2.04;

/// A recording taken as steady although its slip still drifts a little at its end.
#[derive(Debug, Clone, Serialize)]
pub struct SmallDrift {
    /// The run file.
    pub file: String,
    /// The steady window, s.
    pub from_s: f64,
    pub to_s: f64,
    /// The slip's change between the window's halves, and the most taken so, percentage
    /// points.
    pub drift_pp: f64,
    pub small_drift_pp: f64,
    /// How far the steady slip may still lie from the window's mean, percentage points: added
    /// to the mean's standard error.
    pub offset_pp: f64,
}

/// Measured slip of a label from its runs, each with its file's name (for messages). A run
/// still drifting at its end is refused or, with [`Unsettled::Use`], stands with its window
/// and the drift added to its mean's standard error where the drift is small, or with its
/// extrapolated steady slip (`crate::settling`): the samples of its last window moved to that
/// slip, and the extrapolation's standard error as its mean's.
pub fn measured_slip(
    recs: &[(&str, &Recording)],
    ratio: f64,
    unsettled: Unsettled,
) -> Result<MeasuredSlip> {
    let mut all = Vec::new();
    let mut steady_s = 0.0;
    let mut var_sum = 0.0;
    let mut weights = 0.0;
    let mut settling = Vec::new();
    let mut drifting = Vec::new();
    let small_drift_pp = match unsettled {
        Unsettled::Use { small_drift_pp, .. } => small_drift_pp,
        Unsettled::Refuse => 0.0,
    };
    for (file, r) in recs {
        let (s, t, v) = match steady_part_within(r, ratio, small_drift_pp) {
            Ok((p, drift)) => {
                // The steady slip taken to lie within `SETTLE_OFFSET_PER_DRIFT` drifts of the
                // window's mean.
                let d = drift.map_or(0.0, |w| SETTLE_OFFSET_PER_DRIFT * w.drift_pp);
                let v = batch_mean_variance(&p.slip_pct) + d * d;
                if let Some(w) = drift {
                    drifting.push(SmallDrift {
                        file: file.to_string(),
                        from_s: w.start_s,
                        to_s: w.end_s,
                        drift_pp: w.drift_pp,
                        small_drift_pp,
                        offset_pp: d.abs(),
                    });
                }
                (p.slip_pct, p.steady_s, v)
            }
            Err(e) => match unsettled {
                Unsettled::Use {
                    gross_slip_from_pct,
                    ..
                } if still_drifting(r, ratio) => {
                    let x = extrapolated(file, r, ratio, gross_slip_from_pct).map_err(|why| {
                        TwinError::Unusable(format!(
                            "{file}: {e}; {why}; record until the slip has settled for \
                             {MIN_WINDOW_S} s"
                        ))
                    })?;
                    let v = x.steady_se_pct.powi(2);
                    settling.push(x.fit);
                    (x.slip_pct, 0.0, v)
                }
                _ => return Err(TwinError::Unusable(format!("{file}: {e}"))),
            },
        };
        let w = s.len() as f64;
        var_sum += w * w * v;
        weights += w;
        steady_s += t;
        all.extend(s);
    }
    let (mean, std) = (fom::stats::mean(&all), fom::stats::sample_std(&all));
    all.sort_by(f64::total_cmp);
    let q = |p| quantile(&all, p);
    Ok(MeasuredSlip {
        samples: all.len(),
        steady_s,
        mean_pct: mean,
        std_pct: std,
        mean_se_pct: (var_sum / (weights * weights)).sqrt(),
        quantiles_pct: [q(0.05), q(0.25), q(0.5), q(0.75), q(0.95)],
        settling,
        drifting,
    })
}

/// The settle of a recording still drifting at its end, extrapolated (`crate::settling`)
/// over its running samples.
fn extrapolated(
    file: &str,
    rec: &Recording,
    ratio: f64,
    gross_slip_from_pct: f64,
) -> std::result::Result<crate::settling::Extrapolated, String> {
    let r = running(rec, ratio);
    crate::settling::extrapolate(
        file,
        &r.time_s,
        &r.slip_pct,
        &r.driver_rpm,
        gross_slip_from_pct,
    )
}

/// A recording's running samples (the one rule, docs/decisions/running-sample.md): their
/// times, slip (paper eq. 1, %) and driver speeds.
struct Running {
    time_s: Vec<f64>,
    slip_pct: Vec<f64>,
    driver_rpm: Vec<f64>,
}

fn running(rec: &Recording, ratio: f64) -> Running {
    let max = max_driver_rpm(&rec.driver_rpm);
    let idx: Vec<usize> = (0..rec.len())
        .filter(|&i| is_running(rec.driver_rpm[i], max))
        .collect();
    Running {
        time_s: idx.iter().map(|&i| rec.time_s[i]).collect(),
        slip_pct: idx
            .iter()
            .map(|&i| slip_pct(ratio, rec.driver_rpm[i], rec.driven_rpm[i]))
            .collect(),
        driver_rpm: idx.iter().map(|&i| rec.driver_rpm[i]).collect(),
    }
}

/// Whether the motor runs at its speed over the samples after `from_s` (times `t`, driver
/// speeds `driver_rpm`): the driver's speed passes the one drift test there. The error says
/// by how much it still changed.
pub(crate) fn motor_at_speed(
    t: &[f64],
    driver_rpm: &[f64],
    from_s: f64,
) -> std::result::Result<(), String> {
    match fom::steady::settle(t, driver_rpm, MIN_WINDOW_S, Some(from_s)) {
        fom::steady::Settling::Unsettled {
            last: Some(test), ..
        } => Err(format!(
            "the motor is still running up: its speed changed {:+.1} rpm between the halves of \
             {:.2}-{:.2} s",
            test.drift_pp, test.start_s, test.end_s
        )),
        _ => Ok(()),
    }
}

/// Student's t quantile for 4 degrees of freedom at 0.9995 (two-sided 0.1 %; Abramowitz &
/// Stegun, Handbook of Mathematical Functions, 1964, table 26.10).
const T4_0_9995: f64 = 8.610;

/// Whether the slip after `from_s` (times `t`, slip `slip_pct`) has settled at the window's
/// start: split into the drift test's `DRIFT_BATCHES` batches from the start, the first
/// batch's mean lies within `T4_0_9995` standard errors of the later half's mean, the error
/// from the later half's own batch means (5 batches, 4 degrees of freedom: the difference
/// of a batch mean and a mean of five has variance s^2 (1 + 1/5)), or so close that it moves
/// the early half's mean by no more than the drift test's floor. The error says how far the
/// window's start stands apart.
pub(crate) fn slip_settled_from(
    t: &[f64],
    slip_pct: &[f64],
    from_s: f64,
) -> std::result::Result<(), String> {
    let (tw, v): (Vec<f64>, Vec<f64>) = t
        .iter()
        .zip(slip_pct)
        .filter(|p| *p.0 > from_s && p.1.is_finite())
        .map(|(a, b)| (*a, *b))
        .unzip();
    let len = v.len() / DRIFT_BATCHES;
    if len == 0 {
        return Ok(());
    }
    let means: Vec<f64> = v.chunks_exact(len).map(fom::stats::mean).collect();
    let late = &means[DRIFT_BATCHES / 2..DRIFT_BATCHES];
    let (first, late_mean) = (means[0], fom::stats::mean(late));
    let se = fom::stats::sample_std(late) * (1.0 + 1.0 / late.len() as f64).sqrt();
    // The drift test's floor on the half-means' difference: one batch of the early half's
    // five standing `gap` apart moves that half's mean by gap / 5.
    let floor =
        (DRIFT_BATCHES / 2) as f64 * DRIFT_FLOOR_PP.max(DRIFT_FLOOR_SHARE * late_mean.abs());
    let gap = first - late_mean;
    if gap.abs() <= (T4_0_9995 * se).max(floor) {
        return Ok(());
    }
    let apart = if se > 0.0 {
        format!("{:.0} standard errors apart", gap.abs() / se)
    } else {
        "the later half without scatter".to_string()
    };
    Err(format!(
        "the slip is still settling at the window's start: {first:.3} % over {from_s:.2}-{:.2} \
         s against {late_mean:.3} % over its later half ({apart})",
        tw[len - 1]
    ))
}

/// A spectral line in a signal: amplitude and phase (rad) of y = c + A cos(2 pi f t + p) in
/// samples `y` at times `t`, fitted by least squares (normal equations of [1, cos, sin]). Each
/// sample is taken as the mean over the `dt` before its time (a tachometer's or an output row's
/// interval mean: a boxcar of gain sinc(pi f dt)), whose attenuation is taken out.
pub fn line(t: &[f64], y: &[f64], f_hz: f64, dt: f64) -> (f64, f64) {
    line_on_trend(t, y, f_hz, dt, 0)
}

/// The phase (deg, in (-180, 180]) by which `y` lags `x` at `f_hz`: the difference of their
/// lines' phases ([`line_on_trend`] with a quadratic trend, both sampled at times `t` as means
/// over `dt`), the phase of their cross spectrum at that frequency (Bendat & Piersol, Random
/// Data, 2010, sec. 5.2). Positive when `y` peaks after `x`.
pub fn lag_deg(t: &[f64], x: &[f64], y: &[f64], f_hz: f64, dt: f64) -> f64 {
    let px = line_on_trend(t, x, f_hz, dt, 2).1;
    let py = line_on_trend(t, y, f_hz, dt, 2).1;
    let d = (px - py).to_degrees();
    180.0 - (180.0 - d).rem_euclid(360.0)
}

/// [`line`] fitted together with a polynomial trend of `degree` in time instead of a constant
/// (speeds that still creep after the slip has settled). A singular fit (fewer samples than
/// unknowns) gives amplitude 0.
pub fn line_on_trend(t: &[f64], y: &[f64], f_hz: f64, dt: f64, degree: usize) -> (f64, f64) {
    /// Most unknowns: the line's two and a cubic trend's four.
    const MAX_K: usize = 6;
    let w = 2.0 * std::f64::consts::PI * f_hz;
    let k = degree + 3;
    assert!(
        k <= MAX_K,
        "a trend of degree {degree} is beyond the line fit's cubic"
    );
    let (t0, span) = (t[0], (t[t.len() - 1] - t[0]).max(dt));
    // The normal equations' upper triangle in fixed arrays (the lower one is its mirror: the
    // same products, so the same sums bit for bit).
    let mut upper = [[0.0; MAX_K]; MAX_K];
    let mut rhs = [0.0; MAX_K];
    let mut phi = [0.0; MAX_K];
    for (&ti, &yi) in t.iter().zip(y) {
        // Each row is the mean over (t - dt, t]: its phase centre is t - dt / 2.
        let tc = ti - 0.5 * dt;
        let u = (ti - t0) / span;
        let (sin, cos) = (w * tc).sin_cos();
        phi[0] = cos;
        phi[1] = sin;
        phi[2] = 1.0;
        for j in 3..k {
            phi[j] = phi[j - 1] * u;
        }
        for i in 0..k {
            rhs[i] += phi[i] * yi;
            for j in i..k {
                upper[i][j] += phi[i] * phi[j];
            }
        }
    }
    let a = faer::Mat::<f64>::from_fn(k, k, |i, j| upper[i.min(j)][i.max(j)]);
    let b = faer::Mat::<f64>::from_fn(k, 1, |i, _| rhs[i]);
    // The normal equations are symmetric positive definite unless the fit is singular.
    let Ok(llt) = a.llt(faer::Side::Lower) else {
        return (0.0, 0.0);
    };
    let x = faer::linalg::solvers::Solve::solve(&llt, &b);
    let gain = {
        let z = std::f64::consts::PI * f_hz * dt;
        z.sin() / z
    };
    (
        x[(0, 0)].hypot(x[(1, 0)]) / gain,
        (-x[(1, 0)]).atan2(x[(0, 0)]),
    )
}

/// Synthetic recordings for unit tests.
#[cfg(test)]
pub(crate) mod synthetic {
    use super::Recording;
    use rand::Rng;
    use rand_distr::StandardNormal;
    use rand_xoshiro::rand_core::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// `duration_s` at 1 kHz: the motor runs up over 0.5 s to 1750 rpm, white noise of 1 rpm
    /// on it; the slip `slip_pct(t)` with white noise of 0.05 pp; the fan pulley twice the
    /// driver's pitch diameter.
    pub(crate) fn slip_recording(
        duration_s: f64,
        slip_pct: impl Fn(f64) -> f64,
        seed: u64,
    ) -> Recording {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut rec = Recording::default();
        for k in 0..(duration_s * 1000.0) as usize {
            let t = k as f64 * 1e-3;
            let n1 = 1750.0 * (t / 0.5).min(1.0) + rng.sample::<f64, _>(StandardNormal);
            let slip = slip_pct(t) + 0.05 * rng.sample::<f64, _>(StandardNormal);
            rec.time_s.push(t);
            rec.driver_rpm.push(n1.max(0.0));
            // slip = 100 (1 - R n2 / n1) with R = 2.
            rec.driven_rpm
                .push((n1 * (1.0 - slip / 100.0) / 2.0).max(0.0));
        }
        rec
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_is_recovered_from_interval_means() {
        // 1 kHz interval means of 3 + 2 cos(2 pi 37 t + 0.4) over 1 s.
        let (f, dt) = (37.0, 1e-3);
        let w = 2.0 * std::f64::consts::PI * f;
        let t: Vec<f64> = (1..=1000).map(|k| k as f64 * dt).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&ti| 3.0 + 2.0 * ((w * ti + 0.4).sin() - (w * (ti - dt) + 0.4).sin()) / (w * dt))
            .collect();
        let (a, p) = line(&t, &y, f, dt);
        assert!((a - 2.0).abs() < 1e-6, "amplitude {a}");
        assert!((p - 0.4).abs() < 1e-6, "phase {p}");
    }

    #[test]
    fn a_lag_is_read_with_its_sign_at_its_frequency() {
        // y lags x by 30 deg at 116 Hz; a 40 Hz line of another phase rides on both.
        let (f, dt) = (116.0, 1e-3);
        let w = 2.0 * std::f64::consts::PI * f;
        let t: Vec<f64> = (1..=2000).map(|k| k as f64 * dt).collect();
        let other = |ti: f64, p: f64| 0.5 * (2.0 * std::f64::consts::PI * 40.0 * ti + p).cos();
        let x: Vec<f64> = t
            .iter()
            .map(|&ti| (w * ti).cos() + other(ti, 0.0))
            .collect();
        let lag = 30f64.to_radians();
        let y: Vec<f64> = t
            .iter()
            .map(|&ti| 2.0 + 0.1 * (w * ti - lag).cos() + other(ti, 2.0))
            .collect();
        // Within 0.05 deg: the other line leaks a little through the fitted trend.
        let l = lag_deg(&t, &x, &y, f, dt);
        assert!((l - 30.0).abs() < 0.05, "{l}");
        let l = lag_deg(&t, &y, &x, f, dt);
        assert!((l + 30.0).abs() < 0.05, "{l}");
        // At the other line's frequency the lag is that line's: -2 rad.
        let at_40 = lag_deg(&t, &x, &y, 40.0, dt);
        assert!((at_40 + 2f64.to_degrees()).abs() < 0.05, "{at_40}");
        // Wrapped into (-180, 180]: a 200 deg lag reads as -160 deg.
        let z: Vec<f64> = t
            .iter()
            .map(|&ti| (w * ti - 200f64.to_radians()).cos())
            .collect();
        let l = lag_deg(&t, &x, &z, f, dt);
        assert!((l + 160.0).abs() < 0.05, "{l}");
    }

    /// 1 s of slip at 500 Hz after `from_s` = 0: 0.7 % with white noise of 0.12 pp (the shipped
    /// healthy sample's scatter) plus `tail(t)`.
    fn slip_window(seed: u64, tail: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        use rand::Rng;
        use rand_xoshiro::rand_core::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let t: Vec<f64> = (1..=500).map(|k| k as f64 * 2e-3).collect();
        let v = t
            .iter()
            .map(|&ti| {
                let n: f64 = rng.sample(rand_distr::StandardNormal);
                0.7 + 0.12 * n + tail(ti)
            })
            .collect();
        (t, v)
    }

    #[test]
    fn a_window_beginning_in_a_settle_s_tail_is_told_from_a_settled_one() {
        // The fan's spin-up tail: 8 pp decaying with a 0.05 s time constant from the window's
        // start, as in the shipped healthy sample's loosest run cut at 2.25 s.
        let (t, v) = slip_window(1, |t| 8.0 * (-t / 0.05).exp());
        let why = slip_settled_from(&t, &v, 0.0).unwrap_err();
        assert!(
            why.contains("still settling at the window's start"),
            "{why}"
        );
        assert!(why.contains("over 0.00-0.10 s"), "{why}");
        // The same tail 0.3 s earlier has decayed to 0.02 pp: settled.
        let (t, v) = slip_window(1, |t| 8.0 * (-(t + 0.3) / 0.05).exp());
        assert!(slip_settled_from(&t, &v, 0.0).is_ok());
        // Without noise a tail moving the early half's mean less than the drift test's floor
        // (5 x 0.01 pp on the first batch) is no transient; one above it is.
        let flat = |tail: f64| {
            let v: Vec<f64> = t
                .iter()
                .map(|&ti| 0.7 + if ti <= 0.1 { tail } else { 0.0 })
                .collect();
            slip_settled_from(&t, &v, 0.0)
        };
        assert!(flat(0.04).is_ok());
        assert!(flat(0.06).is_err());
    }

    #[test]
    fn a_settled_window_is_refused_about_once_in_a_thousand() {
        // The first batch's mean and the later half's are Gaussian; the test's quantile is
        // Student's t at 0.9995 with 4 degrees of freedom: one refusal in 1000 expected.
        let refused = (0..1000)
            .filter(|&seed| {
                let (t, v) = slip_window(seed, |_| 0.0);
                slip_settled_from(&t, &v, 0.0).is_err()
            })
            .count();
        assert!(refused <= 3, "{refused} of 1000 refused");
    }

    #[test]
    fn a_small_drift_stands_with_its_mean_s_error_widened_and_a_larger_one_is_refused() {
        let used = Unsettled::Use {
            small_drift_pp: 0.035,
            gross_slip_from_pct: 2.0,
        };
        // The slip settles as 0.7 % + a exp(-t / 2 s); with a = 0.25 pp, 0.02 pp is left to
        // settle at 5 s, and the last seconds drift by about that.
        let slow_settle =
            |a_pp: f64| synthetic::slip_recording(5.0, |t| 0.7 + a_pp * (-t / 2.0).exp(), 3);
        let rec = slow_settle(0.25);
        let refused = measured_slip(&[("slow.csv", &rec)], 2.0, Unsettled::Refuse).unwrap_err();
        assert!(refused.to_string().contains("still drifting"), "{refused}");
        let m = measured_slip(&[("slow.csv", &rec)], 2.0, used).unwrap();
        let d = &m.drifting[0];
        assert!(d.drift_pp.abs() <= 0.035 && d.drift_pp < 0.0, "{d:?}");
        // The window is longer than the settle's 2 s time constant, so the steady 0.7 % lies
        // within the widened error of its mean.
        assert!(d.to_s - d.from_s > 2.0, "{d:?}");
        assert!(
            m.mean_se_pct >= SETTLE_OFFSET_PER_DRIFT * d.drift_pp.abs(),
            "{m:?}"
        );
        assert!((m.mean_pct - 0.7).abs() <= m.mean_se_pct, "{m:?}");
        // Eight times the settle drifts by more than the finest class step: refused.
        let rec = slow_settle(2.0);
        let why = measured_slip(&[("slow.csv", &rec)], 2.0, used).unwrap_err();
        assert!(why.to_string().contains("still drifting"), "{why}");
    }
}
