//! The steady slip of a recording still settling at its end: an exponential settle fitted to
//! its last seconds, checked against its own last half second, and extrapolated
//! (docs/decisions/settling-extrapolation.md).
//!
//! A belt that slides after start-up pulls its fan up slowly: on the full-order model with a
//! Stribeck friction drop at the loosest matrix setting the slip falls from 15.4 % to 10.1 %
//! between 3 and 5 s, and a 5 s recording fails the steady test. What it holds is the settle
//! itself. `slip(t) = s_inf + a exp(-(t - t_end) / tau)` (the first-order response of a
//! fan inertia pulled by a sliding belt; Ogata, Modern Control Engineering, 5th ed., 2010,
//! sec. 5.2) is fitted to block means of the recording's later half (at least
//! `FIT_WINDOW_S`); the fit is trusted only where the driver has reached its running speed,
//! the settling's time constant lies within the window, the same fit made without the
//! window's last `CHECK_SHARE` predicts that last part within its noise, and the settle heads
//! for gross slip (a belt regaining its grip sticks short of where its slide heads).

use fom::stats::{mean, Z90};
use fom::steady::{batch_means_se, DRIFT_FLOOR_PP, DRIFT_FLOOR_SHARE, DRIFT_SE, MIN_WINDOW_S};
use serde::Serialize;

/// Shortest end of a recording the settle is fitted to, s: two minimum steady windows. A
/// longer recording is fitted over its later half, where a slow settle shows.
pub const FIT_WINDOW_S: f64 = 2.0 * MIN_WINDOW_S;
/// Length of the block means the settle is fitted to, s (many periods of the pulleys'
/// once-per-revolution lines at running speed).
pub const BLOCK_S: f64 = 0.1;
/// Share of the fitted window at its end that the fit without it must predict (0.5 s of
/// the shortest window).
pub const CHECK_SHARE: f64 = 0.25;
/// Time constants tried, log-spaced from `BLOCK_S` to `TAU_MAX_WINDOWS` windows.
const TAU_POINTS: usize = 200;
/// The longest time constant tried, in windows: far beyond the window, where the settle is
/// a line.
const TAU_MAX_WINDOWS: f64 = 50.0;
/// The profile likelihood's 90 % threshold for one parameter: chi-square quantile 2.71
/// (Press et al., Numerical Recipes, 3rd ed., 2007, sec. 15.6.5).
const DELTA_CHI2_90: f64 = 2.705_543_454;

/// What the extrapolation of one recording found.
#[derive(Debug, Clone, Serialize)]
pub struct SettlingFit {
    /// The run file.
    pub file: String,
    /// The window fitted, s.
    pub fit_from_s: f64,
    pub fit_to_s: f64,
    /// The mean slip over the recording's last `MIN_WINDOW_S`, %.
    pub last_window_pct: f64,
    /// The settle's fitted time constant, s.
    pub time_constant_s: f64,
    /// The extrapolated steady slip and its 90 % interval, %.
    pub steady_pct: f64,
    pub steady_90_pct: [f64; 2],
}

/// An extrapolated recording: the fit, and the slip samples that stand for its steady state.
#[derive(Debug, Clone)]
pub struct Extrapolated {
    pub fit: SettlingFit,
    /// The last `MIN_WINDOW_S`'s samples about the fitted settle, moved to the steady slip:
    /// the spread at the end taken to persist.
    pub slip_pct: Vec<f64>,
    /// Standard error of the extrapolated steady slip, percentage points.
    pub steady_se_pct: f64,
}

/// One time constant's least-squares fit.
#[derive(Debug, Clone, Copy)]
struct Point {
    tau_s: f64,
    s_inf: f64,
    a: f64,
    rss: f64,
    /// Var(s_inf) per unit residual variance: the (0, 0) element of (X^T X)^-1.
    var_unit: f64,
}

impl Point {
    /// The least-squares s_inf and a at time constant `tau_s` over block means, each block's
    /// exponential its samples' mean (exact for block means; `None` where the two columns
    /// cannot be told apart).
    fn fit(b: &[Block], t_end: f64, tau_s: f64) -> Option<Self> {
        let n = b.len() as f64;
        let x: Vec<f64> = b
            .iter()
            .map(|k| {
                mean(
                    &k.times_s
                        .iter()
                        .map(|&ti| (-(ti - t_end) / tau_s).exp())
                        .collect::<Vec<_>>(),
                )
            })
            .collect();
        let y: Vec<f64> = b.iter().map(|k| k.mean).collect();
        let (sx, sxx) = (x.iter().sum::<f64>(), x.iter().map(|v| v * v).sum::<f64>());
        let sy = y.iter().sum::<f64>();
        let sxy = x.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>();
        let det = n * sxx - sx * sx;
        if det.abs() <= 1e-12 * n * sxx {
            return None;
        }
        let s_inf = (sxx * sy - sx * sxy) / det;
        let a = (n * sxy - sx * sy) / det;
        let rss = x
            .iter()
            .zip(&y)
            .map(|(xi, yi)| (yi - s_inf - a * xi).powi(2))
            .sum();
        Some(Self {
            tau_s,
            s_inf,
            a,
            rss,
            var_unit: sxx / det,
        })
    }

    fn at(&self, t: f64, t_end: f64) -> f64 {
        self.s_inf + self.a * (-(t - t_end) / self.tau_s).exp()
    }
}

/// The fit at every time constant, the best, and the residual variance at the best.
struct Profile {
    points: Vec<Point>,
    best: Point,
    sigma2: f64,
}

impl Profile {
    /// Least squares of `y = s_inf + a exp(-(t - t_end) / tau)` over the grid of tau (the
    /// model is linear in s_inf and a at fixed tau: the normal equations of two unknowns),
    /// the grid refined twice, `TAU_POINTS` points between the best point's neighbours.
    fn fit(b: &[Block], t_end: f64, window_s: f64) -> Option<Self> {
        let mut log_step = (TAU_MAX_WINDOWS * window_s / BLOCK_S).ln() / (TAU_POINTS - 1) as f64;
        let coarse = (0..TAU_POINTS).map(|k| BLOCK_S * (k as f64 * log_step).exp());
        let mut points: Vec<Point> = coarse.filter_map(|tau| Point::fit(b, t_end, tau)).collect();
        for _ in 0..2 {
            let first = *points.iter().min_by(|p, q| p.rss.total_cmp(&q.rss))?;
            let fine = (0..TAU_POINTS).map(|k| {
                let u = 2.0 * k as f64 / (TAU_POINTS - 1) as f64 - 1.0;
                first.tau_s * (u * log_step).exp()
            });
            points.extend(fine.filter_map(|tau| Point::fit(b, t_end, tau)));
            log_step *= 2.0 / (TAU_POINTS - 1) as f64;
        }
        let best = *points.iter().min_by(|p, q| p.rss.total_cmp(&q.rss))?;
        let sigma2 = best.rss / (b.len() as f64 - 3.0).max(1.0);
        Some(Self {
            points,
            best,
            sigma2,
        })
    }

    /// The time constants the profile likelihood keeps at 90 % (Press et al., Numerical
    /// Recipes, 3rd ed., 2007, sec. 15.6.5).
    fn accepted(&self) -> impl Iterator<Item = &Point> {
        let limit = self.best.rss + DELTA_CHI2_90 * self.sigma2;
        self.points.iter().filter(move |p| p.rss <= limit)
    }
}

/// The smallest and the largest of `values` ([inf, -inf] for none).
fn span(values: impl Iterator<Item = f64>) -> [f64; 2] {
    values.fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| {
        [lo.min(v), hi.max(v)]
    })
}

/// One block of samples: their times and their mean value.
struct Block {
    times_s: Vec<f64>,
    mean: f64,
}

/// The samples in (`from_s`, `to_s`] in blocks `BLOCK_S` long.
fn blocks(t: &[f64], v: &[f64], from_s: f64, to_s: f64) -> Vec<Block> {
    let n = ((to_s - from_s) / BLOCK_S).round().max(1.0) as usize;
    let mut out: Vec<(Vec<f64>, f64)> = vec![(Vec::new(), 0.0); n];
    for (&ti, &vi) in t.iter().zip(v).filter(|p| *p.0 > from_s && *p.0 <= to_s) {
        let k = (((ti - from_s) / BLOCK_S).ceil() as usize).clamp(1, n) - 1;
        out[k].0.push(ti);
        out[k].1 += vi;
    }
    out.into_iter()
        .filter(|b| !b.0.is_empty())
        .map(|(times_s, sum)| Block {
            mean: sum / times_s.len() as f64,
            times_s,
        })
        .collect()
}

/// The steady slip ahead of a recording still settling at its end: `t`, `slip` (%) and
/// `driver_rpm` of its running samples. Only a settle that heads for gross slip, its 90 %
/// interval at `gross_slip_from_pct` or above, is extrapolated: a belt still sliding follows
/// the fan's spin-up there, while one that regains its grip sticks at a level the fit does not
/// see. An error says why the recording holds no settle to extrapolate.
pub fn extrapolate(
    file: &str,
    t: &[f64],
    slip: &[f64],
    driver_rpm: &[f64],
    gross_slip_from_pct: f64,
) -> Result<Extrapolated, String> {
    let (Some(&t0), Some(&t_end)) = (t.first(), t.last()) else {
        return Err("no running samples".into());
    };
    if t_end - t0 < FIT_WINDOW_S {
        return Err(format!(
            "too short to extrapolate: {:.2} s of running, need {FIT_WINDOW_S} s",
            t_end - t0
        ));
    }
    let window_s = FIT_WINDOW_S.max(0.5 * (t_end - t0));
    let from_s = t_end - window_s;
    // The motor at its running speed: a driver still running up pulls the slip with it.
    crate::signal::motor_at_speed(t, driver_rpm, from_s)?;
    let b = blocks(t, slip, from_s, t_end);
    let check_s = CHECK_SHARE * window_s;
    let check_from_s = t_end - check_s;
    let split = b.partition_point(|k| k.times_s.last().is_some_and(|&ti| ti <= check_from_s));
    let no_fit = || format!("no settle fits the slip over {from_s:.2}-{t_end:.2} s");
    // The check: the fit without the window's end predicts that end's mean.
    let early = Profile::fit(&b[..split], t_end, window_s).ok_or_else(no_fit)?;
    let (last_t, last_v): (Vec<f64>, Vec<f64>) = t
        .iter()
        .zip(slip)
        .filter(|p| *p.0 > check_from_s)
        .map(|(a, b)| (*a, *b))
        .unzip();
    let predicted = |p: &Point| mean(&last_t.iter().map(|&ti| p.at(ti, t_end)).collect::<Vec<_>>());
    let spread = span(early.accepted().map(predicted));
    let (measured, predicted_best) = (mean(&last_v), predicted(&early.best));
    let se = batch_means_se(&last_v, mean).hypot(0.5 * (spread[1] - spread[0]) / Z90);
    let tolerance = (DRIFT_SE * se).max(DRIFT_FLOOR_PP.max(DRIFT_FLOOR_SHARE * measured.abs()));
    let off = (measured - predicted_best).abs();
    // A NaN (no sample to compare) fails the check too.
    if off.is_nan() || off > tolerance {
        return Err(format!(
            "no settle to extrapolate, the drift is not one: the fit to {from_s:.2}-{check_from_s:.2} s \
             predicts {predicted_best:.3} % over the last {check_s:.2} s, measured {measured:.3} % \
             (noise explains {tolerance:.3} pp)"
        ));
    }
    let all = Profile::fit(&b, t_end, window_s).ok_or_else(no_fit)?;
    let longest = all.accepted().map(|p| p.tau_s).fold(0.0, f64::max);
    if longest > window_s {
        return Err(format!(
            "no settle to extrapolate, no settling in sight: time constants up to {longest:.1} s fit \
             the slip over the last {window_s:.2} s (a settle must show within it)"
        ));
    }
    // The asymptote's profile interval, and how far it moved with the window's end: one
    // exponential is a model of the settle, and that move is its error seen in the data.
    let [lo, hi] = span(all.accepted().flat_map(|p| {
        let h = Z90 * (all.sigma2 * p.var_unit).sqrt();
        [p.s_inf - h, p.s_inf + h]
    }));
    let best = all.best;
    let steady_se_pct = (0.5 * (hi - lo) / Z90).hypot(best.s_inf - early.best.s_inf);
    let lowest_pct = best.s_inf - Z90 * steady_se_pct;
    if lowest_pct < gross_slip_from_pct {
        let (heads, why) = if best.s_inf < 0.0 {
            (
                "falls as if towards no slip at all".to_string(),
                "the belt is regaining its grip and will stick at a slip this fit cannot see",
            )
        } else {
            (
                format!(
                    "heads for {:.3} % (90 % interval down to {lowest_pct:.3} %)",
                    best.s_inf
                ),
                "a belt regaining its grip sticks at a slip this fit cannot see",
            )
        };
        return Err(format!(
            "no settle to extrapolate: the slip fitted over the last {window_s:.2} s {heads}, \
             not for gross slip (from {gross_slip_from_pct:.3} %, where the critical class \
             starts): {why}"
        ));
    }
    let last_from_s = t_end - MIN_WINDOW_S;
    let last: Vec<(f64, f64)> = t
        .iter()
        .zip(slip)
        .filter(|p| *p.0 > last_from_s)
        .map(|(&ti, &v)| (ti, v))
        .collect();
    let slip_pct: Vec<f64> = last
        .iter()
        .map(|&(ti, v)| v - best.at(ti, t_end) + best.s_inf)
        .collect();
    let last_window_pct = mean(&last.iter().map(|p| p.1).collect::<Vec<_>>());
    Ok(Extrapolated {
        fit: SettlingFit {
            file: file.to_string(),
            fit_from_s: from_s,
            fit_to_s: t_end,
            last_window_pct,
            time_constant_s: best.tau_s,
            steady_pct: best.s_inf,
            steady_90_pct: [lowest_pct, best.s_inf + Z90 * steady_se_pct],
        },
        slip_pct,
        steady_se_pct,
    })
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    use super::*;

    /// Where gross slip starts on the shipped drive: three times its healthy 0.69 %.
    const GROSS: f64 = 2.07;

    /// 1 kHz samples over (0, `duration_s`] of `slip(t)` with noise uniform within 0.2 pp
    /// (realisation `seed` of a seeded generator), and a driver at `driver(t)`.
    fn recording(
        duration_s: f64,
        seed: u64,
        slip: impl Fn(f64) -> f64,
        driver: impl Fn(f64) -> f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (1..=(duration_s * 1000.0) as usize)
            .map(|i| i as f64 * 1e-3)
            .collect();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let s = t
            .iter()
            .map(|&ti| slip(ti) + 0.2 * rng.gen_range(-1.0..1.0))
            .collect();
        let d = t.iter().map(|&ti| driver(ti)).collect();
        (t, s, d)
    }

    #[test]
    fn a_first_order_settle_is_extrapolated_to_its_asymptote() {
        // 9 % + 400 % exp(-t / 0.9 s): 10.55 % at 5 s, still falling 1.7 pp/s.
        let (t, s, d) = recording(5.0, 0, |t| 9.0 + 400.0 * (-t / 0.9).exp(), |_| 1760.0);
        let e = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap();
        let f = &e.fit;
        assert!((f.steady_pct - 9.0).abs() < 0.05, "{f:?}");
        assert!((f.time_constant_s - 0.9).abs() < 0.05, "{f:?}");
        assert!(f.last_window_pct > 11.0, "{f:?}");
        // The samples standing for the steady state sit at the asymptote with the end's spread.
        assert!((mean(&e.slip_pct) - f.steady_pct).abs() < 0.02);
        assert_eq!(e.slip_pct.len(), 1000);
    }

    #[test]
    fn the_interval_holds_the_asymptote_at_least_as_often_as_it_says() {
        // 100 noise realisations of the settle above: the 90 % interval must hold 9 % in at
        // least 85 (a binomial(100, 0.9) count falls below 85 with probability 0.04), and no
        // settle is refused.
        let mut held = 0;
        for seed in 1..=100 {
            let (t, s, d) = recording(5.0, seed, |t| 9.0 + 400.0 * (-t / 0.9).exp(), |_| 1760.0);
            let f = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap().fit;
            held += usize::from(f.steady_90_pct[0] <= 9.0 && 9.0 <= f.steady_90_pct[1]);
        }
        assert!(held >= 85, "{held} of 100");
    }

    #[test]
    fn a_settle_that_heads_below_gross_slip_is_not_extrapolated() {
        // The same settle heading for 1 %: a belt regaining its grip may stick before it gets
        // there, so the fit cannot say where it ends.
        let (t, s, d) = recording(5.0, 0, |t| 1.0 + 400.0 * (-t / 0.9).exp(), |_| 1760.0);
        let why = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap_err();
        assert!(why.contains("not for gross slip (from 2.070 %,"), "{why}");
        // Heading for 9 %, it is.
        let (t, s, d) = recording(5.0, 0, |t| 9.0 + 400.0 * (-t / 0.9).exp(), |_| 1760.0);
        assert!(extrapolate("r.csv", &t, &s, &d, GROSS).is_ok());
    }

    #[test]
    fn a_drift_without_a_settle_in_sight_is_not_extrapolated() {
        // A straight fall of 1 pp/s: any asymptote is a guess.
        let (t, s, d) = recording(5.0, 0, |t| 12.0 - t, |_| 1760.0);
        let why = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap_err();
        assert!(why.contains("no settling in sight"), "{why}");
    }

    #[test]
    fn a_fall_that_speeds_up_at_the_end_is_not_extrapolated() {
        // A belt regaining its grip: the fall steepens over the last half second.
        let (t, s, d) = recording(
            5.0,
            0,
            |t| {
                if t < 4.5 {
                    20.0 - 2.0 * t
                } else {
                    11.0 - 12.0 * (t - 4.5)
                }
            },
            |_| 1760.0,
        );
        let why = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap_err();
        assert!(why.contains("the drift is not one"), "{why}");
    }

    #[test]
    fn a_drive_still_running_up_is_not_extrapolated() {
        // The driver gains 100 rpm over the window: the slip follows the motor, not the belt.
        let (t, s, d) = recording(
            3.0,
            0,
            |t| 1.0 + 20.0 * (-t / 0.5).exp(),
            |t| 1650.0 + 50.0 * t,
        );
        let why = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap_err();
        assert!(why.contains("still running up"), "{why}");
    }

    #[test]
    fn too_short_a_recording_is_not_extrapolated() {
        let (t, s, d) = recording(1.5, 0, |t| 9.0 + 400.0 * (-t / 0.9).exp(), |_| 1760.0);
        let why = extrapolate("r.csv", &t, &s, &d, GROSS).unwrap_err();
        assert!(why.contains("too short"), "{why}");
    }
}
