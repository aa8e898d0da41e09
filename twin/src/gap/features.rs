//! What `rom gap` compares between a recording and the twin: one value with its standard error
//! per cell (signal x statistic x band x window). Measured and simulated recordings go through
//! the same function ([`features`]), so a cell means the same thing on both sides.

use std::f64::consts::PI;

use fom::stats::{mean, quantile, quantile_unsorted, sample_std};
use rom::snapshots::quantile_function;
use serde::Serialize;

pub use super::sensor_noise::{
    correlated_noise, mean_scatter_acf, mean_scatter_ratio, noise_scatter, NoiseScatter, ACF_LAGS,
    CORRELATED_NOISE_RATIO,
};
use crate::error::Result;
use crate::measured::Recording;
use crate::signal::{
    line_on_trend, min_window_after, part_after, steady_part, still_drifting, SteadyPart,
};
use fom::steady::{batch_means_se as batch_se, is_running, max_driver_rpm, BATCHES, MIN_WINDOW_S};

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Signal {
    DriverSpeed,
    DrivenSpeed,
    Slip,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Statistic {
    Mean,
    Std,
    P05,
    P50,
    P95,
    /// 1-Wasserstein distance between the measured and the twin's distributions (a pair
    /// statistic: the twin's own value is zero).
    Wasserstein1,
    /// Amplitude of a spectral line.
    Amplitude,
    /// Excess kurtosis of the speed about its 20 ms moving average: 0 for white noise, negative
    /// when readings jump between quantisation levels (a pulse tachometer on a coarse timer),
    /// positive with outliers (missed pulses).
    Kurtosis,
    /// Time from the first running sample to 90 % of the steady driven speed, s.
    T90,
    /// The product P tau of a pulse tachometer's pulses per revolution and timer resolution,
    /// s, read from the lattice of levels its readings sit on ([`timer_lattice_s`]); 0 when
    /// they sit on none.
    TimerLattice,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Band {
    /// The signal's level (no filtering).
    Level,
    /// The line at the driver's rotation frequency.
    Driver1x,
    /// The line at the driven (fan) rotation frequency.
    Driven1x,
    /// The line at z times the fan frequency (z from the data, see `blade_count`).
    BladePass,
    /// The line at the belt's pass frequency (belt speed / belt length).
    BeltPass,
    /// What is left below ~25 Hz once the lines are taken out (20 ms moving average).
    Broadband,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Window {
    StartUp,
    Steady,
}

/// One place where twin and measurement can disagree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub struct Cell {
    pub window: Window,
    pub signal: Signal,
    pub statistic: Statistic,
    pub band: Band,
}

impl Cell {
    pub const fn new(window: Window, signal: Signal, statistic: Statistic, band: Band) -> Self {
        Self {
            window,
            signal,
            statistic,
            band,
        }
    }

    /// `window/signal/statistic/band`, e.g. `steady/driven-speed/amplitude/driven-1x`.
    pub fn name(&self) -> String {
        format!(
            "{}/{}/{}/{}",
            kebab(&self.window),
            kebab(&self.signal),
            kebab(&self.statistic),
            kebab(&self.band)
        )
    }
}

/// The serde (kebab-case) name of a unit enum value.
fn kebab<T: Serialize>(v: &T) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

use Band::*;
use Signal::*;
use Statistic::*;
use Window::*;

/// The cells, in report order. Not every combination of the four coordinates means something
/// (a blade-pass line of the slip's quantile does not); these do.
pub const CELLS: [Cell; 19] = [
    Cell::new(Steady, Slip, Mean, Level),
    Cell::new(Steady, Slip, Std, Level),
    Cell::new(Steady, Slip, P05, Level),
    Cell::new(Steady, Slip, P50, Level),
    Cell::new(Steady, Slip, P95, Level),
    Cell::new(Steady, Slip, Wasserstein1, Level),
    Cell::new(Steady, DriverSpeed, Mean, Level),
    Cell::new(Steady, DrivenSpeed, Mean, Level),
    Cell::new(Steady, DriverSpeed, Amplitude, Driver1x),
    Cell::new(Steady, DrivenSpeed, Amplitude, Driver1x),
    Cell::new(Steady, DrivenSpeed, Amplitude, Driven1x),
    Cell::new(Steady, DrivenSpeed, Amplitude, BladePass),
    Cell::new(Steady, DrivenSpeed, Amplitude, BeltPass),
    Cell::new(Steady, DrivenSpeed, Std, Broadband),
    Cell::new(Steady, DriverSpeed, Kurtosis, Level),
    Cell::new(Steady, DrivenSpeed, Kurtosis, Level),
    Cell::new(StartUp, Slip, Mean, Level),
    Cell::new(StartUp, DrivenSpeed, T90, Level),
    Cell::new(Steady, DriverSpeed, TimerLattice, Level),
];

/// Position of a cell in [`CELLS`].
pub fn cell_index(c: Cell) -> usize {
    CELLS.iter().position(|x| *x == c).expect("a listed cell")
}

/// A value with its standard error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Measure {
    pub value: f64,
    pub se: f64,
}

/// What sets the bands' frequencies besides the speeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BandContext {
    /// Blade count z of the blade-pass band.
    pub blades: u32,
    /// Belt length, m, and the driver's pitch diameter, m (belt-pass frequency).
    pub belt_length_m: f64,
    pub driver_diameter_m: f64,
}

/// The cells of one recording, in [`CELLS`] order (the Wasserstein cell holds 0 until
/// [`compare`] fills it), the steady slip samples sorted (for the distribution distance), and
/// each shaft's white noise (first differences, rpm) and scatter (`noise_scatter`).
#[derive(Debug, Clone, Default)]
pub struct Features {
    pub cells: Vec<Measure>,
    pub slip_sorted: Vec<f64>,
    pub noise_rpm: [f64; 2],
    /// Per shaft, its scatter about a short moving average over `noise_rpm`, and its scatter
    /// about the 20 ms moving average, rpm (`noise_scatter`; NaN on a twin's run, which is
    /// read like its measurement and needs neither).
    pub scatter_ratio: [f64; 2],
    pub scatter_rpm: [f64; 2],
    /// Per shaft, the readings' autocorrelation at lags 1..=8 about their 100 ms moving average
    /// (`noise_scatter`; NaN where not read).
    pub scatter_acf: [[f64; ACF_LAGS]; 2],
    /// Line frequencies: driver 1x, driven 1x, blade-pass, belt-pass, Hz.
    pub frequencies_hz: [f64; 4],
    /// Time from the first running sample to the end of the recording, s.
    pub running_s: f64,
    /// Time from the first running sample to the start of the steady window, s.
    pub startup_s: f64,
    /// The recording still drifts at its end: its steady cells read its last minimum window
    /// (`Read::Own`), detrended for their standard errors.
    pub unsettled: bool,
}

/// Which part of a recording the steady cells read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Read {
    /// Its own steady window (the one steady-state definition); where it still drifts at its
    /// end, its last minimum window (`fom::steady::MIN_WINDOW_S`), marked unsettled
    /// (docs/decisions/gap-unsettled-labels.md).
    Own,
    /// A twin recording over its measurement's settled window: from `startup_s` after the
    /// first running sample, or from its own start-up where that is later.
    After(f64),
    /// A twin recording over its measurement's unsettled window: the minimum window from
    /// `startup_s` after the first running sample, as it is.
    Window(f64),
}

impl Read {
    /// How a twin run of `run_s` from standstill is read to compare like with like with
    /// `measured`. A run longer than the measurement has that much start-up in front of it (a
    /// recording that starts in steady running, `baseline::twin_run_s`), so an unsettled
    /// window, whose place in the drift matters, sits that much later in the run; a settled
    /// one is read from the twin's own start-up on.
    pub fn like(measured: &Features, run_s: f64) -> Self {
        if measured.unsettled {
            Read::Window(measured.startup_s + (run_s - measured.running_s).max(0.0))
        } else {
            Read::After(measured.startup_s)
        }
    }
}

/// Centred moving average over `w` samples (shorter at the ends).
pub(super) fn moving_average(v: &[f64], w: usize) -> Vec<f64> {
    let h = w / 2;
    let mut prefix = Vec::with_capacity(v.len() + 1);
    prefix.push(0.0);
    for x in v {
        prefix.push(prefix.last().unwrap() + x);
    }
    (0..v.len())
        .map(|i| {
            let a = i.saturating_sub(h);
            let b = (i + h + 1).min(v.len());
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

/// Excess kurtosis m4 / m2^2 - 3.
pub(crate) fn excess_kurtosis(v: &[f64]) -> f64 {
    let m = mean(v);
    let m2 = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64;
    let m4 = v.iter().map(|x| (x - m).powi(4)).sum::<f64>() / v.len() as f64;
    m4 / (m2 * m2) - 3.0
}

/// Share of the readings each lattice level must hold. A true pulse gap next to one level
/// leaves the neighbouring level a few per cent (2 % on the default drive with a 60-pulse,
/// 4.1 us tachometer; example `tachometer_kurtosis`).
const LATTICE_LEVEL_SHARE: f64 = 0.01;
/// Largest relative spacing of two adjacent lattice levels: 1 / k for pulse gaps of k >= 5
/// timer ticks (a coarser timer reads too few levels to be one). Keeps a missed pulse's
/// half-speed readings from posing as a level.
const LATTICE_MAX_SPACING: f64 = 0.2;
/// Standard error of a lattice's P tau, relative: the spread of the estimate over timers of
/// 3-5 us on the default drive (0.8-2.7 %, example `tachometer_kurtosis`).
pub const LATTICE_RELATIVE_SE: f64 = 0.02;
/// Largest density between two lattice levels, as a share of the smaller level's peak.
const LATTICE_DIP: f64 = 0.2;
/// Largest share of the readings between two lattice levels that may lie in the middle third.
const LATTICE_EMPTY_MIDDLE: f64 = 0.03;

/// The product P tau of a pulse tachometer (pulses per revolution P, timer resolution tau), s,
/// from the lattice its readings `v` (rpm) sit on; 0 when they sit on none. A speed read from a
/// pulse gap of k timer ticks is n_k = 60 / (P tau k) (`sensor.rs`), so the readings cluster
/// at fixed levels whatever the drive does, and the reciprocals of adjacent levels are
/// P tau / 60 apart. The levels are the peaks of the readings' histogram smoothed with the
/// speed noise (estimated from the 10th percentile of the first differences, so that jumps
/// between levels do not inflate it): a lattice needs two peaks holding `LATTICE_LEVEL_SHARE`
/// (1 %) of the readings each with the density between them below `LATTICE_DIP` (a fifth) of
/// the smaller peak, i.e. levels more than about four noise sd apart. The closest pair of peaks gives the product (a pair m
/// levels apart would give m times it). Unlike the kurtosis of the readings, which swings as
/// the true pulse gap moves between two levels (example `tachometer_kurtosis`), the level
/// spacing depends on P tau alone.
pub fn timer_lattice_s(v: &[f64]) -> f64 {
    if v.len() < 20 {
        return 0.0;
    }
    let mut d: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    d.sort_by(f64::total_cmp);
    // The 10th percentile of |N(0, 2 s^2)| is 0.1777 s. Readings that jump between levels
    // every few samples still inflate it (to ~2x on a 60-pulse tachometer at 2-4 us), so the
    // histogram is smoothed with half of it: a narrow kernel may split one blob into bumps,
    // which the dip and the empty-middle tests below reject.
    let noise = (0.5 * quantile(&d, 0.1) / 0.1777).max(1e-3);
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0) {
        return 0.0;
    }
    let h = (0.25 * noise).max((hi - lo) / 20_000.0);
    let bins = ((hi - lo) / h) as usize + 1;
    let mut hist = vec![0.0; bins];
    for x in v {
        hist[(((x - lo) / h) as usize).min(bins - 1)] += 1.0;
    }
    // Gaussian kernel of sd `noise`, +-3 sd.
    let s = noise / h;
    let half = (3.0 * s).ceil() as isize;
    let kernel: Vec<f64> = (-half..=half)
        .map(|j| (-0.5 * (j as f64 / s).powi(2)).exp())
        .collect();
    let density: Vec<f64> = (0..bins as isize)
        .map(|i| {
            (-half..=half)
                .filter_map(|j| {
                    let k = i + j;
                    (0..bins as isize)
                        .contains(&k)
                        .then(|| hist[k as usize] * kernel[(j + half) as usize])
                })
                .sum()
        })
        .collect();
    // Peaks holding enough readings within +-1.5 noise sd.
    let reach = (1.5 * s).ceil() as usize;
    let peaks: Vec<usize> = (0..bins)
        .filter(|&i| {
            let left = i == 0 || density[i] > density[i - 1];
            let right = i + 1 == bins || density[i] >= density[i + 1];
            let mass: f64 = hist[i.saturating_sub(reach)..(i + reach + 1).min(bins)]
                .iter()
                .sum();
            left && right && mass >= LATTICE_LEVEL_SHARE * v.len() as f64
        })
        .collect();
    // A level: the mean of the readings within 1.5 noise sd of its peak (the bin centre alone
    // is a quarter noise sd coarse).
    let level = |i: usize| {
        let centre = lo + (i as f64 + 0.5) * h;
        let near: Vec<f64> = v
            .iter()
            .copied()
            .filter(|x| (x - centre).abs() <= 1.5 * noise)
            .collect();
        mean(&near)
    };
    peaks
        .windows(2)
        .filter_map(|w| {
            let dip = density[w[0]..=w[1]]
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min);
            if dip >= LATTICE_DIP * density[w[0]].min(density[w[1]]) {
                return None;
            }
            // Between two levels of a lattice the readings are noise tails: the middle third
            // of the span holds almost none. A slow ripple of the speed (whose histogram also
            // peaks at its two extremes) holds a fifth of its readings there.
            let (a, b) = (level(w[0]), level(w[1]));
            if b - a > LATTICE_MAX_SPACING * b {
                return None;
            }
            let third = (b - a) / 3.0;
            let span = v.iter().filter(|&&x| x >= a && x <= b).count();
            let middle = v
                .iter()
                .filter(|&&x| x > a + third && x < b - third)
                .count();
            (middle as f64 <= LATTICE_EMPTY_MIDDLE * span as f64).then_some((a, b))
        })
        .map(|(a, b)| 60.0 * (1.0 / a - 1.0 / b))
        .fold(
            0.0,
            |best: f64, c| if best == 0.0 { c } else { best.min(c) },
        )
}

/// The timer-lattice cell of a product P tau (s; 0 without a lattice): with its relative
/// standard error `LATTICE_RELATIVE_SE` (0 without a lattice).
pub fn lattice_measure(p_tau_s: f64) -> Measure {
    Measure {
        value: p_tau_s,
        se: LATTICE_RELATIVE_SE * p_tau_s,
    }
}

/// `y` without its lines at `freqs_hz` (each fitted on a quadratic trend, `line_on_trend`).
fn without_lines(t: &[f64], y: &[f64], freqs_hz: &[f64], dt: f64) -> Vec<f64> {
    let mut r = y.to_vec();
    for &f in freqs_hz {
        let (a, p) = line_on_trend(t, y, f, dt, 2);
        let wf = 2.0 * PI * f;
        for (ri, ti) in r.iter_mut().zip(t) {
            *ri -= a * (wf * (ti - 0.5 * dt) + p).cos();
        }
    }
    r
}

/// Robust standard deviation of white noise on a slowly varying signal: the median absolute
/// first difference / (0.6745 sqrt 2) (the MAD estimator of Hampel 1974 applied to
/// differences, whose variance is twice the noise's).
pub fn noise_sd(v: &[f64]) -> f64 {
    let d: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    quantile_unsorted(&d, 0.5) / (0.6745 * 2f64.sqrt())
}

/// Amplitude of the line at `f_hz` in `y`, fitted together with a quadratic trend (the speeds
/// may still creep after the slip has settled).
fn line_amplitude(t: &[f64], y: &[f64], f_hz: f64, dt: f64) -> f64 {
    line_on_trend(t, y, f_hz, dt, 2).0
}

/// Amplitude of the line at `f_hz` and its noise floor: the RMS amplitude at eight nearby
/// frequencies off the line (`floor_offsets_hz`), which is what noise alone gives at that
/// frequency.
fn line_with_floor(t: &[f64], y: &[f64], f_hz: f64, f_ref_hz: f64, dt: f64) -> Measure {
    let a = line_amplitude(t, y, f_hz, dt);
    let off_line: Vec<f64> = floor_offsets_hz(f_hz, f_ref_hz)
        .iter()
        .map(|&f| line_amplitude(t, y, f, dt))
        .collect();
    Measure {
        value: a,
        se: fom::stats::rms(&off_line),
    }
}

/// The frequencies a line's noise floor is read at: offsets of 0.37-0.89 of the fan frequency
/// `f_ref_hz` above the line and below it (not harmonics of either shaft). A lower one that
/// would fall below half the line's frequency is taken at the line's frequency divided by
/// the upper one's ratio instead (the same distance in log frequency): the speeds wander
/// slowly, their spectrum rising towards zero frequency, and at a tenth of the fan frequency
/// that wander, not the noise at the fan's line, sets the amplitude
/// (docs/decisions/gap-line-floor.md).
fn floor_offsets_hz(f_hz: f64, f_ref_hz: f64) -> Vec<f64> {
    [0.37, 0.53, 0.71, 0.89]
        .iter()
        .flat_map(|off| {
            let up = f_hz + off * f_ref_hz;
            let down = f_hz - off * f_ref_hz;
            let down = if down >= 0.5 * f_hz {
                down
            } else {
                f_hz * f_hz / up
            };
            [down, up]
        })
        .collect()
}

/// The steady window of a recording's speeds: the steady part of its slip (the one
/// steady-state definition, or with `startup_s` the part that long after the first running
/// sample: a twin recording read over its measurement's window), narrowed to where the driven
/// speed has reached its steady level (within 0.5 % or five noise sd of the mean of the
/// window's second half) for good, but never to less than the one minimum steady window
/// (docs/decisions/steady-window.md); the slip may settle while the fan is still running up.
pub struct SteadySpeeds {
    pub part: SteadyPart,
    /// The window is a drifting one (`Read::Own` on an unsettled recording, `Read::Window`).
    pub unsettled: bool,
    pub time_s: Vec<f64>,
    pub driver_rpm: Vec<f64>,
    pub driven_rpm: Vec<f64>,
    /// Mean sample interval, s.
    pub dt_s: f64,
}

pub fn steady_speeds(rec: &Recording, ratio: f64, read: Read) -> Result<SteadySpeeds> {
    let (part, unsettled) = match read {
        Read::Own => match steady_part(rec, ratio) {
            Ok(p) => (p, false),
            Err(_) if still_drifting(rec, ratio) => (last_window(rec, ratio)?, true),
            Err(e) => return Err(e),
        },
        Read::After(s) => (part_after(rec, ratio, s)?, false),
        Read::Window(s) => (min_window_after(rec, ratio, s)?, true),
    };
    let max1 = max_driver_rpm(&rec.driver_rpm);
    let steady: Vec<usize> = (0..rec.len())
        .filter(|&i| {
            let t = rec.time_s[i];
            t > part.start_s
                && (!unsettled || t <= part.start_s + MIN_WINDOW_S)
                && is_running(rec.driver_rpm[i], max1)
        })
        .collect();
    let n2: Vec<f64> = steady.iter().map(|&i| rec.driven_rpm[i]).collect();
    let level = mean(&n2[n2.len() / 2..]);
    let band = (0.005 * level).max(5.0 * noise_sd(&n2));
    let from = n2
        .iter()
        .rposition(|v| (v - level).abs() > band)
        .map_or(0, |k| k + 1)
        .min(n2.len() / 2)
        .min(longest_start(&steady, rec));
    let time_s: Vec<f64> = steady[from..].iter().map(|&i| rec.time_s[i]).collect();
    let dt_s = (time_s[time_s.len() - 1] - time_s[0]) / (time_s.len() - 1) as f64;
    Ok(SteadySpeeds {
        driver_rpm: steady[from..].iter().map(|&i| rec.driver_rpm[i]).collect(),
        driven_rpm: n2[from..].to_vec(),
        time_s,
        dt_s,
        part,
        unsettled,
    })
}

/// The last minimum window of a recording (`fom::steady::MIN_WINDOW_S` before its last
/// running sample).
fn last_window(rec: &Recording, ratio: f64) -> Result<SteadyPart> {
    let samples = rec.slip_samples(ratio);
    let (t0, end) = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) => (a.0, b.0),
        _ => (0.0, 0.0),
    };
    min_window_after(rec, ratio, end - t0 - MIN_WINDOW_S)
}

/// `v` without its least-squares straight line in the sample index (its mean kept): a drifting
/// window's samples about their drift, whose batch means give the standard error of what the
/// window holds beyond the drift (docs/decisions/gap-unsettled-labels.md).
fn detrended(v: &[f64]) -> Vec<f64> {
    let n = v.len() as f64;
    let xm = 0.5 * (n - 1.0);
    let ym = mean(v);
    let sxx: f64 = (0..v.len()).map(|i| (i as f64 - xm).powi(2)).sum();
    let sxy: f64 = v
        .iter()
        .enumerate()
        .map(|(i, y)| (i as f64 - xm) * (y - ym))
        .sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    v.iter()
        .enumerate()
        .map(|(i, y)| y - b * (i as f64 - xm))
        .collect()
}

/// The latest start (an index into `steady`) that leaves the window at least the one minimum
/// steady window long (docs/decisions/steady-window.md); 0 when it is shorter already.
fn longest_start(steady: &[usize], rec: &Recording) -> usize {
    let end_s = steady.last().map_or(0.0, |&i| rec.time_s[i]);
    steady
        .iter()
        .rposition(|&i| end_s - rec.time_s[i] >= MIN_WINDOW_S)
        .unwrap_or(0)
}

/// The blade-pass line at `blades` x the fan frequency in the steady driven speed, with its
/// noise floor.
pub fn blade_line(s: &SteadySpeeds, blades: u32) -> Measure {
    let f2 = mean(&s.driven_rpm) / 60.0;
    line_with_floor(&s.time_s, &s.driven_rpm, blades as f64 * f2, f2, s.dt_s)
}

/// The cells of one recording. `ratio` is R_t of the slip formula; the windows are those of
/// [`steady_speeds`].
pub fn features(rec: &Recording, ratio: f64, ctx: &BandContext, read: Read) -> Result<Features> {
    let speeds = steady_speeds(rec, ratio, read)?;
    let lb = blade_line(&speeds, ctx.blades);
    let SteadySpeeds {
        part,
        unsettled,
        time_s: t,
        driver_rpm: n1,
        driven_rpm: n2,
        dt_s: dt,
    } = speeds;
    let max1 = max_driver_rpm(&rec.driver_rpm);
    let running = |i: usize| is_running(rec.driver_rpm[i], max1);
    let slip = &part.slip_pct;
    // A drifting window's standard errors are those of its samples about the drift: the
    // drift is the transient both sides run through, not scatter of the statistic.
    let se = |v: &[f64], stat: &dyn Fn(&[f64]) -> f64| {
        if unsettled {
            batch_se(&detrended(v), stat)
        } else {
            batch_se(v, stat)
        }
    };
    let m = |v: &[f64], stat: &dyn Fn(&[f64]) -> f64| Measure {
        value: stat(v),
        se: se(v, stat),
    };
    let (f1, f2) = (mean(&n1) / 60.0, mean(&n2) / 60.0);
    let f_blade = ctx.blades as f64 * f2;
    let f_belt = PI * ctx.driver_diameter_m * f1 / ctx.belt_length_m;
    let l11 = line_with_floor(&t, &n1, f1, f2, dt);
    let l21 = line_with_floor(&t, &n2, f1, f2, dt);
    let l22 = line_with_floor(&t, &n2, f2, f2, dt);
    let lbelt = line_with_floor(&t, &n2, f_belt, f2, dt);
    // Broadband: the driven speed without its lines, smoothed over 20 ms.
    let w = ((0.02 / dt).round() as usize).max(1);
    let lines = [f1, f2, f_blade];
    let n2_lines_out = without_lines(&t, &n2, &lines, dt);
    let lines_out = moving_average(&n2_lines_out, w);
    // Speed about its 20 ms moving average: the sensor's own scatter.
    let about_average = |v: &[f64]| -> Vec<f64> {
        let ma = moving_average(v, w);
        v.iter().zip(&ma).map(|(a, b)| a - b).collect()
    };
    let (k1, k2) = (about_average(&n1), about_average(&n2));
    // Start-up: from the first running sample to 90 % of the steady driven speed.
    let n2_steady = mean(&n2);
    let t0 = part.running_from_s;
    let t90 = (0..rec.len())
        .find(|&i| rec.time_s[i] >= t0 && rec.driven_rpm[i] >= 0.9 * n2_steady)
        .map_or(part.start_s, |i| rec.time_s[i]);
    // Start-up slip: its mean from the first running sample to t90; the standard error is the
    // steady mean's scaled to the window's sample count (noise, not the transient, limits it).
    let startup: Vec<f64> = (0..rec.len())
        .filter(|&i| rec.time_s[i] >= t0 && rec.time_s[i] <= t90 && running(i))
        .map(|i| fom::slip::slip_pct(ratio, rec.driver_rpm[i], rec.driven_rpm[i]))
        .collect();
    // A recording that starts in steady running (the exchange format allows it) has no
    // start-up to compare: its driven speed reads 90 % of the steady level within its first
    // few running samples (a drive cannot run up in that time; a tachometer's first readings
    // are zero until its second pulse, so the first running sample is not the start).
    let has_startup = startup.len() >= 2 * BATCHES;
    let startup_mean = if !has_startup {
        Measure {
            value: f64::NAN,
            se: f64::NAN,
        }
    } else {
        Measure {
            value: mean(&startup),
            se: se(slip, &mean) * (slip.len() as f64 / startup.len() as f64).sqrt(),
        }
    };
    let mut cells = vec![
        Measure {
            value: f64::NAN,
            se: f64::NAN
        };
        CELLS.len()
    ];
    for (c, out) in CELLS.iter().zip(cells.iter_mut()) {
        *out = match (c.window, c.signal, c.statistic, c.band) {
            (Steady, Slip, Mean, Level) => m(slip, &mean),
            (Steady, Slip, Std, Level) => m(slip, &sample_std),
            (Steady, Slip, P05, Level) => m(slip, &|v| quantile_unsorted(v, 0.05)),
            (Steady, Slip, P50, Level) => m(slip, &|v| quantile_unsorted(v, 0.5)),
            (Steady, Slip, P95, Level) => m(slip, &|v| quantile_unsorted(v, 0.95)),
            (Steady, Slip, Wasserstein1, Level) => Measure {
                value: 0.0,
                se: 0.0,
            },
            (Steady, DriverSpeed, Mean, Level) => m(&n1, &mean),
            (Steady, DrivenSpeed, Mean, Level) => m(&n2, &mean),
            (Steady, DriverSpeed, Amplitude, Driver1x) => l11,
            (Steady, DrivenSpeed, Amplitude, Driver1x) => l21,
            (Steady, DrivenSpeed, Amplitude, Driven1x) => l22,
            (Steady, DrivenSpeed, Amplitude, BladePass) => lb,
            (Steady, DrivenSpeed, Amplitude, BeltPass) => lbelt,
            (Steady, DrivenSpeed, Std, Broadband) => m(&lines_out, &sample_std),
            (Steady, DriverSpeed, Kurtosis, Level) => m(&k1, &excess_kurtosis),
            (Steady, DrivenSpeed, Kurtosis, Level) => m(&k2, &excess_kurtosis),
            (Steady, DriverSpeed, TimerLattice, Level) => {
                // Without a lattice the value and its error are 0, which leaves the cell out of
                // every fit (`fit_cell`). Not from batches: a level holding 2 % of the
                // readings is not seen in every tenth of them. Not on a drifting window
                // either: its minimum window is too few readings per level, and a lattice
                // read there was five times too fine (docs/validation/gap-model-forms.md,
                // "Short recordings"); the sensor stage reads the whole recording.
                lattice_measure(if unsettled { 0.0 } else { timer_lattice_s(&n1) })
            }
            (StartUp, Slip, Mean, Level) => startup_mean,
            (StartUp, DrivenSpeed, T90, Level) if has_startup => Measure {
                value: t90 - t0,
                se: 2.0 * dt,
            },
            (StartUp, DrivenSpeed, T90, Level) => Measure {
                value: f64::NAN,
                se: f64::NAN,
            },
            _ => unreachable!("every listed cell has a rule"),
        };
    }
    let mut slip_sorted = slip.clone();
    slip_sorted.sort_by(f64::total_cmp);
    // The sensor's scatter, read on the measured recordings only (the twin's noise is set).
    let scatter = match read {
        Read::Own => [
            noise_scatter(&without_lines(&t, &n1, &lines, dt), w),
            noise_scatter(&n2_lines_out, w),
        ],
        _ => [NoiseScatter::NONE; 2],
    };
    Ok(Features {
        cells,
        slip_sorted,
        noise_rpm: [noise_sd(&n1), noise_sd(&n2)],
        scatter_ratio: scatter.map(|x| x.ratio),
        scatter_rpm: scatter.map(|x| x.level_rpm),
        scatter_acf: scatter.map(|x| x.acf),
        frequencies_hz: [f1, f2, f_blade, f_belt],
        running_s: rec.time_s[rec.len() - 1] - t0,
        startup_s: part.start_s - t0,
        unsettled,
    })
}

/// Mid-point probability levels (i + 1/2) / 200 on which slip distributions are compared
/// (finer than the surrogate's 50: a 1-Wasserstein distance of 2000-sample recordings).
pub fn levels() -> Vec<f64> {
    (0..200).map(|i| (i as f64 + 0.5) / 200.0).collect()
}

/// 1-Wasserstein distance between two sorted samples: the mean absolute difference of their
/// quantile functions (Villani, Optimal Transport, 2009, remark 2.19), on [`levels`].
pub fn wasserstein1(a: &[f64], b: &[f64]) -> f64 {
    let p = levels();
    let (qa, qb) = (quantile_function(a, &p), quantile_function(b, &p));
    qa.iter().zip(&qb).map(|(x, y)| (x - y).abs()).sum::<f64>() / p.len() as f64
}

/// Features of several runs of one label: the mean of each cell, its standard error divided by
/// sqrt(runs); slip samples pooled; noise averaged.
pub fn pool(runs: Vec<Features>) -> Features {
    let k = runs.len() as f64;
    let mut out = runs[0].clone();
    for (i, c) in out.cells.iter_mut().enumerate() {
        let vals: Vec<Measure> = runs.iter().map(|r| r.cells[i]).collect();
        c.value = vals.iter().map(|m| m.value).sum::<f64>() / k;
        c.se = (vals.iter().map(|m| m.se * m.se).sum::<f64>() / k).sqrt() / k.sqrt();
    }
    out.slip_sorted = runs.iter().flat_map(|r| r.slip_sorted.clone()).collect();
    out.slip_sorted.sort_by(f64::total_cmp);
    for j in 0..2 {
        out.noise_rpm[j] = runs.iter().map(|r| r.noise_rpm[j]).sum::<f64>() / k;
        out.scatter_ratio[j] = runs.iter().map(|r| r.scatter_ratio[j]).sum::<f64>() / k;
        out.scatter_rpm[j] = runs.iter().map(|r| r.scatter_rpm[j]).sum::<f64>() / k;
        out.scatter_acf[j] =
            std::array::from_fn(|i| runs.iter().map(|r| r.scatter_acf[j][i]).sum::<f64>() / k);
    }
    out.running_s = runs
        .iter()
        .map(|r| r.running_s)
        .fold(f64::INFINITY, f64::min);
    out.startup_s = runs.iter().map(|r| r.startup_s).fold(0.0, f64::max);
    out.unsettled = runs.iter().any(|r| r.unsettled);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;
    use rand_distr::StandardNormal;
    use rand_xoshiro::rand_core::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// A synthetic recording: motor run-up over 0.5 s, then steady speeds with a line of
    /// `line_rpm` at the fan frequency on the driven speed, white noise of 1 rpm.
    fn recording(line_rpm: f64, seed: u64) -> Recording {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut rec = Recording::default();
        for k in 0..4000 {
            let t = k as f64 * 1e-3;
            let ramp = (t / 0.5).min(1.0);
            let n1 = 1750.0 * ramp;
            let n2 = 866.0 * ramp
                + line_rpm * (2.0 * PI * 866.0 / 60.0 * t).cos()
                + if ramp < 1.0 {
                    -30.0 * (1.0 - ramp)
                } else {
                    0.0
                };
            let e1: f64 = rng.sample(StandardNormal);
            let e2: f64 = rng.sample(StandardNormal);
            rec.time_s.push(t);
            rec.driver_rpm.push((n1 + e1).max(0.0));
            rec.driven_rpm.push((n2 + e2).max(0.0));
        }
        rec
    }

    fn ctx() -> BandContext {
        BandContext {
            blades: 8,
            belt_length_m: 1.32,
            driver_diameter_m: 0.1,
        }
    }

    #[test]
    fn correlated_noise_reads_above_one_at_its_level_and_white_noise_under_lines_reads_one() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let dt = 1e-3;
        let t: Vec<f64> = (0..3000).map(|k| k as f64 * dt).collect();
        let e: Vec<f64> = (0..3002).map(|_| rng.sample(StandardNormal)).collect();
        // Noise of 1 rpm correlated over three readings (lag correlations 2/3 and 1/3), as a
        // counter's whose gate spans readings: first differences see sqrt(1/3) of it.
        let counter: Vec<f64> = (0..3000)
            .map(|k| 870.0 + (e[k] + e[k + 1] + e[k + 2]) / 3f64.sqrt())
            .collect();
        let lines = [1750.0 / 60.0, 870.0 / 60.0, 8.0 * 870.0 / 60.0];
        let white = noise_sd(&counter);
        assert!((white - 3f64.sqrt().recip()).abs() < 0.06, "{white}");
        // About the 7-reading average it keeps 0.78 of its sd, 1.35 times the differences'
        // level; about the 20 ms average 0.95 (its share in the average).
        let w = 20; // 20 ms at 1 kHz, as `features` reads it
        let read = noise_scatter(&without_lines(&t, &counter, &lines, dt), w);
        let (ratio, level) = (read.ratio, read.level_rpm);
        assert!((ratio - 1.35).abs() < 0.1, "{ratio}");
        assert!((level - 0.95).abs() < 0.06, "{level}");
        // Its autocorrelation: 2/3 and 1/3 at lags 1 and 2, none beyond; the sample estimate's
        // se over 2900 readings is about 0.03 (Bartlett's formula), so 0.08 is 2.5 se and the
        // 100 ms average's bias (-0.01).
        let expected = [2.0 / 3.0, 1.0 / 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        for (lag, (a, b)) in read.acf.iter().zip(expected).enumerate() {
            assert!((a - b).abs() < 0.08, "lag {}: {a} against {b}", lag + 1);
        }
        // White noise of 1 rpm under a blade-pass line of 2 rpm and a fan line of 1 rpm: the
        // lines are taken out and the scatter is the white level's.
        let v: Vec<f64> = t
            .iter()
            .zip(&e)
            .map(|(&ti, &ei)| {
                870.0
                    + 2.0 * (2.0 * PI * lines[2] * ti).cos()
                    + (2.0 * PI * lines[1] * ti + 0.3).cos()
                    + ei
            })
            .collect();
        let read = noise_scatter(&without_lines(&t, &v, &lines, dt), w);
        let (ratio_white, level_white) = (read.ratio, read.level_rpm);
        assert!((ratio_white - 1.0).abs() < 0.05, "{ratio_white}");
        assert!((level_white - 1.0).abs() < 0.06, "{level_white}");
        // The data set's decision: the mean over its recordings, per shaft.
        let reading = |r: [f64; 2]| Features {
            scatter_ratio: r,
            ..Features::default()
        };
        let set = [
            reading([1.0, 1.35]),
            reading([1.02, f64::NAN]),
            reading([0.98, 1.2]),
        ];
        assert_eq!(correlated_noise(set.iter()), [false, true]);
        assert_eq!(correlated_noise([reading([1.0, 1.08])].iter()), [false; 2]);
        let mean = mean_scatter_ratio(set.iter());
        assert!((mean[0] - 1.0).abs() < 1e-12 && (mean[1] - 1.275).abs() < 1e-12);
        assert!(mean_scatter_ratio([reading([f64::NAN, 1.0])].iter())[0].is_nan());
    }

    #[test]
    fn a_line_stands_out_of_its_noise_floor_and_noise_alone_does_not() {
        let with = features(&recording(0.5, 1), 2.0, &ctx(), Read::Own).unwrap();
        let without = features(&recording(0.0, 1), 2.0, &ctx(), Read::Own).unwrap();
        let i = cell_index(Cell::new(Steady, DrivenSpeed, Amplitude, Driven1x));
        let (a, b) = (with.cells[i], without.cells[i]);
        assert!((a.value - 0.5).abs() < 4.0 * a.se, "{a:?}");
        assert!(a.value > 10.0 * a.se, "{a:?}");
        assert!(b.value < 4.0 * b.se, "{b:?}");
        // The white noise is found (1 rpm on both signals).
        for s in without.noise_rpm {
            assert!((s - 1.0).abs() < 0.1, "{s}");
        }
        // White noise has no excess kurtosis.
        let k = without.cells[cell_index(Cell::new(Steady, DriverSpeed, Kurtosis, Level))];
        assert!(k.value.abs() < 4.0 * k.se, "{k:?}");
    }

    #[test]
    fn a_lines_floor_is_the_noise_near_it_not_a_slow_wander() {
        // White noise of 1 rpm at 1 kHz over 3.5 s, under a slow wander of the speed (0.3 rpm
        // at 1.6 Hz and 4.2 Hz, 0.11 and 0.29 of the 14.5 Hz shaft frequency): the fan line's
        // floor is what white noise gives there, 2 sd / sqrt(n), not the wander.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(31);
        let (f_hz, dt) = (14.5, 1e-3);
        let t: Vec<f64> = (0..3500).map(|k| k as f64 * dt).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| {
                let w = |f: f64| 0.3 * (2.0 * std::f64::consts::PI * f * t + 0.4).sin();
                870.0 + w(1.6) + w(4.2) + rng.sample::<f64, _>(StandardNormal)
            })
            .collect();
        let white = 2.0 / (t.len() as f64).sqrt();
        let line = line_with_floor(&t, &y, f_hz, f_hz, dt);
        assert!(
            line.se < 1.5 * white && line.se > 0.5 * white,
            "{line:?}, white {white}"
        );
        // The wander is there, and at the slow offsets it would have been read as the floor.
        assert!(line_amplitude(&t, &y, 1.6, dt) > 5.0 * line.se, "{line:?}");
        // A line above the fan's (the motor's, at twice its frequency) keeps every offset.
        let motor = line_with_floor(&t, &y, 2.0 * f_hz, f_hz, dt);
        assert!(motor.se < 1.5 * white, "{motor:?}, white {white}");
    }

    #[test]
    fn a_recording_that_starts_in_steady_running_has_no_start_up_cells() {
        let startup = |rec: &Recording| {
            let f = features(rec, 2.0, &ctx(), Read::Own).unwrap();
            [
                f.cells[cell_index(Cell::new(StartUp, Slip, Mean, Level))].value,
                f.cells[cell_index(Cell::new(StartUp, DrivenSpeed, T90, Level))].value,
            ]
        };
        // From standstill: the run-up is read (t90 within the 0.5 s ramp).
        let full = recording(0.0, 4);
        let [_, t90] = startup(&full);
        assert!(t90 > 0.3 && t90 < 0.5, "{t90}");
        // The same recording from 1 s on, times restarting at 0, the first two readings zero
        // as a tachometer gives them before its second pulse: no start-up to compare.
        let mut steady = Recording::default();
        for k in 1000..full.len() {
            let zero = k < 1002;
            steady.time_s.push(full.time_s[k] - 1.0);
            steady
                .driver_rpm
                .push(if zero { 0.0 } else { full.driver_rpm[k] });
            steady
                .driven_rpm
                .push(if zero { 0.0 } else { full.driven_rpm[k] });
        }
        assert!(startup(&steady).iter().all(|v| v.is_nan()));
    }

    /// Readings on the lattice 60 / (P tau k) of a 60-pulse tachometer with a 3.5 us timer
    /// around 1750 rpm (k 163-165) with 1 rpm noise give P tau back; smooth readings of the
    /// same spread, and 1 rpm noise alone, give none.
    #[test]
    fn the_timer_lattice_is_read_from_the_levels_and_smooth_readings_have_none() {
        use rand::{Rng, SeedableRng};
        use rand_distr::StandardNormal;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        let c = 60.0 * 3.5e-6;
        let on_lattice: Vec<f64> = (0..2000)
            .map(|i| {
                let k = 163 + (i % 7) / 3;
                60.0 / (c * k as f64) + rng.sample::<f64, _>(StandardNormal)
            })
            .collect();
        let got = timer_lattice_s(&on_lattice);
        assert!((got / c - 1.0).abs() < 0.02, "{got} vs {c}");
        let smooth: Vec<f64> = (0..2000)
            .map(|i| 1750.0 + 8.0 * (i as f64 * 0.01).sin() + rng.sample::<f64, _>(StandardNormal))
            .collect();
        assert_eq!(timer_lattice_s(&smooth), 0.0);
        // A ripple of 50 noise sd: its histogram peaks at both extremes with a deep dip
        // between, but a fifth of it lies in the middle.
        let ripple: Vec<f64> = (0..2000)
            .map(|i| {
                1750.0 + 50.0 * (i as f64 * 0.0123).sin() + rng.sample::<f64, _>(StandardNormal)
            })
            .collect();
        assert_eq!(timer_lattice_s(&ripple), 0.0);
        let noise: Vec<f64> = (0..2000)
            .map(|_| 1750.0 + rng.sample::<f64, _>(StandardNormal))
            .collect();
        assert_eq!(timer_lattice_s(&noise), 0.0);
    }

    /// A recording of `duration_s` at 1 kHz: the motor runs up over 0.5 s, then the slip
    /// rises by `drift_pp_per_s` from 1 % (a loose belt still creeping towards its level),
    /// white noise of 0.05 pp on it and 1 rpm on the driver speed.
    fn drifting(duration_s: f64, drift_pp_per_s: f64, seed: u64) -> Recording {
        crate::signal::synthetic::slip_recording(duration_s, |t| 1.0 + drift_pp_per_s * t, seed)
    }

    /// A recording still drifting at its end is kept, marked unsettled, and read over its last
    /// minimum window, with standard errors about the drift (those of the same noise without
    /// it, not the drift's); a settled one keeps its own window; one shorter than the minimum
    /// window is refused as before.
    #[test]
    fn an_unsettled_recording_is_read_over_its_last_minimum_window() {
        let slip_mean = cell_index(Cell::new(Steady, Slip, Mean, Level));
        let f = features(&drifting(5.0, 0.1, 7), 2.0, &ctx(), Read::Own).unwrap();
        assert!(f.unsettled);
        assert!(
            (f.running_s - f.startup_s - MIN_WINDOW_S).abs() < 2e-3,
            "{f:?}"
        );
        assert!(f.running_s > 4.9, "{}", f.running_s);
        // Over 4-5 s the slip is 1.4-1.5 %: the window's mean is 1.45 %.
        let m = f.cells[slip_mean];
        assert!((m.value - 1.45).abs() < 0.01, "{m:?}");
        let flat = features(&drifting(5.0, 0.0, 7), 2.0, &ctx(), Read::Own).unwrap();
        assert!(!flat.unsettled);
        assert!(flat.startup_s < 1.0, "{}", flat.startup_s);
        let flat_last = features(
            &drifting(5.0, 0.0, 7),
            2.0,
            &ctx(),
            Read::Window(f.startup_s),
        )
        .unwrap();
        // The same noise over the same window: the drift does not inflate the error (0.1 pp
        // over the window would give a batch-means error of about 0.01 pp, six times the
        // noise's).
        let (se, se_flat) = (m.se, flat_last.cells[slip_mean].se);
        assert!(
            se < 1.5 * se_flat && se > se_flat / 1.5,
            "{se} vs {se_flat}"
        );
        // A twin recording read like it: the same window, also unsettled.
        let twin = features(
            &drifting(5.0, 0.1, 8),
            2.0,
            &ctx(),
            Read::like(&f, f.running_s),
        )
        .unwrap();
        assert!(twin.unsettled);
        assert!((twin.startup_s - f.startup_s).abs() < 1e-9);
        let e = features(&drifting(0.9, 0.1, 7), 2.0, &ctx(), Read::Own).unwrap_err();
        assert!(e.to_string().contains("too short"), "{e}");
    }

    /// A drifting window's timer-lattice cell is left out (1 s holds too few readings per
    /// level); the same readings on a settled recording give the lattice back.
    #[test]
    fn a_drifting_window_leaves_its_timer_lattice_out() {
        let lattice = cell_index(Cell::new(Steady, DriverSpeed, TimerLattice, Level));
        let c = 60.0 * 3.5e-6;
        let on_lattice = |drift_pp_per_s: f64| {
            let mut rec = drifting(5.0, drift_pp_per_s, 7);
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
            for i in 0..rec.len() {
                if rec.time_s[i] > 0.5 {
                    // The driver speed on the lattice 60 / (P tau k), the slip kept.
                    let n1 = 60.0 / (c * (163 + (i % 7) / 3) as f64)
                        + rng.sample::<f64, _>(StandardNormal);
                    rec.driven_rpm[i] *= n1 / rec.driver_rpm[i];
                    rec.driver_rpm[i] = n1;
                }
            }
            features(&rec, 2.0, &ctx(), Read::Own).unwrap()
        };
        let settled = on_lattice(0.0);
        assert!(!settled.unsettled);
        let got = settled.cells[lattice].value;
        assert!((got / c - 1.0).abs() < 0.02, "{got} vs {c}");
        let drifting = on_lattice(0.1);
        assert!(drifting.unsettled);
        let m = drifting.cells[lattice];
        assert_eq!((m.value, m.se), (0.0, 0.0));
    }

    #[test]
    fn the_wasserstein_distance_of_a_shift_is_the_shift() {
        let a: Vec<f64> = (0..1000).map(|i| i as f64 / 1000.0).collect();
        let b: Vec<f64> = a.iter().map(|x| x + 0.25).collect();
        assert!((wasserstein1(&a, &b) - 0.25).abs() < 1e-9);
    }

    #[test]
    fn quantised_readings_have_negative_kurtosis() {
        // Readings alternating between two levels 4 rpm apart, plus 1 rpm noise.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let v: Vec<f64> = (0..4000)
            .map(|k| {
                let e: f64 = rng.sample(StandardNormal);
                1750.0 + if (k * 7919) % 13 < 6 { 2.0 } else { -2.0 } + e
            })
            .collect();
        assert!(excess_kurtosis(&v) < -0.5, "{}", excess_kurtosis(&v));
    }
}
