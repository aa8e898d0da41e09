//! Stage "sensor": the tachometer identified from the recordings before any mechanics is
//! judged, so that the twin is read through the sensor the measurement was taken with and a
//! sensor difference never shows up as a mechanical gap (docs/decisions/sensor-first.md).
//!
//! A recording holds speeds (rpm) at sample times, not pulse times. What they reveal of a pulse
//! tachometer (`crate::sensor`: P pulses per revolution, a timer of resolution tau, missing
//! pulses bridged, white noise added per sample):
//! - **P tau**, from the lattice of levels 60 / (P tau k) the readings sit on
//!   (`features::timer_lattice_s`); P and tau apart only with the pulse rate below.
//! - **The pulse rate** n P / 60, from the readings' hold: a reading changes only when a
//!   pulse arrives, so where pulses come at most every third sample and the reading moves
//!   from pulse to pulse (a timer lattice, a speed ripple), the variogram of the readings rises
//!   linearly over one pulse period and bends there ([`hold_samples`]). Faster pulses, or
//!   readings that do not change from pulse to pulse, leave no trace of P, and then the
//!   readings do not depend on it either.
//! - **The white noise**, about the lattice levels where there is a lattice, else from the
//!   first differences (`features::noise_sd`).
//! - **Missing pulses**, where there is a lattice: a gap bridged over two pulses is read as
//!   half its tick count, which is odd (a reading half-way between two levels) with a
//!   probability set by where the true gap sits between two tick counts ([`missing_share`]).
//!   Without a lattice a bridged gap reads the true mean speed and leaves no trace.
//! - **A counter's gate**, where there is a lattice: a counter by the M/T method prints the
//!   lattice of a timer of clock / m, m the whole gaps its gate holds, which differs between
//!   the shafts; counters are tried against the lattice's pulse timer by which levels they
//!   print (`super::sensor_counter`), and where one prints the measured levels and the timer
//!   does not, the twin is read through it.
//! - **The white noise's shape**, its excess kurtosis per shaft, where neither a lattice nor a
//!   hold shapes the readings' steps ([`noise_kurtosis`]): a sensor whose scatter changes
//!   from reading to reading (a counter whose count of whole pulse gaps alternates) reads with
//!   heavier tails than Gaussian noise, and the twin is then read through a noise of that
//!   shape (`crate::sensor::SensorModel::noise_excess_kurtosis`).

use fom::stats::{mean, median, quantile_unsorted, Z90};
use serde::Serialize;

use fom::DriveConfig;

use super::baseline::LabelTwin;
use super::features::{
    excess_kurtosis, noise_sd, steady_speeds, timer_lattice_s, Read, SteadySpeeds, ACF_LAGS,
};
use super::sensor_counter::{counter_fit, CounterFit, JITTER_EVIDENCE};
use crate::measured::DataSet;
use crate::sensor::SensorModel;

/// Largest lag of the variogram, samples: holds up to half of it are found.
const MAX_LAG: usize = 40;
/// Relative change of the variogram's step that ends its first line (a hold's bend).
const BEND: f64 = 0.3;
/// Least share of the windows read that must show a hold for the pulses per revolution to be
/// read from it.
const MIN_HOLD_SHARE: f64 = 0.5;
/// Least hold, samples, resolved: a first line needs two lags before the bend.
const MIN_HOLD: f64 = 2.5;
/// Largest noise of a reading's tick count (sd, ticks) at which a reading half-way between two
/// levels is told from one on a level (a reading more than 0.3 tick off a level: 3 sd).
const MAX_TICK_NOISE: f64 = 0.1;
/// Least probability that a bridged gap reads off the lattice for the missing-pulse share to
/// be read (near a level, bridged gaps read on it and hide).
const MIN_ODD: f64 = 0.15;
/// Second differences per batch of the noise shape's estimate: the local noise level is
/// taken as constant over a batch (a second at 1 kHz). Sample kurtoses of shorter batches
/// average low for heavy tails (a mixture's share of scales varies from batch to batch).
const SHAPE_BATCH: usize = 1000;
/// Fewest second differences in a window for its noise shape to be read.
const MIN_SHAPE_READINGS: usize = 200;
/// Sum over all lags of the fourth powers of the autocorrelation of white noise's second
/// differences (rho_1 = -2/3, rho_2 = 1/6): the factor by which their sample kurtosis varies
/// more than that of independent samples, Var = 24 / n x this (Bartlett's formula for the
/// fourth moment of a Gaussian linear process; Priestley, Spectral Analysis and Time Series,
/// 1981, sec. 5.3).
const D2_KURTOSIS_VARIANCE_FACTOR: f64 = 1.0 + 2.0 * (16.0 / 81.0 + 1.0 / 1296.0);

/// One shaft's steady readings.
pub struct ShaftReadings<'a> {
    pub sample_rate_hz: f64,
    pub rpm: &'a [f64],
}

/// What the readings say about the tachometer (see the module's text for what they can say).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IdentifiedSensor {
    /// Pulses per revolution, from the pulse rate; `None` where the readings hold no trace of
    /// it.
    pub pulses_per_rev: Option<u32>,
    /// The estimate before rounding and its 90 % interval over the windows it was read in
    /// (NaN with one window).
    pub pulses_per_rev_estimate: f64,
    pub pulses_per_rev_interval90: [f64; 2],
    /// Windows (shaft x recording) in which the hold was found, of all read.
    pub pulses_per_rev_windows: [usize; 2],
    /// P tau from the readings' lattice, s, with its 90 % interval; `None` without a lattice.
    pub pulses_x_timer_s: Option<f64>,
    pub pulses_x_timer_interval90: [f64; 2],
    /// The timer's resolution, s: P tau over P where both are read; `None` otherwise.
    pub timer_resolution_s: Option<f64>,
    /// White noise of the driver's and the driven speed, rpm (median over the recordings).
    pub speed_noise_rpm: [f64; 2],
    /// Per shaft, the recordings' scatter about a 7-reading moving average over their white
    /// noise, mean over the labels (`features::noise_scatter`: 1 for white noise; above
    /// `features::CORRELATED_NOISE_RATIO` the noise is taken as correlated over a few
    /// readings, as a counter's whose gate spans readings).
    pub speed_noise_scatter_ratio: [f64; 2],
    /// Where a shaft's noise is correlated, the white noise the twin is read with there
    /// instead of `speed_noise_rpm`: the readings' scatter about their 20 ms moving average
    /// (mean over the labels); `None` where the noise is white. Both filled in with the label
    /// twins (`with_correlated_noise`).
    pub speed_noise_correlated_rpm: [Option<f64>; 2],
    /// Where a shaft's noise is correlated, the readings' autocorrelation at lags 1-8 (mean over
    /// the labels, `features::noise_scatter`), which the twin's noise is filtered to
    /// (`crate::sensor::noise_taps_for`); `None` where the noise is white.
    pub speed_noise_autocorrelation: [Option<[f64; ACF_LAGS]>; 2],
    /// Share of missing pulses where a lattice shows them, with its 90 % interval (from the
    /// count of readings off the lattice, Poisson); `None` otherwise.
    pub missing_pulse_share: Option<f64>,
    pub missing_pulse_share_interval90: [f64; 2],
    /// Excess kurtosis of the white noise of the driver's and the driven speed with its 90 %
    /// interval ([`noise_kurtosis`]); NaN where a lattice or a hold shapes every window's
    /// readings.
    pub noise_excess_kurtosis: [f64; 2],
    pub noise_excess_kurtosis_interval90: [[f64; 2]; 2],
    /// The sensor the twin is read through: each identified setting, the configuration's
    /// where the readings say nothing.
    pub twin_pulses_per_rev: u32,
    pub twin_timer_resolution_s: f64,
    pub twin_missing_pulse_share: f64,
    /// The counter by the M/T method that reads the recordings best where a lattice was read
    /// and its pulse timer does not print the readings' levels, with its distance from them
    /// and the timer's (`sensor_counter::counter_fit`); `None` without a lattice or where the
    /// timer prints them.
    pub counter_tried: Option<CounterFit>,
    /// That counter where it reads the readings' levels much better than the pulse timer
    /// (`CounterFit::reads_better`): the sensor is then taken as a counter.
    pub counter: Option<CounterFit>,
    /// The counting gate the twin is read with, s (0: the speed from the last pulse gap).
    pub twin_gate_s: f64,
    /// The jitter of each pulse edge the twin is read with, s: a counter's
    /// (`CounterFit::edge_jitter_s`), 0 otherwise (a pulse timer's scatter is read as white
    /// noise about its levels).
    pub twin_edge_jitter_s: f64,
    /// Excess kurtosis of the white noise the twin's readings get per shaft, as its second
    /// differences read it (0: Gaussian, where the interval holds 0 or the kurtosis is
    /// negative, which no scale mixture gives).
    pub twin_noise_excess_kurtosis: [f64; 2],
    /// Per setting, "identified", "bounded" or "not identifiable from speed readings", and
    /// how.
    pub confidence: Vec<String>,
}

impl IdentifiedSensor {
    /// Whether the readings showed a sensor's own structure: a timer's lattice, the pulses per
    /// revolution (the readings' hold) or missing pulses. Without it a tachometer model has
    /// nothing of its own to be named by in `rom gap` (docs/decisions/sensor-first.md).
    pub fn read_structure(&self) -> bool {
        self.pulses_per_rev.is_some()
            || self.pulses_x_timer_s.is_some()
            || self.timer_resolution_s.is_some()
            || self.missing_pulse_share.is_some()
            || self.counter.is_some()
    }

    /// This sensor with `speed_noise_scatter_ratio`, `speed_noise_correlated_rpm` and
    /// `speed_noise_autocorrelation` from the label twins' measurements and noise
    /// (`features::mean_scatter_ratio`, `correlated_noise`, `mean_scatter_acf`).
    pub(super) fn with_correlated_noise(mut self, twins: &[LabelTwin]) -> Self {
        self.speed_noise_scatter_ratio =
            super::features::mean_scatter_ratio(twins.iter().map(|lt| &lt.measured));
        let mean = |v: Vec<f64>| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
        self.speed_noise_correlated_rpm = [0, 1].map(|j| {
            mean(
                twins
                    .iter()
                    .filter(|lt| lt.noise_correlated[j])
                    .map(|lt| lt.noise_rpm[j])
                    .collect(),
            )
        });
        let acf = super::features::mean_scatter_acf(twins.iter().map(|lt| &lt.measured));
        self.speed_noise_autocorrelation = [0, 1].map(|j| {
            twins
                .iter()
                .any(|lt| lt.noise_taps[j].is_some())
                .then_some(acf[j])
        });
        self
    }

    /// Whether the twin's sensor differs from the configuration's.
    pub fn differs_from(&self, own: &SensorModel) -> bool {
        self.twin_pulses_per_rev != own.pulses_per_rev
            || self.twin_timer_resolution_s != own.timer_resolution_s
            || self.twin_missing_pulse_share != own.missing_pulse_share
            || self.twin_gate_s != own.gate_s
            || self.twin_edge_jitter_s != own.edge_jitter_s
    }

    /// One line for the text report.
    pub fn summary(&self) -> String {
        let p = self.pulses_per_rev.map_or("not read".to_string(), |p| {
            format!(
                "{p} [{:.1}, {:.1}]",
                self.pulses_per_rev_interval90[0], self.pulses_per_rev_interval90[1]
            )
        });
        let c = self.pulses_x_timer_s.map_or("no lattice".to_string(), |c| {
            format!(
                "{c:.3e} s [{:.3e}, {:.3e}]",
                self.pulses_x_timer_interval90[0], self.pulses_x_timer_interval90[1]
            )
        });
        let m = self
            .missing_pulse_share
            .map_or("not read".to_string(), |q| {
                format!(
                    "{:.1} % [{:.1}, {:.1}]",
                    100.0 * q,
                    100.0 * self.missing_pulse_share_interval90[0],
                    100.0 * self.missing_pulse_share_interval90[1]
                )
            });
        let k = |i: usize| {
            let [lo, hi] = self.noise_excess_kurtosis_interval90[i];
            if self.noise_excess_kurtosis[i].is_nan() {
                "not read".to_string()
            } else {
                format!("{:+.2} [{lo:+.2}, {hi:+.2}]", self.noise_excess_kurtosis[i])
            }
        };
        let shape = match self.twin_noise_excess_kurtosis {
            [a, b] if a == 0.0 && b == 0.0 => "Gaussian noise".to_string(),
            [a, b] => {
                format!("noise of excess kurtosis {a:.2} / {b:.2} (a Gaussian scale mixture)")
            }
        };
        let correlated: Vec<String> = self
            .speed_noise_correlated_rpm
            .iter()
            .zip(["driver", "driven"])
            .zip(&self.speed_noise_autocorrelation)
            .filter_map(|((n, shaft), acf)| {
                let acf = acf.map_or(String::new(), |a| {
                    format!(", lags 1-3 {:+.2} {:+.2} {:+.2}", a[0], a[1], a[2])
                });
                n.map(|n| format!("{shaft} {n:.2} rpm{acf}"))
            })
            .collect();
        let correlated = if correlated.is_empty() {
            String::new()
        } else {
            format!(
                " (noise correlated over readings, as a counter's gate gives, read at its \
                 scatter and autocorrelation: {})",
                correlated.join(", ")
            )
        };
        format!(
            "pulses per revolution {p}; P x timer {c}; white noise {:.2} / {:.2} rpm (driver / \
             driven), excess kurtosis {} / {}; missing pulses {m}; the twin read through {} \
             pulses per revolution, {}, {:.1} % of pulses missing, {shape}{correlated}",
            self.speed_noise_rpm[0],
            self.speed_noise_rpm[1],
            k(0),
            k(1),
            self.twin_pulses_per_rev,
            if self.twin_gate_s > 0.0 {
                format!(
                    "a counter of {:.1} ms gate on a clock of {:.3e} s, edges jittered by \
                     {:.2} us",
                    1e3 * self.twin_gate_s,
                    self.twin_timer_resolution_s,
                    1e6 * self.twin_edge_jitter_s
                )
            } else if self.twin_timer_resolution_s > 0.0 {
                format!("a timer of {:.3e} s", self.twin_timer_resolution_s)
            } else {
                "an exact timer".to_string()
            },
            100.0 * self.twin_missing_pulse_share
        )
    }
}

/// The sensor of a data set's usable labels: every recording's steady window (the one
/// steady-state definition, `features::steady_speeds`), both shafts.
pub fn identify_data_set(
    set: &DataSet,
    labels: &[String],
    ratio: f64,
    cfg: &DriveConfig,
) -> IdentifiedSensor {
    let speeds: Vec<SteadySpeeds> = labels
        .iter()
        .flat_map(|l| set.runs_of(l))
        .filter_map(|i| steady_speeds(&set.recordings[i], ratio, Read::Own).ok())
        .collect();
    let windows: Vec<ShaftReadings> = speeds
        .iter()
        .flat_map(|s| {
            [&s.driver_rpm, &s.driven_rpm].map(|rpm| ShaftReadings {
                sample_rate_hz: 1.0 / s.dt_s,
                rpm,
            })
        })
        .collect();
    let driver: Vec<bool> = (0..windows.len()).map(|k| k % 2 == 0).collect();
    identify(&windows, &driver, &SensorModel::from_config(cfg))
}

/// Identifies the sensor from steady readings of the recordings (driver and driven shafts);
/// `own` is the configuration's sensor, kept where the readings say nothing.
pub fn identify(windows: &[ShaftReadings], driver: &[bool], own: &SensorModel) -> IdentifiedSensor {
    let window_lattice: Vec<f64> = windows.iter().map(|w| timer_lattice_s(w.rpm)).collect();
    let holds: Vec<Option<f64>> = windows.iter().map(|w| hold_samples(w.rpm)).collect();
    // Each window's lattice, then the lattice all of them print together.
    let (on_lattice, lattices): (Vec<&[f64]>, Vec<f64>) = windows
        .iter()
        .zip(&window_lattice)
        .filter(|(_, c)| **c > 0.0)
        .map(|(w, &c)| (w.rpm, refine_lattice(&[w.rpm], c)))
        .unzip();
    let lattice =
        (!lattices.is_empty()).then(|| refine_lattice(&on_lattice, median(lattices.clone())));
    // Each window's readings on that lattice, for its white noise and its missing pulses.
    let window_c: Vec<Option<f64>> = windows
        .iter()
        .map(|w| lattice.map(|c| refine_lattice(&[w.rpm], c)))
        .collect();
    let rel = super::features::LATTICE_RELATIVE_SE / (lattices.len().max(1) as f64).sqrt();
    let pulses: Vec<f64> = windows
        .iter()
        .zip(&holds)
        .filter_map(|(w, h)| {
            let h = (*h)?;
            Some(60.0 * w.sample_rate_hz / (mean(w.rpm) * h))
        })
        .collect();
    let (p_est, p_int) = spread_interval(&pulses);
    // A hold in a few windows only is a slow ripple's or a lattice's chance pattern, not the
    // pulse rate: a sensor's pulses show in every window whose speed lets them.
    let held = !pulses.is_empty() && pulses.len() as f64 >= MIN_HOLD_SHARE * windows.len() as f64;
    let pulses_per_rev = held.then(|| p_est.round().max(1.0) as u32);
    let noise: Vec<f64> = windows
        .iter()
        .zip(&window_c)
        .map(|(w, &c)| white_noise(w.rpm, c))
        .collect();
    let noise_of = |is_driver: bool| {
        let v: Vec<f64> = noise
            .iter()
            .zip(driver)
            .filter(|(_, &d)| d == is_driver)
            .map(|(n, _)| *n)
            .collect();
        if v.is_empty() {
            f64::NAN
        } else {
            median(v)
        }
    };
    // Pooled over the windows that read it: readings off the lattice over their expected
    // count per missing pulse.
    let read: Vec<(f64, f64, f64)> = windows
        .iter()
        .zip(&window_c)
        .filter_map(|(w, c)| missing_share(w.rpm, (*c)?))
        .collect();
    let (off, expected, pulses_off) = read
        .iter()
        .fold((0.0, 0.0, 0.0), |(a, b, c), x| (a + x.0, b + x.1, c + x.2));
    let missing = (!read.is_empty()).then(|| off / expected);
    let missing_interval = missing.map_or([f64::NAN; 2], |q| {
        let rel = Z90 / pulses_off.max(1.0).sqrt();
        [(q * (1.0 - rel)).max(0.0), q * (1.0 + rel)]
    });
    let timer = lattice.zip(pulses_per_rev).map(|(c, p)| c / p as f64);
    let twin_pulses = pulses_per_rev.unwrap_or(own.pulses_per_rev);
    let counter_tried = lattice.and_then(|c| counter_fit(windows, &noise, driver, c, twin_pulses));
    let counter = counter_tried.filter(CounterFit::reads_better);
    let mut confidence = settings_confidence(
        (pulses_per_rev, pulses.len(), windows.len()),
        (lattice, timer),
        counter,
        missing,
    );
    // The noise's shape, per shaft, where no lattice or hold shapes a window's steps.
    let shapes: Vec<(f64, [f64; 2])> = [true, false]
        .iter()
        .map(|&d| {
            let free: Vec<&[f64]> = (0..windows.len())
                .filter(|&i| driver[i] == d && window_lattice[i] == 0.0 && holds[i].is_none())
                .map(|i| windows[i].rpm)
                .collect();
            noise_kurtosis(&free)
        })
        .collect();
    let twin_kurtosis = shapes
        .iter()
        .map(|shape| if heavy_tailed(shape) { shape.0 } else { 0.0 });
    for (shape, shaft) in shapes.iter().zip(["driver", "driven"]) {
        confidence.push(shape_confidence(shaft, shape));
    }
    IdentifiedSensor {
        pulses_per_rev,
        pulses_per_rev_estimate: if pulses.is_empty() { f64::NAN } else { p_est },
        pulses_per_rev_interval90: p_int,
        pulses_per_rev_windows: [pulses.len(), windows.len()],
        pulses_x_timer_s: lattice,
        pulses_x_timer_interval90: lattice.map_or([f64::NAN; 2], |c| {
            [c * (1.0 - Z90 * rel), c * (1.0 + Z90 * rel)]
        }),
        timer_resolution_s: timer,
        speed_noise_rpm: [noise_of(true), noise_of(false)],
        speed_noise_scatter_ratio: [f64::NAN; 2],
        speed_noise_correlated_rpm: [None; 2],
        speed_noise_autocorrelation: [None; 2],
        missing_pulse_share: missing,
        missing_pulse_share_interval90: missing_interval,
        twin_pulses_per_rev: twin_pulses,
        twin_timer_resolution_s: match counter {
            Some(k) => k.clock_s,
            None => lattice.map_or(own.timer_resolution_s, |c| c / twin_pulses as f64),
        },
        twin_missing_pulse_share: match counter {
            Some(_) => own.missing_pulse_share,
            None => missing.unwrap_or(own.missing_pulse_share).min(0.45),
        },
        counter_tried,
        counter,
        twin_gate_s: counter.map_or(own.gate_s, |k| k.gate_s),
        twin_edge_jitter_s: counter.map_or(own.edge_jitter_s, |k| k.edge_jitter_s),
        noise_excess_kurtosis: [shapes[0].0, shapes[1].0],
        noise_excess_kurtosis_interval90: [shapes[0].1, shapes[1].1],
        twin_noise_excess_kurtosis: twin_kurtosis.collect::<Vec<_>>().try_into().expect("two"),
        confidence,
    }
}

/// The confidence lines of the pulses per revolution (read, and held in `held` of `windows`),
/// the timer (the lattice's P tau, tau), a counter taken and the missing-pulse share.
fn settings_confidence(
    (pulses_per_rev, held, windows): (Option<u32>, usize, usize),
    (lattice, timer): (Option<f64>, Option<f64>),
    counter: Option<CounterFit>,
    missing: Option<f64>,
) -> Vec<String> {
    let mut confidence = vec![match pulses_per_rev {
        Some(_) => format!(
            "pulses per revolution identified from the readings' hold in {held} of {windows} \
             windows"
        ),
        None if held > 0 => format!(
            "pulses per revolution not identifiable from speed readings: a hold in only {held} \
             of {windows} windows; the configuration's value kept"
        ),
        None => "pulses per revolution not identifiable from speed readings: no hold (pulses \
                 faster than every third sample, or readings unchanged from pulse to pulse); \
                 the configuration's value kept"
            .to_string(),
    }];
    confidence.push(match (lattice, timer) {
        (Some(_), Some(_)) => "timer identified: the lattice's P tau over P; the twin read at \
                               the measured speeds for the cells the lattice shapes"
            .into(),
        (Some(_), None) => "timer bounded: P tau from the lattice, tau for the configuration's \
                            P; the twin read at the measured speeds for the cells the lattice \
                            shapes"
            .to_string(),
        (None, _) => {
            "timer not identifiable: no lattice in the readings; the configuration's value \
             kept"
                .to_string()
        }
    });
    if let Some(k) = counter {
        confidence.push(format!(
            "counter identified: the readings occupy the levels of a counter by the M/T method \
             (gate {:.1} ms, clock {:.3e} s; distance {:.2} from its readings, {:.2} from the \
             lattice's pulse timer's), its pulse edges jittered by {:.2} us (read from the \
             readings' scatter about their speed; misfit {:.3} lower than without jitter, \
             read where {JITTER_EVIDENCE} or more); the twin read through it",
            1e3 * k.gate_s,
            k.clock_s,
            k.distance,
            k.timer_distance,
            1e6 * k.edge_jitter_s,
            k.edge_jitter_gain,
        ));
    }
    confidence.push(match missing {
        Some(_) if counter.is_some() => "missing pulses not read: the readings off the \
                                          lattice are the counter's changing count of gaps; the \
                                          configuration's value kept"
            .into(),
        Some(_) => "missing pulses identified from the readings off the lattice".into(),
        None => "missing pulses not identifiable without a lattice; the \
                 configuration's value kept"
            .into(),
    });
    confidence
}

/// Standard errors by which a noise's excess kurtosis must exceed 0 for the twin to be read
/// through a scale mixture: 3.09, one-sided 0.1 %, so that Gaussian noise is taken for a
/// mixture on one shaft in a thousand, not in twenty as the 90 % interval's lower end would.
const SHAPE_EVIDENCE_SE: f64 = 3.09;

/// Whether a shaft's noise shape (`noise_kurtosis`'s estimate and 90 % interval) is heavier-tailed
/// than Gaussian beyond `SHAPE_EVIDENCE_SE`.
fn heavy_tailed(&(k, [lo, _]): &(f64, [f64; 2])) -> bool {
    let se = (k - lo) / Z90;
    k.is_finite() && se > 0.0 && k > SHAPE_EVIDENCE_SE * se
}

/// The confidence line of a shaft's noise shape (`noise_kurtosis`'s estimate and interval).
fn shape_confidence(shaft: &str, shape: &(f64, [f64; 2])) -> String {
    let &(k, [lo, hi]) = shape;
    if k.is_nan() {
        format!(
            "noise shape on the {shaft} shaft not identifiable: a timer lattice or a hold \
             shapes every window's steps; Gaussian"
        )
    } else if heavy_tailed(shape) {
        format!(
            "noise shape on the {shaft} shaft identified from the readings' second \
             differences: excess kurtosis {k:+.2} [{lo:+.2}, {hi:+.2}]; the twin's noise a \
             Gaussian scale mixture"
        )
    } else if hi < 0.0 {
        format!(
            "noise shape on the {shaft} shaft lighter-tailed than Gaussian: excess kurtosis \
             {k:+.2} [{lo:+.2}, {hi:+.2}], which no scale mixture gives; Gaussian"
        )
    } else {
        format!(
            "noise shape on the {shaft} shaft Gaussian: excess kurtosis {k:+.2} [{lo:+.2}, \
             {hi:+.2}] within {SHAPE_EVIDENCE_SE} standard errors of 0"
        )
    }
}

/// Excess kurtosis of the white noise of readings `windows` (rpm) and its 90 % interval, from
/// their second differences, each window read apart (recordings differ in noise level, and
/// pooling levels would itself make a scale mixture). Second differences take slow motion
/// out: a line at f is scaled by 4 sin^2(pi f / fs), 0.016 at 20 Hz and 0.5 at 116 Hz of
/// 1 kHz readings, the white noise by sqrt 6 in sd. For noise e_t = s_t z_t, a Gaussian scale
/// mixture (z_t iid N(0, 1); Andrews and Mallows, J. R. Stat. Soc. B 36, 1974) of excess
/// kurtosis k whose variance s_t^2 has lag correlations rho_1 and rho_2, the second
/// differences' excess kurtosis is k (9 + 8 rho_1 + rho_2) / 18 (fourth cumulants of
/// independent terms add: Kendall and Stuart, The Advanced Theory of Statistics I, 1977,
/// sec. 3.13): k / 2 for a scale drawn anew at each reading, as for iid terms, k for a scale
/// that changes slowly against the readings, as a counter's count of whole pulse gaps does.
/// The estimate is the second differences' own; the twin is read through noise whose second
/// differences show the same (`crate::sensor::noise_kurtosis_for_second_differences`). The
/// mean over batches of about `SHAPE_BATCH`; its standard error the larger of the batches'
/// spread and Gaussian noise's (`D2_KURTOSIS_VARIANCE_FACTOR`). NaN without a batch.
pub fn noise_kurtosis(windows: &[&[f64]]) -> (f64, [f64; 2]) {
    let read: usize = windows
        .iter()
        .map(|w| w.len().saturating_sub(2))
        .filter(|&n| n >= MIN_SHAPE_READINGS)
        .sum();
    let batches: Vec<f64> = windows
        .iter()
        .flat_map(|w| {
            let d2: Vec<f64> = w.windows(3).map(|x| x[2] - 2.0 * x[1] + x[0]).collect();
            let size = d2.len() / (d2.len() / SHAPE_BATCH).max(1);
            let whole: Vec<f64> = if d2.len() < MIN_SHAPE_READINGS {
                Vec::new()
            } else {
                d2.chunks_exact(size).map(excess_kurtosis).collect()
            };
            whole
        })
        .filter(|k| k.is_finite())
        .collect();
    if batches.is_empty() {
        return (f64::NAN, [f64::NAN; 2]);
    }
    let k = mean(&batches);
    let n = batches.len() as f64;
    let null = (24.0 * D2_KURTOSIS_VARIANCE_FACTOR / read as f64).sqrt();
    let spread = if batches.len() > 1 {
        fom::stats::sample_std(&batches) / n.sqrt()
    } else {
        0.0
    };
    let se = null.max(spread);
    (k, [k - Z90 * se, k + Z90 * se])
}

/// Median of estimates and its 90 % interval (normal, over the estimates' spread; NaN with
/// fewer than two).
fn spread_interval(v: &[f64]) -> (f64, [f64; 2]) {
    if v.is_empty() {
        return (f64::NAN, [f64::NAN; 2]);
    }
    let m = median(v.to_vec());
    if v.len() < 2 {
        return (m, [f64::NAN; 2]);
    }
    let se = fom::stats::sample_std(v) / (v.len() as f64).sqrt();
    (m, [m - Z90 * se, m + Z90 * se])
}

/// Least-squares line a + b h through the variogram `v` (V(h) at v[h - 1]) over `lags`.
fn line(v: &[f64], lags: std::ops::RangeInclusive<usize>) -> (f64, f64) {
    let h: Vec<f64> = lags.clone().map(|h| h as f64).collect();
    let y: Vec<f64> = lags.map(|h| v[h - 1]).collect();
    let (mh, my) = (mean(&h), mean(&y));
    let sxy: f64 = h.iter().zip(&y).map(|(a, b)| (a - mh) * (b - my)).sum();
    let sxx: f64 = h.iter().map(|a| (a - mh).powi(2)).sum();
    let b = sxy / sxx;
    (my - b * mh, b)
}

/// The hold of a reading, samples: where the readings' variogram first bends. A reading
/// changes only at pulses, a pulse period H apart and uniformly placed against the samples,
/// so V(h) = 2 s^2 + D_1 h / H for h <= H (s: the white noise, D_1: the mean square change
/// from one pulse to the next) and linear again, with another slope, up to 2H. The first lag
/// where the variogram's step leaves its first step by `BEND` ends the first line; H is where
/// it meets the line after. `None` where the variogram does not start as a rising line
/// (white noise, a smooth speed), does not bend, or the first pulse's change does not stand
/// out of the noise (D_1 below s^2). Holds shorter than three samples are not resolved.
pub fn hold_samples(rpm: &[f64]) -> Option<f64> {
    if rpm.len() < 20 * MAX_LAG {
        return None;
    }
    // Slow motion out: minus a centred moving mean over 2 MAX_LAG + 1 samples.
    let w = MAX_LAG;
    let y: Vec<f64> = (0..rpm.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(w), (i + w + 1).min(rpm.len()));
            rpm[i] - mean(&rpm[a..b])
        })
        .collect();
    let v: Vec<f64> = (1..=MAX_LAG)
        .map(|h| {
            mean(
                &y.windows(h + 1)
                    .map(|p| (p[h] - p[0]).powi(2))
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    // step(h) = V(h + 1) - V(h).
    let step = |h: usize| v[h] - v[h - 1];
    let first = step(1);
    if first <= 0.0 {
        return None;
    }
    let bend = (2..MAX_LAG - 3).find(|&h| (step(h) - first).abs() > BEND * first)?;
    let (a1, b1) = line(&v, 1..=bend);
    let (a2, b2) = line(&v, bend + 2..=(2 * bend - 1).max(bend + 3).min(MAX_LAG));
    // A hold bends the variogram down (the change over two pulses is at most twice that over
    // one, less where the pulses' readings do not wander); a smooth speed bends it up.
    if bend < 3 || b2 > (1.0 - BEND) * b1 {
        return None;
    }
    let hold = (a2 - a1) / (b1 - b2);
    let consistent = hold >= bend as f64 - 1.0 && hold <= bend as f64 + 1.5;
    (consistent && hold >= MIN_HOLD && b1 * hold > 0.5 * a1).then_some(hold)
}

/// The lattice P tau (s) near `c` (within 3 %, its spread over timers) on which the readings
/// of `windows` sit best together: where their tick counts 60 / (c n) lie closest to whole
/// numbers, by the sum over the windows of the mean cosine of their phases 2 pi 60 / (c n)
/// (Mardia and Jupp, Directional Statistics, 2000, sec. 3.4). The lattice's spacing gives P tau
/// to about 2 %, too coarse to tell which whole tick count a reading of ~100 ticks sits on; the
/// phases pin it to a lattice the readings print. Lattices one tick count apart print nearly
/// the same levels; of those within 2 % of the best fit, the nearest to `c` is kept. One
/// shaft's readings cannot tell its lattices one tick count apart, and on the slower shaft
/// (twice the ticks) one of them lies half a tick off the faster shaft's levels: read
/// together, the shafts' lattices agree only where both print their readings.
fn refine_lattice(windows: &[&[f64]], c: f64) -> f64 {
    let xs: Vec<Vec<f64>> = windows
        .iter()
        .map(|rpm| {
            let step = (rpm.len() / 2000).max(1);
            rpm.iter()
                .step_by(step)
                .copied()
                .filter(|&x| x > 0.0)
                .collect()
        })
        .filter(|x: &Vec<f64>| !x.is_empty())
        .collect();
    let fit = |c: f64| xs.iter().map(|x| lattice_phase(x, c)).sum::<f64>();
    let tried: Vec<(f64, f64)> = (-600..=600)
        .map(|k| c * (1.0 + 5e-5 * k as f64))
        .map(|c| (c, fit(c)))
        .collect();
    let best = tried.iter().map(|x| x.1).fold(f64::NEG_INFINITY, f64::max);
    tried
        .iter()
        .filter(|x| x.1 >= best - 0.02 * best.abs())
        .min_by(|a, b| (a.0 - c).abs().total_cmp(&(b.0 - c).abs()))
        .map_or(c, |x| x.0)
}

/// How well the lattice P tau `c` prints the readings `rpm`: the mean cosine of their tick
/// counts' phases 2 pi 60 / (c n) (1: every reading on one of its levels, -1: every reading
/// half-way between two; Mardia and Jupp, Directional Statistics, 2000, sec. 3.4).
fn lattice_phase(rpm: &[f64], c: f64) -> f64 {
    rpm.iter()
        .map(|&n| (2.0 * std::f64::consts::PI * 60.0 / (c * n)).cos())
        .sum::<f64>()
        / rpm.len() as f64
}

/// The white noise of readings, rpm: with a lattice P tau `lattice`, the robust sd of each
/// reading about its nearest level (the MAD, Hampel 1974); else from first differences.
fn white_noise(rpm: &[f64], lattice: Option<f64>) -> f64 {
    match lattice {
        Some(c) => {
            let r: Vec<f64> = rpm
                .iter()
                .filter(|&&x| x > 0.0)
                .map(|&x| x - 60.0 / (c * (60.0 / (c * x)).round()))
                .collect();
            let abs: Vec<f64> = r.iter().map(|x| x.abs()).collect();
            quantile_unsorted(&abs, 0.5) / 0.6745
        }
        None => noise_sd(rpm),
    }
}

/// Share of missing pulses from readings on a lattice P tau `c`: each reading's tick count
/// u = 60 / (c n) is whole for a single gap and, for a gap bridged over two pulses, odd halves
/// with probability 1 - |1 - 2 f| (f: where the true gap sits between two tick counts, read as
/// the fractional part of the local mean tick count). A bridged reading holds until the next
/// pulse, so the share of readings that are bridged is the share of missing pulses q; q is the
/// share read off the lattice over the mean probability. `None` where the noise hides the
/// half ticks or the gap sits too near a tick count for bridged gaps to show; else the count
/// off the lattice, its expectation per unit share, and the count of pulses behind it (a
/// reading holds over `hold_samples` samples where pulses come slower than the samples).
fn missing_share(rpm: &[f64], c: f64) -> Option<(f64, f64, f64)> {
    let u: Vec<f64> = rpm
        .iter()
        .filter(|&&x| x > 0.0)
        .map(|&x| 60.0 / (c * x))
        .collect();
    if u.len() < 100 {
        return None;
    }
    let on: Vec<f64> = u
        .iter()
        .copied()
        .filter(|x| (x - x.round()).abs() < 0.2)
        .collect();
    let tick_noise = {
        let abs: Vec<f64> = on.iter().map(|x| (x - x.round()).abs()).collect();
        quantile_unsorted(&abs, 0.5) / 0.6745
    };
    if tick_noise > MAX_TICK_NOISE || on.len() < u.len() / 2 {
        return None;
    }
    // Where the true gap sits, per stretch of 50 readings (the speed may move over the
    // recording): the mean of its on-lattice tick counts.
    let mut off = 0.0;
    let mut expected = 0.0;
    for chunk in u.chunks(50) {
        let on: Vec<f64> = chunk
            .iter()
            .copied()
            .filter(|x| (x - x.round()).abs() < 0.2)
            .map(f64::round)
            .collect();
        if on.is_empty() {
            continue;
        }
        let m = mean(&on);
        let f = m - m.floor();
        expected += chunk.len() as f64 * (1.0 - (1.0 - 2.0 * f).abs());
        off += chunk
            .iter()
            .filter(|x| (*x - x.round()).abs() > 0.3)
            .count() as f64;
    }
    let hold = hold_samples(rpm).unwrap_or(1.0);
    (expected >= MIN_ODD * u.len() as f64).then_some((off, expected, off / hold))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::measure;

    /// Rows of a drive at `rpm` (driven at half) with a 1x ripple of 0.5 % on the driven shaft,
    /// 10 kHz rows for `seconds`.
    fn rows(rpm: f64, seconds: f64) -> Vec<fom::OutputRow> {
        (0..=(seconds * 1e4) as usize)
            .map(|k| {
                let t = k as f64 * 1e-4;
                let ripple = 1.0 + 0.005 * (2.0 * std::f64::consts::PI * rpm / 60.0 * t).sin();
                fom::OutputRow {
                    time_s: t,
                    driver_rpm: rpm,
                    driven_rpm: 0.5 * rpm * ripple,
                    ..Default::default()
                }
            })
            .collect()
    }

    fn identify_of(sensor: &SensorModel, rpm: f64) -> IdentifiedSensor {
        let rec = measure(&rows(rpm, 4.0), sensor);
        let skip = (0.2 * sensor.sample_rate_hz) as usize;
        let w = [
            ShaftReadings {
                sample_rate_hz: sensor.sample_rate_hz,
                rpm: &rec.driver_rpm[skip..],
            },
            ShaftReadings {
                sample_rate_hz: sensor.sample_rate_hz,
                rpm: &rec.driven_rpm[skip..],
            },
        ];
        identify(&w, &[true, false], &SensorModel::default())
    }

    /// A counter by the M/T method (4 ms gate, 40 us clock, 60 pulses) is told from the pulse
    /// timer its lattice implies and read back; pulse timers whose lattices are read are not
    /// taken for counters.
    #[test]
    fn a_counter_is_told_from_a_pulse_timer_and_read_back() {
        let counter = SensorModel {
            timer_resolution_s: 40e-6,
            gate_s: 4e-3,
            speed_noise_rpm: [0.02; 2],
            ..SensorModel::default()
        };
        // At 1752 rpm the counts are 6 and 7 at the motor, 2 and 3 at the fan, and the gate
        // and clock are read back.
        let id = identify_of(&counter, 1752.0);
        let k = id.counter.expect("a counter");
        assert!((k.gate_s - 4e-3).abs() < 1.5e-4, "{k:?}");
        assert!((k.clock_s / 40e-6 - 1.0).abs() < 0.01, "{k:?}");
        assert_eq!(
            (id.twin_gate_s, id.twin_timer_resolution_s),
            (k.gate_s, k.clock_s)
        );
        assert_eq!(id.twin_missing_pulse_share, 0.0, "{id:?}");
        assert!(id.read_structure() && id.differs_from(&SensorModel::default()));
        // At a constant 1500 rpm (5 and 6, 2 and 3) other counters occupy the same few levels,
        // and one of them may be read; it is still a counter, not a timer.
        let id = identify_of(&counter, 1500.0);
        let k = id.counter.expect("a counter");
        assert!(k.distance < 0.02 && k.timer_distance > 0.1, "{k:?}");
        for (timer_s, noise_rpm) in [(4e-6, 0.3), (5e-6, 1.0), (30e-6, 1.0)] {
            let timer = SensorModel {
                timer_resolution_s: timer_s,
                speed_noise_rpm: [noise_rpm; 2],
                ..SensorModel::default()
            };
            let id = identify_of(&timer, 1752.0);
            assert!(id.pulses_x_timer_s.is_some(), "{id:?}");
            assert!(id.counter.is_none(), "{:?}", id.counter_tried);
            assert_eq!(id.twin_gate_s, 0.0);
        }
    }

    /// A counter's pulse edges' jitter (4 ms gate, 50 us clock, 60 pulses) is read back where
    /// it shows: the fan at 870 rpm, whose pulse gap (22.99 ticks) locks to the clock. How the
    /// lock holds depends on the speed to a few hundredths of an rpm, which the readings give
    /// only roughly, so one draw reads the jitter to within about a factor of two (draws of
    /// 1.5 us read 0.75-2.75 us, of 3 us 1.5-3.75 us) and the median of five to within a
    /// third; none is read without jitter.
    #[test]
    fn a_counters_edge_jitter_is_read_back_where_a_shaft_locks_to_its_clock() {
        let rows: Vec<fom::OutputRow> = (0..=40_000)
            .map(|k| fom::OutputRow {
                time_s: k as f64 * 1e-4,
                driver_rpm: 1752.0,
                driven_rpm: 870.0,
                ..Default::default()
            })
            .collect();
        let read = |jitter_s: f64, seed: u64| {
            let counter = SensorModel {
                timer_resolution_s: 50e-6,
                gate_s: 4e-3,
                speed_noise_rpm: [0.0; 2],
                edge_jitter_s: jitter_s,
                seed,
                ..SensorModel::default()
            };
            let rec = measure(&rows, &counter);
            let w = [&rec.driver_rpm[200..], &rec.driven_rpm[200..]].map(|rpm| ShaftReadings {
                sample_rate_hz: 1000.0,
                rpm,
            });
            let id = identify(&w, &[true, false], &SensorModel::default());
            let k = id.counter.expect("a counter");
            assert_eq!(id.twin_edge_jitter_s, k.edge_jitter_s);
            k.edge_jitter_s
        };
        // Without jitter or noise the readings are the same whatever the seed: one draw.
        assert_eq!(read(0.0, 1), 0.0);
        for (jitter_s, draws) in [(1.5e-6, 5), (3e-6, 5)] {
            let got: Vec<f64> = (0..draws).map(|seed| read(jitter_s, 6 + seed)).collect();
            for g in &got {
                assert!((0.4..=2.5).contains(&(g / jitter_s)), "{got:?}");
            }
            assert!(
                (median(got.clone()) / jitter_s - 1.0).abs() < 1.0 / 3.0,
                "{got:?}"
            );
        }
    }

    /// A 4 us timer behind 60 pulses with 1 rpm of noise, four labels: the fan's levels
    /// (about 290 ticks apart) are blurred by the noise and print lattices one tick count apart
    /// nearly alike, one of them half a tick off the motor's (about 145 ticks). The lattice read
    /// prints the motor's readings on its levels, as the plant's lattice does.
    #[test]
    fn the_lattice_read_prints_both_shafts_readings_on_its_levels() {
        for seed in 1..=6 {
            let recs: Vec<_> = (0..4)
                .map(|k| {
                    let sensor = SensorModel {
                        timer_resolution_s: 4e-6,
                        seed: 10 * seed + k,
                        ..SensorModel::default()
                    };
                    measure(&rows(1752.0 - 0.3 * k as f64, 2.5), &sensor)
                })
                .collect();
            let skip = 500;
            let windows: Vec<ShaftReadings> = recs
                .iter()
                .flat_map(|r| {
                    [&r.driver_rpm[skip..], &r.driven_rpm[skip..]].map(|rpm| ShaftReadings {
                        sample_rate_hz: 1000.0,
                        rpm,
                    })
                })
                .collect();
            let driver: Vec<bool> = (0..windows.len()).map(|k| k % 2 == 0).collect();
            let id = identify(&windows, &driver, &SensorModel::default());
            let c = id.pulses_x_timer_s.expect("a lattice");
            for r in &recs {
                let (read, truth) = (
                    lattice_phase(&r.driver_rpm[skip..], c),
                    lattice_phase(&r.driver_rpm[skip..], 240e-6),
                );
                assert!(
                    read > 0.5 && truth > 0.5,
                    "seed {seed}: P tau {c:e}, in phase {read:.2}, the plant's {truth:.2}"
                );
            }
        }
    }

    /// Identifies `truth`'s sensor at 1750 rpm and checks its pulse count and timer (2 %).
    fn pulses_and_timer_recovered(truth: &SensorModel) -> IdentifiedSensor {
        let id = identify_of(truth, 1750.0);
        assert_eq!(id.pulses_per_rev, Some(truth.pulses_per_rev), "{id:?}");
        let tau = id.timer_resolution_s.expect("a timer");
        assert!(
            (tau / truth.timer_resolution_s - 1.0).abs() < 0.02,
            "{id:?}"
        );
        id
    }

    #[test]
    fn pulses_timer_noise_and_missing_pulses_are_recovered() {
        let truth = SensorModel {
            sample_rate_hz: 1000.0,
            pulses_per_rev: 8,
            speed_noise_rpm: [1.0; 2],
            timer_resolution_s: 30e-6,
            missing_pulse_share: 0.05,
            gate_s: 0.0,
            noise_excess_kurtosis: [0.0; 2],
            noise_taps: [None; 2],
            edge_jitter_s: 0.0,
            seed: 5,
        };
        let id = pulses_and_timer_recovered(&truth);
        assert!(id.read_structure());
        let c = id.pulses_x_timer_s.expect("a lattice");
        assert!((c / 240e-6 - 1.0).abs() < 0.02, "{id:?}");
        for n in id.speed_noise_rpm {
            assert!((n - 1.0).abs() < 0.15, "{id:?}");
        }
        let q = id.missing_pulse_share.expect("missing pulses read");
        // About 40 pulses missing in the 3.8 s read: the interval is wide, but holds the
        // truth and not zero.
        let [lo, hi] = id.missing_pulse_share_interval90;
        assert!(lo < 0.05 && 0.05 < hi && lo > 0.01, "{q} {id:?}");
        assert_eq!(id.twin_pulses_per_rev, 8);
        assert!(id.differs_from(&SensorModel::default()));
    }

    #[test]
    fn another_pulse_count_and_no_missing_pulses_are_recovered() {
        let truth = SensorModel {
            sample_rate_hz: 1000.0,
            pulses_per_rev: 4,
            speed_noise_rpm: [0.5; 2],
            timer_resolution_s: 50e-6,
            missing_pulse_share: 0.0,
            gate_s: 0.0,
            noise_excess_kurtosis: [0.0; 2],
            noise_taps: [None; 2],
            edge_jitter_s: 0.0,
            seed: 9,
        };
        let id = pulses_and_timer_recovered(&truth);
        let q = id.missing_pulse_share.expect("missing pulses read");
        assert!(q < 0.005, "{id:?}");
    }

    #[test]
    fn the_default_tachometer_leaves_its_pulse_count_unread_and_the_configuration_stands() {
        // 60 pulses at 1750 and 875 rpm: pulses at 1750 and 875 Hz, faster than every second
        // sample at 1 kHz; an exact timer: no lattice, so no timer and no missing pulses read.
        let truth = SensorModel {
            missing_pulse_share: 0.05,
            ..SensorModel::default()
        };
        let id = identify_of(&truth, 1750.0);
        assert_eq!(id.pulses_per_rev, None, "{id:?}");
        assert_eq!(id.pulses_x_timer_s, None, "{id:?}");
        assert_eq!(id.missing_pulse_share, None, "{id:?}");
        for n in id.speed_noise_rpm {
            assert!((n - 1.0).abs() < 0.1, "{id:?}");
        }
        assert!(!id.differs_from(&SensorModel::default()));
        assert_eq!(id.twin_noise_excess_kurtosis, [0.0; 2], "{id:?}");
    }

    /// Four windows of 2 s at 1 kHz: `motion(t)` rpm plus noise s_t z_t, z_t iid N(0, 1) and
    /// s_t^2 = 1 +- a, its sign drawn for blocks of 5 readings (a scale that changes slowly
    /// against the readings): excess kurtosis 3 a^2 (a Gaussian scale mixture).
    fn readings(a: f64, seed: u64, motion: impl Fn(f64) -> f64) -> Vec<Vec<f64>> {
        use rand::Rng;
        use rand_xoshiro::rand_core::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..4)
            .map(|_| {
                let mut s = 1.0;
                (0..2000)
                    .map(|k: usize| {
                        if k.is_multiple_of(5) {
                            s = (1.0 + if rng.gen::<bool>() { a } else { -a }).sqrt();
                        }
                        let z: f64 = rng.sample(rand_distr::StandardNormal);
                        motion(k as f64 * 1e-3) + s * z
                    })
                    .collect()
            })
            .collect()
    }

    /// The noise shape of `readings(a, seed, motion)` for 20 seeds.
    fn shapes(a: f64, motion: impl Fn(f64) -> f64 + Copy) -> Vec<(f64, [f64; 2])> {
        (0..20)
            .map(|seed| {
                let w = readings(a, seed, motion);
                noise_kurtosis(&w.iter().map(|v| v.as_slice()).collect::<Vec<_>>())
            })
            .collect()
    }

    /// How many of `shapes` have `want` inside their 90 % interval: 18 of 20 expected; fewer
    /// than 15 has a probability of 1 % for a true 90 % interval (binomial).
    fn holding(shapes: &[(f64, [f64; 2])], want: f64) -> usize {
        shapes
            .iter()
            .filter(|(_, [lo, hi])| *lo < want && want < *hi)
            .count()
    }

    #[test]
    fn gaussian_noise_reads_gaussian() {
        let s = shapes(0.0, |_| 1750.0);
        assert!(holding(&s, 0.0) >= 15, "{s:?}");
    }

    #[test]
    fn a_scale_mixture_is_recovered_within_its_interval() {
        // a = 0.5: excess kurtosis 0.75; blocks of 5 give rho_1 = 0.8, rho_2 = 0.6, so the
        // second differences read 0.75 (9 + 8 x 0.8 + 0.6) / 18 = 0.667.
        let s = shapes(0.5, |_| 1750.0);
        let want = 0.75 * (9.0 + 8.0 * 0.8 + 0.6) / 18.0;
        assert!(holding(&s, want) >= 15, "{s:?}");
        assert!(s.iter().all(|(_, [lo, _])| *lo > 0.0), "{s:?}");
    }

    #[test]
    fn a_runout_and_a_blade_pass_are_not_taken_for_noise_shape() {
        // A 20 Hz runout of 10 rpm (about its 20 ms moving average, still 2.4 rpm: its
        // kurtosis there is a sine's, near -1.5) and a 116 Hz line of 2 rpm on Gaussian noise.
        let motion = |t: f64| {
            let w = 2.0 * std::f64::consts::PI;
            1750.0 + 10.0 * (w * 20.0 * t).sin() + 2.0 * (w * 116.0 * t).sin()
        };
        let w = readings(0.0, 0, motion);
        let about_average: Vec<f64> = w[0]
            .iter()
            .enumerate()
            .skip(10)
            .take(1980)
            .map(|(i, x)| x - mean(&w[0][i - 10..=i + 10]))
            .collect();
        assert!(
            excess_kurtosis(&about_average) < -0.5,
            "the runout dominates"
        );
        let s = shapes(0.0, motion);
        assert!(holding(&s, 0.0) >= 15, "{s:?}");
    }
}
