//! The sensor's noise as the readings show it: its scatter against the first differences', the
//! level and autocorrelation of noise correlated over a few readings, and the data set's one
//! decision per shaft (docs/decisions/correlated-sensor-noise.md). `features` reads them per
//! recording; `baseline` gives the label twins the data set's.

use super::features::{moving_average, noise_sd, Features};
use crate::sensor::{noise_taps_for, NOISE_TAPS};
use fom::stats::quantile_unsorted;

/// Mean over a data set's recordings of a shaft's `Features::scatter_ratio` beyond which its
/// sensor's noise is taken as correlated over a few readings (`correlated_noise`). White noise
/// reads 1 within a few per cent per recording; over the model-form matrix's data sets the mean
/// read 0.976-1.026 on the full-order and lumped models' shafts, 1.010-1.046 on the creep
/// model's motor shaft and 1.176-1.249 on its fan shaft, whose counter averages over a gate
/// four readings long (docs/decisions/correlated-sensor-noise.md).
pub const CORRELATED_NOISE_RATIO: f64 = 1.10;

/// Half-width of the short moving average (readings) about which `Features::scatter_ratio`
/// reads a shaft's scatter.
const SHORT_HALF_WIDTH: usize = 3;

/// Robust standard deviation of `v`'s scatter about its centred moving average over 2 h + 1
/// readings, corrected for the average's own share: white noise about such an average keeps
/// a variance of 2 h / (2 h + 1) of its own.
fn scatter_sd(v: &[f64], h: usize) -> f64 {
    let r: Vec<f64> = about_average(v, h).iter().map(|x| x.abs()).collect();
    quantile_unsorted(&r, 0.5) / 0.6745 * ((2 * h + 1) as f64 / (2 * h) as f64).sqrt()
}

/// `v` about its centred moving average over 2 h + 1 readings, on the readings the average
/// spans whole.
fn about_average(v: &[f64], h: usize) -> Vec<f64> {
    let ma = moving_average(v, 2 * h + 1);
    v[h..v.len().saturating_sub(h)]
        .iter()
        .zip(&ma[h..])
        .map(|(a, b)| a - b)
        .collect()
}

/// Lags of the readings' autocorrelation `noise_scatter` reads: those of the twin's noise
/// filter (`crate::sensor::NOISE_TAPS`).
pub const ACF_LAGS: usize = NOISE_TAPS - 1;

/// A shaft's scatter (`noise_scatter`).
#[derive(Debug, Clone, Copy)]
pub struct NoiseScatter {
    /// About a 7-reading moving average over the first differences' white-noise level.
    pub ratio: f64,
    /// About the moving average over the window given, rpm.
    pub level_rpm: f64,
    /// The autocorrelation at lags 1..=8 about the moving average over five such windows.
    pub acf: [f64; ACF_LAGS],
}

impl NoiseScatter {
    /// Not read: too few readings, a twin's run, or no noise.
    pub const NONE: Self = Self {
        ratio: f64::NAN,
        level_rpm: f64::NAN,
        acf: [f64::NAN; ACF_LAGS],
    };
}

/// A shaft's scatter, `r` being its readings with the drive's lines taken out
/// (`without_lines`): about a 7-reading moving average over the first differences' white-noise
/// level (`noise_sd`, of the line-free readings too: a blade-pass line moves them), about the
/// moving average over `w` readings (20 ms in `features`; rpm), and its autocorrelation at
/// lags 1..=8 about the moving average over 5 `w` readings (a window long against the lags,
/// so that the average takes little of the noise: white noise reads about -1/(5 w) at each
/// lag). NaN for fewer than 200 readings. White noise reads a ratio of 1 and the white level;
/// noise correlated over a few readings (a counter whose gate spans readings: successive
/// readings share pulses, and first differences see only part of the noise) reads more than
/// 1, and a level above the first differences' (docs/decisions/correlated-sensor-noise.md).
pub fn noise_scatter(r: &[f64], w: usize) -> NoiseScatter {
    if r.len() < 200 {
        return NoiseScatter::NONE;
    }
    let white = noise_sd(r);
    if white.is_nan() || white <= 0.0 {
        return NoiseScatter::NONE;
    }
    let h = (w / 2).max(SHORT_HALF_WIDTH);
    NoiseScatter {
        ratio: scatter_sd(r, SHORT_HALF_WIDTH) / white,
        level_rpm: scatter_sd(r, h),
        acf: autocorrelation(r, 5 * w),
    }
}

/// The sample autocorrelation at lags 1..=8 (Box, Jenkins and Reinsel, Time Series Analysis,
/// 4th ed. 2008, eq. 2.1.12) of `v` about its centred moving average over `w` readings, on
/// the readings the average spans whole.
fn autocorrelation(v: &[f64], w: usize) -> [f64; ACF_LAGS] {
    let x = about_average(v, w / 2);
    let c0: f64 = x.iter().map(|a| a * a).sum();
    std::array::from_fn(|i| {
        let lag = i + 1;
        if c0 > 0.0 && x.len() > lag {
            x.iter().zip(&x[lag..]).map(|(a, b)| a * b).sum::<f64>() / c0
        } else {
            f64::NAN
        }
    })
}

/// Per shaft, the mean of a data set's recordings' `scatter_acf` over those that read one
/// (NaN where none did): the autocorrelation the twin's noise filter reproduces on a shaft
/// whose noise is correlated (`crate::sensor::noise_taps_for`).
pub fn mean_scatter_acf<'a>(
    labels: impl Iterator<Item = &'a Features> + Clone,
) -> [[f64; ACF_LAGS]; 2] {
    [0, 1].map(|j| {
        let read: Vec<&[f64; ACF_LAGS]> = labels
            .clone()
            .map(|f| &f.scatter_acf[j])
            .filter(|a| a.iter().all(|x| x.is_finite()))
            .collect();
        std::array::from_fn(|i| {
            if read.is_empty() {
                f64::NAN
            } else {
                read.iter().map(|a| a[i]).sum::<f64>() / read.len() as f64
            }
        })
    })
}

/// Per shaft, the mean of a data set's recordings' `scatter_ratio` over those that read one;
/// NaN where none did. A sensor is one for the data set: the mean over its recordings halves
/// the spread of one.
pub fn mean_scatter_ratio<'a>(labels: impl Iterator<Item = &'a Features> + Clone) -> [f64; 2] {
    [0, 1].map(|j| {
        let r: Vec<f64> = labels
            .clone()
            .map(|f| f.scatter_ratio[j])
            .filter(|x| x.is_finite())
            .collect();
        if r.is_empty() {
            f64::NAN
        } else {
            r.iter().sum::<f64>() / r.len() as f64
        }
    })
}

/// Per shaft, whether a data set's sensor noise is correlated over a few readings: its
/// `mean_scatter_ratio` above `CORRELATED_NOISE_RATIO`.
pub fn correlated_noise<'a>(labels: impl Iterator<Item = &'a Features> + Clone) -> [bool; 2] {
    mean_scatter_ratio(labels).map(|r| r > CORRELATED_NOISE_RATIO)
}

/// A data set's sensor noise, one for all its labels (docs/decisions/correlated-sensor-noise.md):
/// per shaft, whether it is correlated over a few readings, and where it is, the filter taps
/// that give the twin's noise the recordings' mean autocorrelation.
#[derive(Debug, Clone, Copy)]
pub(super) struct DataSetNoise {
    pub(super) correlated: [bool; 2],
    pub(super) taps: [Option<[f64; NOISE_TAPS]>; 2],
}

impl DataSetNoise {
    pub(super) fn of<'a>(labels: impl Iterator<Item = &'a Features> + Clone) -> Self {
        let correlated = correlated_noise(labels.clone());
        let acf = mean_scatter_acf(labels);
        Self {
            correlated,
            taps: [0, 1].map(|j| correlated[j].then(|| noise_taps_for(&acf[j])).flatten()),
        }
    }
}
