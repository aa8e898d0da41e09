//! The sensor stage's test of a counter by the M/T method against the pulse timer a read lattice
//! implies (docs/decisions/sensor-first.md, "A counter's gate").
//!
//! Both read speeds on levels 60 m / (P tau k): a pulse timer with m = 1, a counter with m the
//! whole pulse gaps within its gate, which changes with the speed (`crate::sensor::SensorModel`,
//! `gate_s`). A counter of clock tau counting m gaps steps as a timer of tau / m does, so the
//! levels alone do not tell the two apart; which levels the readings occupy does: a timer's
//! readings sit on the levels next to the true speed, a counter's on those of each count m the
//! gate holds, a step of about tau / gate apart on both shafts. Each hypothesis is read by
//! synthesis: the recording's speed, smoothed (its shaft's own 1x and 2x lines kept), is turned
//! into pulse times and read through it without noise, and its readings are compared with the
//! measured ones by which levels they occupy ([`level_distance`]) and how often
//! ([`share_distance`]). The counter's pulse edges' jitter is read from the readings' scatter
//! about their speed ([`edge_jitter`]), which also decides among counters whose levels read
//! the readings alike.

use rayon::prelude::*;
use serde::Serialize;

use fom::stats::mean;

use super::sensor_id::ShaftReadings;
use crate::sensor::{pulse_times, read_pulses, SensorModel};

/// Readings each side of the moving average that stands for the true speed: 25 ms at 1 kHz,
/// long enough to average a counter's steps (about 1 % at its gate) down to a tenth of a step,
/// short enough to keep the shafts' slow speed swings, which spread a timer's readings.
const SMOOTH_HALF: usize = 25;
/// Readings left out at each end of a window: the moving average is one-sided there and the
/// synthetic sensor has seen too few pulses at the start.
const EDGE: usize = 100;
/// Clocks tried: the lattice's tau times j / i, 1 <= j / i <= MAX_CLOCK_MULTIPLE, i <=
/// MAX_CLOCK_DIVISOR. A counter of m gaps steps as a timer of tau / m, so where the lattice's
/// closest levels have one count its clock is a whole multiple of the lattice's; where they
/// have two, m1 and m2, it is m1 m2 / q times it for a whole q (1 / a - 1 / b =
/// P tau (k1 / m1 - k2 / m2) / 60).
const MAX_CLOCK_MULTIPLE: usize = 12;
const MAX_CLOCK_DIVISOR: usize = 8;
/// Gates tried, s: GATE_STEP_S, 2 GATE_STEP_S, ... up to GATE_STEPS of them (0.1 ms is a
/// tenth of a 60-pulse wheel's gap at 1000 rpm: the share of readings with each count m moves
/// by a tenth per step), first every COARSE_GATE_STEPS-th at every clock, then all of them
/// within a coarse step of the best coarse gate at the FINE_CLOCKS clocks that read best.
const GATE_STEP_S: f64 = 1e-4;
const GATE_STEPS: usize = 120;
const COARSE_GATE_STEPS: usize = 10;
const FINE_CLOCKS: usize = 4;
/// Relative step and steps each side by which a hypothesis's clock is refined: +-1.5 %.
const CLOCK_REFINE_STEP: f64 = 5e-4;
const CLOCK_REFINE_STEPS: i32 = 30;
/// Windows of each shaft read, and readings of each window (its middle): enough for the
/// shares of a few levels to a few per cent.
const WINDOWS_PER_SHAFT: usize = 2;
const READINGS_PER_WINDOW: usize = 1500;
/// A counter is read where its distance is below this share of the pulse timer's ...
const COUNTER_SHARE: f64 = 0.5;
/// ... and the pulse timer's is above this: readings a timer prints with fewer than 5 % of
/// them on levels it does not print are a timer's (the full-order and lumped models' pulse
/// timers read 0.002-0.01 off their own readings, the creep model's counters 0.1-0.8 off).
const MIN_TIMER_DISTANCE: f64 = 0.05;

/// A counter by the M/T method read from the recordings, with the distances that chose it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CounterFit {
    /// Counting gate, s.
    pub gate_s: f64,
    /// Clock, s (P tau over the pulses per revolution the twin is read with).
    pub clock_s: f64,
    /// Distance of the readings from the counter's and from the pulse timer's of the lattice
    /// ([`level_distance`] plus `SHARE_WEIGHT` x [`share_distance`]), mean over the windows.
    pub distance: f64,
    pub timer_distance: f64,
    /// The pulse edges' jitter that reads the readings' scatter about their speed, s, and the
    /// drop of the misfit it gives from no jitter ([`edge_jitter`]; 0 s below
    /// `JITTER_EVIDENCE`).
    pub edge_jitter_s: f64,
    pub edge_jitter_gain: f64,
    /// The misfit of the readings' scatter at that jitter ([`edge_jitter`]), which decides
    /// among counters whose levels and shares read the readings alike (`DISTANCE_TIE`).
    pub scatter_misfit: f64,
}

impl CounterFit {
    /// Whether the counter reads the recordings much better than the lattice's pulse timer.
    pub fn reads_better(&self) -> bool {
        self.distance < COUNTER_SHARE * self.timer_distance
            && self.timer_distance > MIN_TIMER_DISTANCE
    }
}

/// The clocks tried, as multiples of the lattice's tau (`MAX_CLOCK_MULTIPLE`), each once, in
/// increasing order.
fn clock_multiples() -> Vec<f64> {
    let mut r: Vec<(usize, usize)> = (1..=MAX_CLOCK_DIVISOR)
        .flat_map(|i| (i..=MAX_CLOCK_MULTIPLE * i).map(move |j| (j, i)))
        .filter(|&(j, i)| gcd(j, i) == 1)
        .collect();
    r.sort_by(|a, b| (a.0 * b.1).cmp(&(b.0 * a.1)));
    r.into_iter().map(|(j, i)| j as f64 / i as f64).collect()
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// One window prepared for synthesis: its times, true pulse times (from the smoothed speed),
/// its smoothed speed between the edges, its measured readings there sorted and their mean
/// square about the smoothed speed ([`scatter_about`]).
struct Prepared {
    times_s: Vec<f64>,
    pulses: Vec<f64>,
    smooth_middle: Vec<f64>,
    sorted: Vec<f64>,
    measured_scatter: f64,
    noise_rpm: f64,
}

/// Mean square of readings `v` (a window's between the edges) about its smoothed speed: the
/// scatter [`edge_jitter`] compares.
fn scatter_about(v: &[f64], smooth_middle: &[f64]) -> f64 {
    v.iter()
        .zip(smooth_middle)
        .map(|(x, m)| (x - m).powi(2))
        .sum::<f64>()
        / v.len() as f64
}

/// The counter that reads the windows' steady readings best, with its distance and that of the
/// pulse timer of the lattice P tau `p_tau_s` ([`CounterFit::reads_better`] says whether it is
/// the sensor), where that timer does not read them (`MIN_TIMER_DISTANCE`); `noise_rpm` is
/// each window's white noise, `driver` marks the driver shaft's windows, `pulses_per_rev` is
/// the twin's. None where the timer reads them or the windows are too short to tell.
pub(super) fn counter_fit(
    windows: &[ShaftReadings],
    noise_rpm: &[f64],
    driver: &[bool],
    p_tau_s: f64,
    pulses_per_rev: u32,
) -> Option<CounterFit> {
    // At most WINDOWS_PER_SHAFT windows of each shaft; the first of each for the coarse search.
    let shaft = |d: bool| -> Vec<Prepared> {
        windows
            .iter()
            .zip(noise_rpm)
            .zip(driver)
            .filter(|(_, &w)| w == d)
            .filter_map(|((w, &noise), _)| prepare(w, noise, pulses_per_rev))
            .take(WINDOWS_PER_SHAFT)
            .collect()
    };
    let (on_driver, on_driven) = (shaft(true), shaft(false));
    let all: Vec<&Prepared> = on_driver.iter().chain(&on_driven).collect();
    let first: Vec<&Prepared> = on_driver
        .iter()
        .take(1)
        .chain(on_driven.iter().take(1))
        .collect();
    if all.is_empty() {
        return None;
    }
    let tau_s = p_tau_s / pulses_per_rev as f64;
    // A noise-free counter of this clock and gate (a pulse timer for a gate of 0).
    let counter_of = |clock_s: f64, gate_s: f64| SensorModel {
        pulses_per_rev,
        timer_resolution_s: clock_s,
        gate_s,
        speed_noise_rpm: [0.0; 2],
        ..SensorModel::default()
    };
    let distance_on = |set: &[&Prepared], clock_s: f64, gate_s: f64| {
        let sensor = counter_of(clock_s, gate_s);
        let sum: f64 = set.iter().map(|p| window_distance(p, &sensor)).sum();
        sum / set.len() as f64
    };
    let distance = |clock_s: f64, gate_s: f64| distance_on(&all, clock_s, gate_s);
    // The lattice's tau is read to about a per cent where the readings are noisy, more than
    // the levels' tolerance: each hypothesis's clock is refined about its estimate.
    let refined = |clock_s: f64, gate_s: f64| {
        (-CLOCK_REFINE_STEPS..=CLOCK_REFINE_STEPS)
            .map(|i| {
                let c = clock_s * (1.0 + i as f64 * CLOCK_REFINE_STEP);
                (distance(c, gate_s), c)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("steps")
    };
    let (timer_distance, _) = refined(tau_s, 0.0);
    // Readings the timer prints within `MIN_TIMER_DISTANCE` are a timer's whatever a counter
    // reads: no counter is sought.
    if timer_distance <= MIN_TIMER_DISTANCE {
        return None;
    }
    // First every clock on a coarse grid of gates (one window per shaft), then the gate on the
    // fine grid at the clocks that read best; among equals the shorter gate, then the finer
    // clock.
    let clocks = clock_multiples();
    // Per clock, the best coarse gate and its distance.
    let mut by_clock: Vec<(f64, usize, usize)> = clocks
        .par_iter()
        .enumerate()
        .map(|(c, &ratio)| {
            (COARSE_GATE_STEPS..=GATE_STEPS)
                .step_by(COARSE_GATE_STEPS)
                .map(|g| {
                    (
                        distance_on(&first, ratio * tau_s, g as f64 * GATE_STEP_S),
                        c,
                        g,
                    )
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .expect("gates")
        })
        .collect();
    by_clock.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    // The fine gates within a coarse step of each best clock's coarse gate.
    let fine: Vec<(f64, usize, usize)> = by_clock
        .iter()
        .take(FINE_CLOCKS)
        .flat_map(|&(_, c, g)| {
            let lo = g.saturating_sub(COARSE_GATE_STEPS).max(1);
            (lo..=(g + COARSE_GATE_STEPS).min(GATE_STEPS)).map(move |g| (c, g))
        })
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&(c, g)| (distance(clocks[c] * tau_s, g as f64 * GATE_STEP_S), c, g))
        .collect();
    let &(least, _, _) = fine.iter().min_by(|a, b| a.0.total_cmp(&b.0))?;
    // The counters whose levels and shares read the readings alike, each with its clock
    // refined and its jitter read; the one whose scatter reads them best is taken, among
    // equals the shorter gate, then the finer clock.
    let mut tied: Vec<(f64, usize, usize)> = fine
        .into_iter()
        .filter(|f| f.0 <= least + DISTANCE_TIE)
        .collect();
    tied.sort_by(|a, b| a.2.cmp(&b.2).then(a.1.cmp(&b.1)));
    tied.truncate(MAX_TIED);
    let read: Vec<CounterFit> = tied
        .iter()
        .map(|&(_, c, g)| {
            let gate_s = g as f64 * GATE_STEP_S;
            let (distance, clock_s) = refined(clocks[c] * tau_s, gate_s);
            let j = edge_jitter(&[&on_driver, &on_driven], &counter_of(clock_s, gate_s));
            CounterFit {
                gate_s,
                clock_s,
                distance,
                timer_distance,
                edge_jitter_s: j.jitter_s,
                edge_jitter_gain: j.gain,
                scatter_misfit: j.least,
            }
        })
        .collect();
    read.into_iter().reduce(|a, b| {
        if b.scatter_misfit < a.scatter_misfit {
            b
        } else {
            a
        }
    })
}

/// Distance from the nearest counter's within which counters read the readings alike: about
/// the sampling error of [`share_distance`] on two windows of 1 500 readings per shaft. Among
/// such counters (a gate 0.1 ms apart can print the same levels at shares this close) the
/// readings' scatter about their speed decides ([`edge_jitter`]).
const DISTANCE_TIE: f64 = 0.01;
/// Most counters so tied that are read for their scatter.
const MAX_TIED: usize = 6;

/// Edge jitters tried, as shares of the counter's clock: 0, 0.5 %, ... 25 %. A jitter of a
/// quarter of the clock moves a reading to the next level about as often as not; the creep
/// model's 1.5 us on a 40-50 us clock is 3-4 %.
const JITTER_STEP: f64 = 0.005;
const JITTER_STEPS: usize = 50;
/// Draws of the jitter each one is read with (common to all jitters tried, so that the
/// synthesis's scatter moves smoothly with the jitter).
const JITTER_DRAWS: u64 = 4;
/// Least drop of [`edge_jitter`]'s misfit from no jitter to the jitter read for a jitter to be
/// read at all: a tenth in the log of one shaft's mean square, about twice its sampling error
/// (two windows of 1 500 readings; the synthesis's is halved by its four draws) and the misfit
/// a smoothed speed leaves where jitter does not show (up to 7 % on constant speeds).
pub(super) const JITTER_EVIDENCE: f64 = 0.01;

/// The pulse edges' jitter, s, of a counter `sensor` reading the shafts' windows `shafts`, with
/// the drop of the misfit it gives from no jitter. Per shaft, the readings' mean square about
/// their smoothed speed is compared with the synthesis's at each jitter tried; the misfit is the
/// sum over the shafts of the squared log ratio (a method of moments; Casella and Berger,
/// Statistical Inference, 2nd ed. 2002, sec. 7.2.1), and the jitter read the one of least
/// misfit, 0 unless it drops the misfit by `JITTER_EVIDENCE`. A counter's readings stay on its
/// levels (no noise is added after its clock stamps the pulses), and where pulse gap and clock
/// phase drift through each other (most speeds) edge jitter leaves a reading's spread over its
/// levels as it was; where a shaft's pulse gap is near a whole number of ticks the phase locks
/// and its readings hold one level, which the jitter breaks: that shaft reads it (the creep
/// model's fan at 870 rpm on a 50 us clock, 22.99 ticks a gap), the other shaft adds a misfit
/// that does not move with it.
fn edge_jitter(shafts: &[&[Prepared]], sensor: &SensorModel) -> JitterRead {
    let shafts: Vec<&[Prepared]> = shafts.iter().copied().filter(|w| !w.is_empty()).collect();
    let measured: Vec<f64> = shafts
        .iter()
        .map(|w| w.iter().map(|p| p.measured_scatter).sum::<f64>() / w.len() as f64)
        .collect();
    let misfit = |k: usize| -> f64 {
        let jitter_s = k as f64 * JITTER_STEP * sensor.timer_resolution_s;
        shafts
            .iter()
            .zip(&measured)
            .enumerate()
            .map(|(j, (w, m))| {
                let mut sum = 0.0;
                for (i, p) in w.iter().enumerate() {
                    let n = p.times_s.len();
                    for draw in 0..JITTER_DRAWS {
                        let s = SensorModel {
                            edge_jitter_s: jitter_s,
                            seed: 0x71_0000 + 256 * j as u64 + 16 * i as u64 + draw,
                            ..*sensor
                        };
                        let r = read_pulses(&p.pulses, &s, &p.times_s);
                        sum += scatter_about(&r[EDGE..n - EDGE], &p.smooth_middle);
                    }
                }
                (m / (sum / (w.len() as u64 * JITTER_DRAWS) as f64))
                    .ln()
                    .powi(2)
            })
            .sum()
    };
    let misfits: Vec<f64> = (0..=JITTER_STEPS).into_par_iter().map(misfit).collect();
    let (best, least) = misfits
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, &m)| (k, m))
        .expect("jitters tried");
    let gain = misfits[0] - least;
    if gain.is_nan() || gain < JITTER_EVIDENCE {
        return JitterRead {
            jitter_s: 0.0,
            gain: gain.max(0.0),
            least: misfits[0],
        };
    }
    JitterRead {
        jitter_s: best as f64 * JITTER_STEP * sensor.timer_resolution_s,
        gain,
        least,
    }
}

/// What [`edge_jitter`] reads: the jitter, s, the drop of the misfit it gives from none, and
/// the misfit at it.
struct JitterRead {
    jitter_s: f64,
    gain: f64,
    least: f64,
}

/// A window's times, the pulse times of its speed smoothed over 2 SMOOTH_HALF + 1 readings
/// with its own 1x and 2x lines kept,
/// its measured readings sorted (between the edges) and its white noise `noise_rpm`, of the
/// window's middle
/// `READINGS_PER_WINDOW` readings and the edges; None for a window too short.
fn prepare(w: &ShaftReadings, noise_rpm: f64, pulses_per_rev: u32) -> Option<Prepared> {
    let n = w.rpm.len().min(READINGS_PER_WINDOW + 2 * EDGE);
    let start = (w.rpm.len() - n) / 2;
    let rpm = &w.rpm[start..start + n];
    if n < 4 * EDGE || rpm.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return None;
    }
    let times_s: Vec<f64> = (0..n).map(|k| k as f64 / w.sample_rate_hz).collect();
    let mut smooth: Vec<f64> = (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(SMOOTH_HALF), (k + SMOOTH_HALF + 1).min(n));
            rpm[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect();
    // The shaft's own once- and twice-per-revolution lines (a runout's), which the moving
    // average flattens, put back from the residual by projection (the window holds many
    // periods, so the sines are near orthogonal; Bendat and Piersol, Random Data, 4th ed.
    // 2010, sec. 11.1).
    let f1_hz = mean(rpm) / 60.0;
    let residual: Vec<f64> = rpm.iter().zip(&smooth).map(|(x, m)| x - m).collect();
    for h in [1.0, 2.0] {
        let w_rad = 2.0 * std::f64::consts::PI * h * f1_hz;
        let (mut c, mut s) = (0.0, 0.0);
        for (r, t) in residual.iter().zip(&times_s) {
            c += r * (w_rad * t).cos();
            s += r * (w_rad * t).sin();
        }
        let (c, s) = (2.0 * c / n as f64, 2.0 * s / n as f64);
        for (m, t) in smooth.iter_mut().zip(&times_s) {
            *m += c * (w_rad * t).cos() + s * (w_rad * t).sin();
        }
    }
    let middle = &rpm[EDGE..n - EDGE];
    let smooth_middle = smooth[EDGE..n - EDGE].to_vec();
    let mut sorted = middle.to_vec();
    sorted.sort_by(f64::total_cmp);
    Some(Prepared {
        measured_scatter: scatter_about(middle, &smooth_middle),
        smooth_middle,
        pulses: pulse_times(&times_s, &smooth, pulses_per_rev),
        times_s,
        sorted,
        noise_rpm: if noise_rpm.is_finite() {
            noise_rpm
        } else {
            0.0
        },
    })
}

/// Distance of a window's measured readings from those `sensor` reads: [`level_distance`]
/// plus `SHARE_WEIGHT` x [`share_distance`].
fn window_distance(p: &Prepared, sensor: &SensorModel) -> f64 {
    let n = p.times_s.len();
    let mut synthetic = read_pulses(&p.pulses, sensor, &p.times_s)[EDGE..n - EDGE].to_vec();
    synthetic.sort_by(f64::total_cmp);
    level_distance(&p.sorted, &synthetic, p.noise_rpm)
        + SHARE_WEIGHT * share_distance(&p.sorted, &synthetic, p.noise_rpm)
}

/// Weight of [`share_distance`] beside [`level_distance`] in a hypothesis's distance: counters
/// that occupy the same levels (a clock and gate of another ratio can) are told apart by how
/// often they occupy each, which a smoothed speed sets only roughly.
const SHARE_WEIGHT: f64 = 1.0;

/// The largest difference of the two samples' empirical distribution functions, each reading
/// allowed the tolerance of [`level_distance`] (the Kolmogorov-Smirnov distance made tolerant as
/// the Levy distance is; Kendall and Stuart, The Advanced Theory of Statistics II, 1979,
/// sec. 30.60).
fn share_distance(a: &[f64], b: &[f64], noise_rpm: f64) -> f64 {
    let below = |v: &[f64], x: f64| v.partition_point(|&y| y <= x) as f64 / v.len() as f64;
    let one_way = |a: &[f64], b: &[f64]| {
        a.iter()
            .map(|&x| {
                let tol = level_tolerance(x, noise_rpm);
                below(a, x) - below(b, x + tol)
            })
            .fold(0.0_f64, f64::max)
    };
    one_way(a, b).max(one_way(b, a))
}

/// Relative distance within which two readings count as one level in [`level_distance`]:
/// 0.1 %, a tenth of a counter's step at its gate and well above the error of a refined clock.
const LEVEL_TOLERANCE: f64 = 1e-3;
/// Noise sd within which a measured reading counts as on a level.
const LEVEL_NOISE_SD: f64 = 3.0;

/// Distance within which a reading `x` and another are one level (`LEVEL_TOLERANCE`,
/// `LEVEL_NOISE_SD`).
fn level_tolerance(x: f64, noise_rpm: f64) -> f64 {
    (LEVEL_TOLERANCE * x).max(LEVEL_NOISE_SD * noise_rpm)
}

/// How far two sorted samples' levels differ: the share of `measured` readings farther than
/// `tol` from every `synthetic` reading plus the share of `synthetic` readings farther than
/// `tol` from every measured one, `tol` the larger of `LEVEL_TOLERANCE` relative and
/// `LEVEL_NOISE_SD` x the window's white noise `noise_rpm`. Which levels are occupied tells a
/// counter from a timer; how often each is (set by where the true speed falls between two
/// levels, which a smoothed speed places to a fraction of a step only) does not enter.
fn level_distance(measured: &[f64], synthetic: &[f64], noise_rpm: f64) -> f64 {
    let off = |a: &[f64], b: &[f64]| {
        let far = a
            .iter()
            .filter(|&&x| {
                let tol = level_tolerance(x, noise_rpm);
                let i = b.partition_point(|&y| y < x - tol);
                !(i < b.len() && b[i] <= x + tol)
            })
            .count();
        far as f64 / a.len().max(1) as f64
    };
    off(measured, synthetic) + off(synthetic, measured)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_share_distance_of_equal_samples_is_zero_and_of_disjoint_ones_one() {
        let a = [1000.0, 1010.0, 1020.0];
        assert_eq!(share_distance(&a, &a, 0.0), 0.0);
        assert_eq!(share_distance(&a, &[1100.0, 1200.0], 0.0), 1.0);
        // Half of b below all of a: at b's first reading F_b is 1/2 and F_a 0.
        assert!((share_distance(&a, &[900.0, 1020.0], 0.0) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn readings_on_the_same_levels_are_near_whatever_their_shares() {
        let a = [1000.0, 1000.0, 1000.0, 1010.0];
        let b = [1000.0, 1010.0, 1010.0, 1010.0];
        assert_eq!(level_distance(&a, &b, 0.0), 0.0);
        // A level within the tolerance (1 rpm at 1000 rpm) is the same level; one beyond it,
        // or beyond three noise sd, is not.
        assert_eq!(level_distance(&a, &[1000.9, 1010.9], 0.0), 0.0);
        assert_eq!(level_distance(&a, &[1000.0, 1012.0], 0.0), 0.25 + 0.5);
        assert_eq!(level_distance(&a, &[1000.0, 1012.0], 1.0), 0.0);
        // A level the measurement never shows counts against the synthesis.
        assert_eq!(
            level_distance(&a, &[1000.0, 1010.0, 1020.0, 1020.0], 0.0),
            0.5
        );
    }
}
