//! The one definition of steady state, for simulated and measured runs alike.
//!
//! 1. **Where the start-up ends**: the MSER-5 truncation rule (White, "An effective truncation
//!    heuristic for bias reduction in simulation output", Simulation 69(6), 1997; recommended by
//!    Hoad, Robinson & Davies, J. Oper. Res. Soc. 61, 2010): over means Z of `BATCH` consecutive
//!    samples, the steady window starts at the batch d minimising the marginal standard error
//!    sum_{i>d} (Z_i - mean_d)^2 / (n - d)^2, searched over the windows at least the minimum
//!    length long. Noise, tachometer quantisation and slow wander count as variance; a transient
//!    counts as bias and is cut off.
//! 2. **Whether it has settled**: the retained window, cut into `DRIFT_BATCHES` batches, must
//!    not drift: the means of its later and earlier halves differ by at most `DRIFT_SE`
//!    standard errors (from the batch means' scatter within each half; batch means carry the
//!    samples' autocorrelation: Law, Simulation Modeling and Analysis, 5th ed., 2015, sec.
//!    9.5.3) or a floor max(`DRIFT_FLOOR_PP`, `DRIFT_FLOOR_SHARE` x |mean|), far below the
//!    surrogate's accuracy targets. A window shorter than the minimum, or one that drifts, is
//!    **unsettled**, and says why.
//!
//! Used by the run summary (`rom simulate`), training (runs continue until settled), the
//! surrogate's snapshots, `rom validate`, and the twin's measured slip (calibrate, diagnose).

use serde::{Deserialize, Serialize};

use crate::stats::mean;

/// Samples per MSER batch (MSER-5).
pub const BATCH: usize = 5;
/// Batches of the drift test.
pub const DRIFT_BATCHES: usize = 10;
/// Standard errors of the half-means' difference that noise may explain.
pub const DRIFT_SE: f64 = 3.0;
/// Drift always accepted, percentage points of slip.
pub const DRIFT_FLOOR_PP: f64 = 0.01;
/// Drift always accepted, share of the window's mean slip.
pub const DRIFT_FLOOR_SHARE: f64 = 0.005;
/// Least window a steady verdict rests on, s: run summaries, measured recordings and the
/// twin's recordings alike (docs/decisions/steady-window.md).
pub const MIN_WINDOW_S: f64 = 1.0;
/// Shortest window a caller may ask for, s (short test drives).
pub const SHORTEST_WINDOW_S: f64 = 0.1;
/// Batches of the batch-means standard error (docs/decisions/batch-means.md).
pub const BATCHES: usize = DRIFT_BATCHES;
/// Driver speed a running sample must exceed, rpm: below it slip, a ratio of speeds, is
/// undefined (docs/decisions/running-sample.md).
pub const RUNNING_MIN_RPM: f64 = 1.0;

/// Whether the driver turns at `driver_rpm`: the part of the running-sample rule a sample
/// decides alone (the full-order model's rows, written before the run's largest speed is
/// known; docs/decisions/running-sample.md).
pub fn turns(driver_rpm: f64) -> bool {
    driver_rpm > RUNNING_MIN_RPM
}

/// The running-sample rule (docs/decisions/running-sample.md): the driver turns
/// ([`turns`]) at no less than `fom::slip::STANDSTILL_SHARE` of the record's largest driver
/// speed `max_driver_rpm` (standstill and the first instants of start-up carry no slip
/// information).
pub fn is_running(driver_rpm: f64, max_driver_rpm: f64) -> bool {
    turns(driver_rpm) && driver_rpm >= crate::slip::STANDSTILL_SHARE * max_driver_rpm
}

/// The largest driver speed of a record, rpm (0 for none), the reference of [`is_running`].
pub fn max_driver_rpm(driver_rpm: &[f64]) -> f64 {
    driver_rpm.iter().copied().fold(0.0, f64::max)
}

/// Standard error of `stat` over the autocorrelated samples `v` by the batch-means method
/// (Law, Simulation Modeling and Analysis, 5th ed., 2015, sec. 9.5.3): `BATCHES` batches of
/// floor(n / `BATCHES`) consecutive samples from the window's start (where the steady state
/// was found to begin), the trailing remainder of fewer than `BATCHES` samples left out,
/// `stat` of each, and the sample standard deviation of those over sqrt(`BATCHES`). NaN with
/// fewer samples than batches. The one definition for simulated and measured records
/// (docs/decisions/batch-means.md).
pub fn batch_means_se(v: &[f64], stat: impl Fn(&[f64]) -> f64) -> f64 {
    let len = v.len() / BATCHES;
    if len == 0 {
        return f64::NAN;
    }
    let b: Vec<f64> = v[..len * BATCHES].chunks(len).map(stat).collect();
    let m = mean(&b);
    let var = b.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (BATCHES - 1) as f64;
    (var / BATCHES as f64).sqrt()
}

/// Drift test of one trailing window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DriftTest {
    /// Start and end of the window, s.
    pub start_s: f64,
    pub end_s: f64,
    /// Mean of the window's block means, %.
    pub mean_pct: f64,
    /// Fitted change over the window, slope x length, percentage points.
    pub drift_pp: f64,
    /// Largest drift accepted for this window, percentage points.
    pub tolerance_pp: f64,
    /// Standard error of `mean_pct`, percentage points: the sample standard deviation of the
    /// window's `DRIFT_BATCHES` batch means over sqrt(`DRIFT_BATCHES`) (the batch-means
    /// method, Law, Simulation Modeling and Analysis, 5th ed., 2015, sec. 9.5.3). Near the
    /// knee the slip swings slowly and a 2 s window's mean carries up to 0.12 pp of it
    /// (`docs/validation/surrogate.md`, "What the two seed-38 misses are").
    pub mean_se_pp: f64,
}

impl DriftTest {
    pub fn passes(&self) -> bool {
        self.drift_pp.abs() <= self.tolerance_pp
    }
}

/// Verdict on a series.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Settling {
    /// Steady from `window.start_s` to the end.
    Settled { window: DriftTest },
    /// The last `MIN_WINDOW_S` (or the whole series, if shorter) still drifts, or the series
    /// is too short to judge.
    Unsettled {
        reason: String,
        last: Option<DriftTest>,
    },
}

impl Settling {
    /// The steady window's test, if settled.
    pub fn window(&self) -> Option<&DriftTest> {
        match self {
            Settling::Settled { window } => Some(window),
            Settling::Unsettled { .. } => None,
        }
    }

    /// Start of the steady window, s, if settled.
    pub fn start_s(&self) -> Option<f64> {
        self.window().map(|w| w.start_s)
    }

    pub fn is_settled(&self) -> bool {
        matches!(self, Settling::Settled { .. })
    }
}

/// Start index of the MSER-5 window of `v`, searched over windows of at least `min_len`
/// samples (counted in samples: the last batch may be a partial one).
fn mser_start(v: &[f64], min_len: usize) -> usize {
    let z: Vec<f64> = v
        .chunks(BATCH)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect();
    let n = z.len();
    // The latest batch start whose window holds `min_len` samples (the first where none does).
    let latest = (v.len().saturating_sub(min_len) / BATCH).min(n - 1);
    // Suffix sums of z and z^2 give every tail's variance in one pass.
    let (mut s1, mut s2) = (0.0, 0.0);
    let mut best = (f64::INFINITY, latest);
    for d in (0..n).rev() {
        s1 += z[d];
        s2 += z[d] * z[d];
        let m = (n - d) as f64;
        if d > latest {
            continue;
        }
        let ss = (s2 - s1 * s1 / m).max(0.0);
        let mser = ss / (m * m);
        if mser <= best.0 {
            best = (mser, d);
        }
    }
    best.1 * BATCH
}

/// Drift test of the window `t`, `v` (at least `DRIFT_BATCHES` samples).
fn drift_test(t: &[f64], v: &[f64]) -> DriftTest {
    let len = v.len() / DRIFT_BATCHES;
    let skip = v.len() - len * DRIFT_BATCHES;
    let means: Vec<f64> = v[skip..]
        .chunks(len)
        .map(|c| c.iter().sum::<f64>() / len as f64)
        .collect();
    let h = DRIFT_BATCHES / 2;
    let (early, late) = means.split_at(h);
    let (a, b) = (mean(early), mean(late));
    let ss: f64 = early.iter().map(|m| (m - a).powi(2)).sum::<f64>()
        + late.iter().map(|m| (m - b).powi(2)).sum::<f64>();
    let var = ss / (DRIFT_BATCHES - 2) as f64;
    let se = (var * 2.0 / h as f64).sqrt();
    let window_mean = mean(v);
    let floor = DRIFT_FLOOR_PP.max(DRIFT_FLOOR_SHARE * window_mean.abs());
    DriftTest {
        start_s: t[0],
        end_s: t[t.len() - 1],
        mean_pct: window_mean,
        drift_pp: b - a,
        tolerance_pp: (DRIFT_SE * se).max(floor),
        mean_se_pp: batch_means_se(v, mean),
    }
}

/// Samples in the minimum window `min_window_s` at the end of the series `t` (ascending times),
/// both ends included (the window starts after the sample before its first), at least
/// `DRIFT_BATCHES`: the series' own spacing there, which is not its mean where samples are
/// missing (a tachometer's first pulses after standstill). The shortest window [`settle`]
/// chooses.
pub fn min_window_len(t: &[f64], min_window_s: f64) -> usize {
    let from = t.last().map_or(f64::INFINITY, |end| end - min_window_s);
    (t.len() - t.partition_point(|&ti| ti < from)).max(DRIFT_BATCHES)
}

/// Settling of the series `value(time_s)` (slip, %) with a steady window of at least
/// `min_window_s`. Times ascending; non-finite values are ignored. With `fixed_start_s` the
/// window is the samples after it (a start the user fixed); without, MSER-5 finds it.
pub fn settle(
    time_s: &[f64],
    value: &[f64],
    min_window_s: f64,
    fixed_start_s: Option<f64>,
) -> Settling {
    let (t, v): (Vec<f64>, Vec<f64>) = time_s
        .iter()
        .zip(value)
        .filter(|p| p.1.is_finite() && fixed_start_s.is_none_or(|f| *p.0 > f))
        .map(|(a, b)| (*a, *b))
        .unzip();
    let span_s = match (t.first(), t.last()) {
        (Some(a), Some(b)) => b - a,
        _ => 0.0,
    };
    let min_len = if span_s > 0.0 {
        min_window_len(&t, min_window_s)
    } else {
        usize::MAX
    };
    if span_s < min_window_s || t.len() < min_len {
        return Settling::Unsettled {
            reason: format!(
                "too short to judge: {span_s:.2} s of data, need {min_window_s} s of steady \
                 running"
            ),
            last: None,
        };
    }
    let start = if fixed_start_s.is_some() {
        0
    } else {
        mser_start(&v, min_len)
    };
    let mut test = drift_test(&t[start..], &v[start..]);
    // The window is the samples after `start_s`.
    test.start_s = match (fixed_start_s, start) {
        (Some(f), _) => f,
        (None, 0) => t[0] - (t[1] - t[0]),
        (None, k) => t[k - 1],
    };
    if !test.passes() {
        return Settling::Unsettled {
            reason: format!(
                "still drifting: slip changed {:+.3} pp between the halves of the last {:.2} s \
                 (mean {:.3} %), more than noise explains ({:.3} pp)",
                test.drift_pp,
                test.end_s - test.start_s,
                test.mean_pct,
                test.tolerance_pp
            ),
            last: Some(test),
        };
    }
    Settling::Settled { window: test }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(f: impl Fn(f64) -> f64, duration_s: f64, rate_hz: f64) -> (Vec<f64>, Vec<f64>) {
        let n = (duration_s * rate_hz) as usize;
        let t: Vec<f64> = (1..=n).map(|i| i as f64 / rate_hz).collect();
        let v = t.iter().map(|&t| f(t)).collect();
        (t, v)
    }

    /// Deterministic pseudo-noise in [-1, 1] (a fixed LCG; no RNG state to seed).
    fn noise(i: usize) -> f64 {
        let x = (i as u64)
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn a_flat_noisy_series_is_steady_over_its_whole_length() {
        let (t, _) = series(|_| 0.0, 5.0, 1000.0);
        let v: Vec<f64> = (0..t.len()).map(|i| 2.0 + 0.5 * noise(i)).collect();
        let s = settle(&t, &v, MIN_WINDOW_S, None);
        let w = match s {
            Settling::Settled { window } => window,
            other => panic!("{other:?}"),
        };
        assert!(w.start_s < 0.5, "{w:?}");
        assert!((w.mean_pct - 2.0).abs() < 0.01);
    }

    #[test]
    fn a_decaying_transient_is_cut_off_where_it_sinks_into_the_noise() {
        // slip = 1 + 5 exp(-t / 0.5 s) + noise of sd 0.03 pp: the transient falls to the
        // noise's standard error of a 5-sample batch mean (~0.008 pp) near t = 3.2 s.
        let (t, _) = series(|_| 0.0, 8.0, 1000.0);
        let v: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &t)| 1.0 + 5.0 * (-t / 0.5).exp() + 0.052 * noise(i))
            .collect();
        let w = match settle(&t, &v, MIN_WINDOW_S, None) {
            Settling::Settled { window } => window,
            other => panic!("{other:?}"),
        };
        assert!(w.start_s > 1.5 && w.start_s < 4.0, "{w:?}");
        // The retained mean carries less bias than its own standard error (~0.001 pp) x 5.
        assert!((w.mean_pct - 1.0).abs() < 0.005, "{w:?}");
        // The whole run, start-up included, would have been biased by 0.3 pp.
        let all = v.iter().sum::<f64>() / v.len() as f64;
        assert!(all - 1.0 > 0.25);
    }

    #[test]
    fn a_series_still_drifting_at_its_end_is_unsettled_and_says_by_how_much() {
        // A knee run still drifting at its end: 10.5 -> 8.9 -> 7.8 -> 7.0 % over 0.5 s blocks.
        let (t, v) = series(|t| 6.0 + 6.0 * (-t / 1.5).exp(), 2.0, 1000.0);
        match settle(&t, &v, MIN_WINDOW_S, None) {
            Settling::Unsettled { reason, last } => {
                assert!(reason.contains("still drifting"), "{reason}");
                assert!(last.unwrap().drift_pp < -0.5);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn quantised_tachometer_noise_does_not_make_a_steady_run_unsettled() {
        // Slip from speeds quantised to 2 rpm steps at 1800 rpm (about 0.11 pp jumps).
        let (t, _) = series(|_| 0.0, 3.0, 500.0);
        let v: Vec<f64> = (0..t.len())
            .map(|i| {
                let driven = ((1780.0 + 3.0 * noise(i)) / 2.0).round() * 2.0;
                100.0 * (1.0 - driven / 1800.0)
            })
            .collect();
        assert!(settle(&t, &v, MIN_WINDOW_S, None).is_settled());
    }

    /// The 99 % band of s / sigma for a sample standard deviation of 10 independent batch
    /// means (chi-square with 9 degrees of freedom: 0.5 % and 99.5 % quantiles 1.735 and
    /// 23.59, divided by 9, square-rooted).
    const SE_RATIO_99: [f64; 2] = [0.439, 1.619];

    /// Independent pseudo-random noise in [-1, 1): splitmix64 of the index (Steele, Lea &
    /// Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014). `noise` above
    /// is a Weyl sequence, evenly spread, whose batch means scatter far less than white
    /// noise's.
    fn white(i: usize) -> f64 {
        let mut z = (i as u64).wrapping_add(1).wrapping_mul(0x9E3779B97F4A7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^= z >> 31;
        ((z >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn the_mean_s_standard_error_matches_white_noise() {
        // Uniform noise of half-width 0.5 pp: sd 0.5 / sqrt(3); the mean of n samples has
        // sd / sqrt(n).
        let n = 5000;
        let (t, _) = series(|_| 0.0, n as f64 / 1000.0, 1000.0);
        let v: Vec<f64> = (0..n).map(|i| 2.0 + 0.5 * white(i)).collect();
        let w = drift_test(&t, &v);
        let exact = 0.5 / 3f64.sqrt() / (n as f64).sqrt();
        let r = w.mean_se_pp / exact;
        println!(
            "standard error {:.3e}, ratio to the exact one {r:.3}",
            w.mean_se_pp
        );
        assert!(r > SE_RATIO_99[0] && r < SE_RATIO_99[1], "{w:?}: ratio {r}");
    }

    #[test]
    fn the_mean_s_standard_error_carries_slow_wander_that_sample_noise_hides() {
        // AR(1) slip with phi = 0.99 (a correlation time of 100 samples, batches of 500):
        // the mean's variance is sigma^2 / n (1 + phi) / (1 - phi), 14 times the naive
        // standard error sd / sqrt(n) (Law 2015, sec. 9.5.3).
        let (n, phi) = (5000, 0.99);
        let (t, _) = series(|_| 0.0, n as f64 / 1000.0, 1000.0);
        let mut x = 0.0;
        let v: Vec<f64> = (0..n)
            .map(|i| {
                x = phi * x + 0.1 * white(i);
                3.0 + x
            })
            .collect();
        let w = drift_test(&t, &v);
        let mean = v.iter().sum::<f64>() / n as f64;
        let sd = (v.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        let naive = sd / (n as f64).sqrt();
        let expected = naive * ((1.0 + phi) / (1.0 - phi)).sqrt();
        let r = w.mean_se_pp / expected;
        println!(
            "standard error {:.3e}, ratio to the exact one {r:.3}",
            w.mean_se_pp
        );
        assert!(r > SE_RATIO_99[0] && r < SE_RATIO_99[1], "{w:?}: ratio {r}");
        assert!(w.mean_se_pp > 5.0 * naive, "{w:?} against {naive}");
    }

    #[test]
    fn the_shortest_window_holds_the_minimum_window_whatever_the_length_mod_the_batch() {
        // A steady drift makes MSER take the shortest window it may. With 3001, ..., 3005
        // samples the last batch of five is a partial one; the window still spans the
        // minimum, and holds at least that many samples.
        for extra in 1..=5 {
            let n = 3000 + extra;
            let t: Vec<f64> = (1..=n).map(|i| i as f64 * 1e-3).collect();
            let v: Vec<f64> = t.iter().map(|&t| 10.0 - t).collect();
            let w = match settle(&t, &v, MIN_WINDOW_S, None) {
                Settling::Unsettled { last: Some(w), .. } => w,
                other => panic!("{other:?}"),
            };
            let held = t.iter().filter(|&&ti| ti > w.start_s).count();
            assert!(held >= 1000, "{n} samples: the window holds {held}");
            assert!(w.end_s - w.start_s >= MIN_WINDOW_S, "{n}: {w:?}");
        }
    }

    #[test]
    fn the_shortest_window_spans_the_minimum_where_early_samples_are_missing() {
        // 1 kHz over 3 s with every other sample of the first second missing: the mean spacing
        // (1.2 ms) would count 834 samples as a second; the last second holds 1000.
        let t: Vec<f64> = (1..=3000)
            .filter(|i| *i > 1000 || i % 2 == 0)
            .map(|i| i as f64 * 1e-3)
            .collect();
        let v: Vec<f64> = t.iter().map(|&t| 10.0 - t).collect();
        let w = match settle(&t, &v, MIN_WINDOW_S, None) {
            Settling::Unsettled { last: Some(w), .. } => w,
            other => panic!("{other:?}"),
        };
        assert!(w.end_s - w.start_s >= MIN_WINDOW_S, "{w:?}");
    }

    #[test]
    fn too_short_a_series_is_unsettled_not_steady() {
        let (t, v) = series(|_| 1.0, 0.5, 1000.0);
        match settle(&t, &v, MIN_WINDOW_S, None) {
            Settling::Unsettled { reason, last: None } => assert!(reason.contains("too short")),
            other => panic!("{other:?}"),
        }
    }
}
