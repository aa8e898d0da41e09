//! Signal processing of measured speeds: the steady part of a recording, its slip samples and
//! the standard error of their mean. One definition, used by calibration and diagnosis.

use fom::slip::slip_pct;
use fom::stats::{median, quantile};
use fom::steady::{batch_means_se, is_running, max_driver_rpm, MIN_WINDOW_S};
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
    turning(rec)?;
    let Running {
        time_s: t,
        slip_pct: all,
        driver_rpm,
    } = running(rec, ratio);
    let start_s = match fom::steady::settle(&t, &all, MIN_WINDOW_S, None) {
        fom::steady::Settling::Settled { window } => window.start_s,
        fom::steady::Settling::Unsettled { reason, .. } => {
            return Err(TwinError::Unusable(format!("not steady: {reason}")));
        }
    };
    // The motor at its running speed over the window: in a short recording the slip can pass
    // the drift test with the run-up inside its window, the motor still gaining speed.
    motor_at_speed(&t, &driver_rpm, start_s).map_err(|why| {
        TwinError::Unusable(format!("not steady: {why}; record until it runs at speed"))
    })?;
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
    Ok(SteadyPart {
        start_s,
        running_from_s: t.first().copied().unwrap_or(0.0),
        slip_pct: slip,
        steady_s,
    })
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
    /// Extrapolate its settle where it holds one that heads for gross slip, from
    /// `gross_slip_from_pct` up (`crate::settling`), else refuse it.
    Extrapolate { gross_slip_from_pct: f64 },
}

/// Measured slip of a label from its runs, each with its file's name (for messages). A run
/// still drifting at its end is refused or, with [`Unsettled::Extrapolate`], stands with its
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
    for (file, r) in recs {
        let (s, t, v) = match steady_slip(r, ratio) {
            Ok((s, t)) => {
                let v = batch_mean_variance(&s);
                (s, t, v)
            }
            Err(e) => match unsettled {
                Unsettled::Extrapolate {
                    gross_slip_from_pct,
                } if still_drifting(r, ratio) => {
                    let x = extrapolated(file, r, ratio, gross_slip_from_pct).map_err(|why| {
                        TwinError::Unusable(format!(
                            "{file}: {e}; {why}; record until the slip settles"
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
}
