//! Sensor model for synthetic measurements (the `tachometer` of the effect catalogue): a pulse
//! tachometer with P pulses per revolution on each shaft, pulse times taken on a timer of finite
//! resolution, pulses that go missing at random, speed computed from the time between the last
//! two pulses (a gap spanning missed pulses is divided by their count, as tachometer firmware
//! does) or, for a counter by the M/T method, from the whole pulse gaps within a gate
//! (`gate_s`), read out at a fixed sampling rate with additive speed noise: Gaussian, or a
//! Gaussian scale mixture of a given excess kurtosis where the readings' noise has heavier
//! tails (`gap::sensor_id::noise_kurtosis`), and white or filtered to a short autocorrelation
//! where the readings' noise is correlated over a few readings (a counter's gate;
//! `noise_taps`).

use rand::Rng;
use rand_distr::StandardNormal;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

use std::collections::BTreeMap;
use std::path::Path;

use fom::DriveConfig;

use crate::error::{Result, TwinError};
use crate::measured::{append_run, Recording, RunEntry};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorModel {
    /// Read-out rate, Hz.
    pub sample_rate_hz: f64,
    /// Tachometer pulses per shaft revolution.
    pub pulses_per_rev: u32,
    /// Standard deviation of the additive speed noise of the driver's and the driven shaft, rpm
    /// (a counter's or a pick-up's noise need not be the same on both).
    pub speed_noise_rpm: [f64; 2],
    /// Resolution of the timer that stamps the pulses, s (0: exact times). A speed n read from
    /// one pulse gap is then quantised in steps of about n^2 P tau / 60 rpm.
    pub timer_resolution_s: f64,
    /// Share of pulses that go missing (a dirty or misaligned pick-up), in [0, 0.5).
    pub missing_pulse_share: f64,
    /// Counting gate of a counter by the M/T method, s (0: the speed from the last pulse gap).
    /// A counter reads the whole pulse gaps within the gate before the read-out (at least the
    /// last one) over their span, n = 60 m / (P T) (Ohmae et al., IEEE Trans. Ind. Electron.
    /// 29(3), 1982), so its steps are those of a timer of tau / m and m changes with the speed.
    pub gate_s: f64,
    /// Excess kurtosis of the driver's and the driven speed noise (0: Gaussian); positive
    /// values make it a Gaussian scale mixture ([`NoiseScale`]).
    pub noise_excess_kurtosis: [f64; 2],
    /// Per shaft, the taps of a filter the noise passes through, where it is correlated over a
    /// few readings (None: white). Scaled to unit energy, so `speed_noise_rpm` stays the
    /// readings' noise sd ([`noise_taps_for`]).
    pub noise_taps: [Option<[f64; NOISE_TAPS]>; 2],
    /// Standard deviation of each pulse edge's time, s (0: exact edges): a pick-up's jitter,
    /// which moves a reading across its timer's or counter's levels before it is stamped, where
    /// an added speed noise moves it off them.
    pub edge_jitter_s: f64,
    /// Seed of the noise, of the edge jitter and of the missing pulses.
    pub seed: u64,
}

/// Taps of a shaft's noise filter (`SensorModel::noise_taps`): the lags of the readings'
/// autocorrelation it reproduces, plus one.
pub const NOISE_TAPS: usize = 9;

/// Unit-energy taps h of a moving-average filter whose output's autocorrelation at lags
/// 1..=8 is `acf` (white noise in, e_k = sum_j h_j w_(k-j)). The autocovariance of such a
/// process is gamma_k = sum_j h_j h_(j+k) (Box, Jenkins and Reinsel, Time Series Analysis,
/// 4th ed. 2008, eq. 3.3.3); the taps are its least-squares fit from white noise by
/// Levenberg-Marquardt (Marquardt, J. SIAM 11(2), 1963), so an autocorrelation estimated from
/// readings that no such filter makes exactly gets the nearest one. None for a non-finite
/// `acf`.
pub fn noise_taps_for(acf: &[f64; NOISE_TAPS - 1]) -> Option<[f64; NOISE_TAPS]> {
    use faer::linalg::solvers::Solve;
    const N: usize = NOISE_TAPS;
    if acf.iter().any(|r| !r.is_finite()) {
        return None;
    }
    let mut target = [1.0; N];
    target[1..].copy_from_slice(acf);
    let residual = |h: &[f64; N]| -> [f64; N] {
        std::array::from_fn(|k| (0..N - k).map(|j| h[j] * h[j + k]).sum::<f64>() - target[k])
    };
    let cost = |f: &[f64; N]| f.iter().map(|x| x * x).sum::<f64>();
    let mut h = [0.0; N];
    h[0] = 1.0;
    let (mut f, mut lambda) = (residual(&h), 1e-3);
    for _ in 0..200 {
        // d f_k / d h_m = h_(m+k) + h_(m-k).
        let jac = faer::Mat::<f64>::from_fn(N, N, |k, m| {
            let up = if m + k < N { h[m + k] } else { 0.0 };
            let down = if m >= k { h[m - k] } else { 0.0 };
            up + down
        });
        let jtj = jac.transpose() * &jac;
        let jtf = jac.transpose() * faer::Mat::<f64>::from_fn(N, 1, |k, _| f[k]);
        let mut improved = false;
        while lambda < 1e12 {
            let a = faer::Mat::<f64>::from_fn(N, N, |i, j| {
                jtj[(i, j)]
                    + if i == j {
                        lambda * (1.0 + jtj[(i, i)])
                    } else {
                        0.0
                    }
            });
            let Ok(llt) = a.llt(faer::Side::Lower) else {
                lambda *= 10.0;
                continue;
            };
            let step = llt.solve(&jtf);
            let trial: [f64; N] = std::array::from_fn(|m| h[m] - step[(m, 0)]);
            let ft = residual(&trial);
            if cost(&ft) < cost(&f) {
                (h, f, lambda) = (trial, ft, (lambda / 10.0).max(1e-12));
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved || cost(&f) < 1e-20 {
            break;
        }
    }
    let energy = h.iter().map(|x| x * x).sum::<f64>().sqrt();
    (energy > 0.0 && energy.is_finite()).then(|| h.map(|x| x / energy))
}

/// A shaft's noise filter, reading by reading: the last draws and the taps they pass through
/// (`SensorModel::noise_taps`); without taps the draw itself.
struct NoiseFilter {
    taps: Option<[f64; NOISE_TAPS]>,
    past: [f64; NOISE_TAPS],
}

impl NoiseFilter {
    fn new(taps: Option<[f64; NOISE_TAPS]>) -> Self {
        let taps = taps.map(|h| {
            let e = h.iter().map(|x| x * x).sum::<f64>().sqrt();
            h.map(|x| x / e)
        });
        Self {
            taps,
            past: [0.0; NOISE_TAPS],
        }
    }

    /// The filtered noise for the draw `w` of this reading.
    fn filter(&mut self, w: f64) -> f64 {
        let Some(h) = self.taps else { return w };
        self.past.copy_within(0..NOISE_TAPS - 1, 1);
        self.past[0] = w;
        h.iter().zip(&self.past).map(|(a, b)| a * b).sum()
    }
}

/// Readings over which a shaft's noise keeps one scale ([`NoiseScale`]).
pub const NOISE_SCALE_BLOCK: usize = 5;
/// Largest excess kurtosis the twin's noise takes: a variance of 1 +- 0.95.
pub const MAX_NOISE_KURTOSIS: f64 = 3.0 * 0.95 * 0.95;

/// The excess kurtosis of [`NoiseScale`]'s noise whose second differences read `k_d2`: for a
/// scale mixture whose variance has lag correlations rho_1 and rho_2, the second differences'
/// excess kurtosis is k (9 + 8 rho_1 + rho_2) / 18 (`gap::sensor_id::noise_kurtosis`); a
/// scale kept over blocks of B readings (at a random phase) has rho_L = 1 - L / B.
pub fn noise_kurtosis_for_second_differences(k_d2: f64) -> f64 {
    let b = NOISE_SCALE_BLOCK as f64;
    let (r1, r2) = (1.0 - 1.0 / b, 1.0 - 2.0 / b);
    k_d2 * 18.0 / (9.0 + 8.0 * r1 + r2)
}

/// The excess kurtosis of noise of `added_rpm` (sd) added to readings whose own scatter is
/// `own_rpm` so that their sum's second differences read `k_d2` (0 where `k_d2` is not
/// positive or nothing is added). The own scatter dilutes the added noise's kurtosis: fourth
/// cumulants of independent terms add, so k_sum = k_added (s_added^2 / s_sum^2)^2 (Kendall and
/// Stuart, The Advanced Theory of Statistics I, 1977, sec. 3.13).
pub fn added_noise_kurtosis(k_d2: f64, added_rpm: f64, own_rpm: f64) -> f64 {
    let added = added_rpm * added_rpm;
    if k_d2 > 0.0 && added > 0.0 {
        let dilution = ((added + own_rpm * own_rpm) / added).powi(2);
        (noise_kurtosis_for_second_differences(k_d2) * dilution).min(MAX_NOISE_KURTOSIS)
    } else {
        0.0
    }
}

/// The scale of a shaft's noise, reading by reading: 1 for Gaussian noise; for an excess
/// kurtosis k > 0, a Gaussian scale mixture (Andrews and Mallows, J. R. Stat. Soc. B 36, 1974)
/// whose variance is 1 + a or 1 - a with equal odds, drawn anew every `NOISE_SCALE_BLOCK`
/// readings from a stream of its own (the Gaussian draws stay those of Gaussian noise): its
/// excess kurtosis is 3 E[v^2] / E[v]^2 - 3 = 3 a^2, so a = sqrt(k / 3), at most 0.95.
struct NoiseScale {
    rng: Option<Xoshiro256PlusPlus>,
    a: f64,
    scale: f64,
}

impl NoiseScale {
    fn new(kurtosis: f64, seed: u64, stream: u64) -> Self {
        let on = kurtosis > 0.0;
        Self {
            rng: on.then(|| Xoshiro256PlusPlus::seed_from_u64(seed ^ (0x5ca1_0000 + stream))),
            a: (kurtosis.min(MAX_NOISE_KURTOSIS) / 3.0).sqrt(),
            scale: 1.0,
        }
    }

    /// The scale at reading `k` (called for k = 0, 1, 2, ... in turn).
    fn at(&mut self, k: usize) -> f64 {
        if let Some(rng) = self.rng.as_mut() {
            if k.is_multiple_of(NOISE_SCALE_BLOCK) {
                let sign = if rng.gen::<bool>() { 1.0 } else { -1.0 };
                self.scale = (1.0 + sign * self.a).sqrt();
            }
        }
        self.scale
    }
}

impl Default for SensorModel {
    /// 1 kHz read-out, a 60-tooth wheel (a common magnetic pick-up), 1 rpm noise (0.06 % of
    /// motor speed: an industrial tachometer's stated accuracy class).
    fn default() -> Self {
        Self {
            sample_rate_hz: 1000.0,
            pulses_per_rev: 60,
            speed_noise_rpm: [1.0; 2],
            timer_resolution_s: 0.0,
            missing_pulse_share: 0.0,
            gate_s: 0.0,
            noise_excess_kurtosis: [0.0; 2],
            noise_taps: [None; 2],
            edge_jitter_s: 0.0,
            seed: 1,
        }
    }
}

impl SensorModel {
    /// The default sensor with the tachometer of a drive configuration's `[effects.tachometer]`
    /// table, where it has one.
    pub fn from_config(cfg: &DriveConfig) -> Self {
        let mut s = Self::default();
        if let Some(t) = cfg.effects.tachometer {
            s.pulses_per_rev = t.pulses_per_rev;
            s.timer_resolution_s = t.timer_resolution_s;
            s.missing_pulse_share = t.missing_pulse_share;
        }
        s
    }

    /// Checks every setting; the error names it.
    pub fn validate(&self) -> Result<()> {
        let bad = |input, message: String| Err(TwinError::InvalidArgument { input, message });
        if !(self.sample_rate_hz.is_finite() && self.sample_rate_hz > 0.0) {
            return bad(
                rom::Input::SampleRate,
                format!("must be positive, got {}", self.sample_rate_hz),
            );
        }
        if self.pulses_per_rev == 0 {
            return bad(rom::Input::PulsesPerRev, "must be at least 1, got 0".into());
        }
        for n in self.speed_noise_rpm {
            if !(n.is_finite() && n >= 0.0) {
                return bad(
                    rom::Input::SpeedNoise,
                    format!("must be zero or positive, got {n}"),
                );
            }
        }
        if !(self.timer_resolution_s.is_finite() && self.timer_resolution_s >= 0.0) {
            return bad(
                rom::Input::TimerResolution,
                format!("must be zero or positive, got {}", self.timer_resolution_s),
            );
        }
        for h in self.noise_taps.iter().flatten() {
            let energy = h.iter().map(|x| x * x).sum::<f64>();
            if !(energy.is_finite() && energy > 0.0) {
                return bad(
                    rom::Input::SpeedNoise,
                    format!("noise filter taps must be finite and not all zero, got {h:?}"),
                );
            }
        }
        if !(self.gate_s.is_finite() && self.gate_s >= 0.0) {
            return bad(
                rom::Input::TimerResolution,
                format!(
                    "the counting gate must be zero or positive, got {}",
                    self.gate_s
                ),
            );
        }
        if !(self.edge_jitter_s.is_finite() && self.edge_jitter_s >= 0.0) {
            return bad(
                rom::Input::TimerResolution,
                format!(
                    "the pulse edges' jitter must be zero or positive, got {}",
                    self.edge_jitter_s
                ),
            );
        }
        if !(0.0..0.5).contains(&self.missing_pulse_share) {
            return bad(
                rom::Input::MissingPulseShare,
                format!("must lie in [0, 0.5), got {}", self.missing_pulse_share),
            );
        }
        Ok(())
    }
}

/// Whether `label` can name a condition in file names (`LABEL-runN.csv`).
pub fn check_label(label: &str) -> Result<()> {
    if label.trim().is_empty() || label.contains(['/', '\\']) {
        return Err(TwinError::InvalidArgument {
            input: rom::Input::ConditionLabel,
            message: format!("`{label}` must be non-empty and contain no path separator"),
        });
    }
    Ok(())
}

/// Appends a full-order run to the measured data set in `dir` as a synthetic recording
/// `LABEL-runN.csv` (first free N), with the centre distance, friction and installation
/// tension as run metadata. Returns the file name.
pub fn append_synthetic_run(
    dir: &Path,
    label: &str,
    cfg: &DriveConfig,
    rows: &[fom::OutputRow],
    sensor: &SensorModel,
) -> Result<String> {
    check_label(label)?;
    let n = (1..)
        .find(|n| !dir.join(format!("{label}-run{n}.csv")).exists())
        .expect("a free run number");
    let file = format!("{label}-run{n}.csv");
    let rec = measure(rows, sensor);
    let mut metadata = BTreeMap::new();
    metadata.insert("synthetic".to_string(), toml::Value::Boolean(true));
    metadata.insert(
        "friction".to_string(),
        toml::Value::Float(cfg.effective_friction()),
    );
    if let Some(t) = cfg.belt.installation_tension_n {
        metadata.insert("installation_tension_n".to_string(), toml::Value::Float(t));
    }
    // A counter's gate and the edges' jitter are named where the sensor has them.
    let mut counter = String::new();
    if sensor.gate_s > 0.0 {
        counter += &format!(", counter gate {} s", sensor.gate_s);
    }
    if sensor.edge_jitter_s > 0.0 {
        counter += &format!(", edge jitter {} s", sensor.edge_jitter_s);
    }
    let comment = format!(
        "synthetic measurement by beltwin {}: sensor {} Hz, {} pulses/rev, timer {} s{counter}, \
         missing pulses {}, noise {} / {} rpm, seed {}",
        env!("CARGO_PKG_VERSION"),
        sensor.sample_rate_hz,
        sensor.pulses_per_rev,
        sensor.timer_resolution_s,
        sensor.missing_pulse_share,
        sensor.speed_noise_rpm[0],
        sensor.speed_noise_rpm[1],
        sensor.seed
    );
    append_run(
        dir,
        RunEntry {
            file: file.clone(),
            label: label.to_string(),
            center_distance_m: Some(cfg.center_distance_m()),
            metadata,
        },
        &rec,
        &comment,
        (cfg.driver.pitch_diameter_m, cfg.driven.pitch_diameter_m),
    )?;
    Ok(file)
}

/// Pulse times of one shaft from interval-mean speeds (rpm) on rows ending at `time_s`: the
/// angle is integrated row by row and a pulse falls every 1/P revolution (linear inside a row).
pub(crate) fn pulse_times(time_s: &[f64], rpm: &[f64], pulses_per_rev: u32) -> Vec<f64> {
    let step = 1.0 / pulses_per_rev as f64;
    let mut pulses = Vec::new();
    let mut rev = 0.0;
    let mut next = step;
    for k in 1..time_s.len() {
        let dt = time_s[k] - time_s[k - 1];
        let d_rev = rpm[k].max(0.0) / 60.0 * dt;
        while d_rev > 0.0 && rev + d_rev >= next {
            pulses.push(time_s[k - 1] + (next - rev) / d_rev * dt);
            next += step;
        }
        rev += d_rev;
    }
    pulses
}

/// Speed (rpm) a pulse tachometer reads at `t`: from the last two pulses up to `t`, or, with a
/// counting gate (`SensorModel::gate_s` > 0), from the whole pulse gaps within the gate before
/// `t` (at least the last one) over their span; zero before the second pulse or when the last
/// pulse is older than the gap to the one before would allow at the slowest speed the sensor
/// resolves (a time-out of 4 pulse gaps).
fn read_speed(pulses: &Pulses, t: f64, (ppr, gate_s): (u32, f64), cursor: &mut usize) -> f64 {
    while *cursor < pulses.times.len() && pulses.times[*cursor] <= t {
        *cursor += 1;
    }
    if *cursor < 2 {
        return 0.0;
    }
    let last = *cursor - 1;
    let (a, b) = (pulses.times[last - 1], pulses.times[last]);
    if t - b > 4.0 * (b - a).max(1e-6) {
        return 0.0;
    }
    if gate_s <= 0.0 {
        return 60.0 / (ppr as f64 * (b - a) / pulses.spans[last]);
    }
    // The M/T method (Ohmae et al. 1982): the first pulse of the span is the earliest within
    // the gate, so the span holds the whole gaps m between it and the last pulse.
    let mut first = last - 1;
    while first > 0 && pulses.times[first - 1] > t - gate_s {
        first -= 1;
    }
    let gaps: f64 = pulses.spans[first + 1..=last].iter().sum();
    60.0 * gaps / (ppr as f64 * (b - pulses.times[first]))
}

/// Pulse times as the tachometer sees them, and for each the number of pulse gaps back to the
/// previous one it saw.
struct Pulses {
    times: Vec<f64>,
    spans: Vec<f64>,
}

/// How many pulse gaps each gap spans, as tachometer firmware infers it: k when the gap is
/// within a quarter of k times the last single-pulse gap with k >= 2 (pulses went missing; a
/// fan drive cannot halve its speed within one pulse), else 1; the single-pulse gap is then
/// updated to gap / k.
fn gap_spans(times: &[f64]) -> Vec<f64> {
    let mut spans = vec![1.0; times.len()];
    let mut single = f64::NAN;
    for i in 1..times.len() {
        let gap = times[i] - times[i - 1];
        let ratio = gap / single;
        let k = ratio.round();
        if k >= 2.0 && (ratio - k).abs() < 0.25 {
            spans[i] = k;
        }
        single = gap / spans[i];
    }
    spans
}

/// The pulses the tachometer sees: each edge jittered, stamped on its timer (rounded down to a
/// multiple of the resolution), some dropped at random.
fn sensed_pulses(mut pulses: Vec<f64>, sensor: &SensorModel, stream: u64) -> Pulses {
    if sensor.edge_jitter_s > 0.0 {
        // A stream of its own, so the speed noise and the drop-outs are the same with and
        // without jitter; an edge never passes the one before (jitter far below a pulse gap).
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(sensor.seed ^ (0x717e_0000 + stream));
        let mut last = f64::NEG_INFINITY;
        for p in pulses.iter_mut() {
            let e: f64 = rng.sample(StandardNormal);
            *p = (*p + sensor.edge_jitter_s * e).max(last);
            last = *p;
        }
    }
    if sensor.timer_resolution_s > 0.0 {
        let tau = sensor.timer_resolution_s;
        for p in pulses.iter_mut() {
            *p = (*p / tau).floor() * tau;
        }
    }
    if sensor.missing_pulse_share > 0.0 {
        // A stream of its own, so the speed noise is the same with and without drop-outs.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(sensor.seed ^ (0x5eed_0000 + stream));
        pulses.retain(|_| rng.gen::<f64>() >= sensor.missing_pulse_share);
    }
    Pulses {
        spans: gap_spans(&pulses),
        times: pulses,
    }
}

/// Noise-free readings at `times_s` of one shaft whose true pulse times are `pulses`, through
/// `sensor`'s timer, counting gate and missing pulses (no added noise): the sensor stage reads
/// recordings by synthesis with it (`gap::sensor_counter`).
pub(crate) fn read_pulses(pulses: &[f64], sensor: &SensorModel, times_s: &[f64]) -> Vec<f64> {
    let p = sensed_pulses(pulses.to_vec(), sensor, 1);
    let mut cursor = 0;
    times_s
        .iter()
        .map(|&t| read_speed(&p, t, (sensor.pulses_per_rev, sensor.gate_s), &mut cursor))
        .collect()
}

/// A synthetic recording of a full-order run's shaft speeds.
pub fn measure(rows: &[fom::OutputRow], sensor: &SensorModel) -> Recording {
    let t: Vec<f64> = rows.iter().map(|r| r.time_s).collect();
    let n1: Vec<f64> = rows.iter().map(|r| r.driver_rpm).collect();
    let n2: Vec<f64> = rows.iter().map(|r| r.driven_rpm).collect();
    let p1 = sensed_pulses(pulse_times(&t, &n1, sensor.pulses_per_rev), sensor, 1);
    let p2 = sensed_pulses(pulse_times(&t, &n2, sensor.pulses_per_rev), sensor, 2);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(sensor.seed);
    let mut gauss = || -> f64 { rng.sample(StandardNormal) };
    let [k1, k2] = sensor.noise_excess_kurtosis;
    let (mut scale1, mut scale2) = (
        NoiseScale::new(k1, sensor.seed, 1),
        NoiseScale::new(k2, sensor.seed, 2),
    );
    let [mut filter1, mut filter2] = sensor.noise_taps.map(NoiseFilter::new);
    let end = t.last().copied().unwrap_or(0.0);
    let n = (end * sensor.sample_rate_hz).floor() as usize;
    let mut rec = Recording::default();
    let (mut c1, mut c2) = (0, 0);
    for k in 0..=n {
        let ts = k as f64 / sensor.sample_rate_hz;
        let mut s1 = read_speed(&p1, ts, (sensor.pulses_per_rev, sensor.gate_s), &mut c1);
        let mut s2 = read_speed(&p2, ts, (sensor.pulses_per_rev, sensor.gate_s), &mut c2);
        // Multiplying by a scale of 1 leaves Gaussian noise's readings bit for bit; so does a
        // shaft without a filter.
        let (v1, v2) = (scale1.at(k), scale2.at(k));
        if s1 > 0.0 {
            s1 = (s1 + sensor.speed_noise_rpm[0] * v1 * filter1.filter(gauss())).max(0.0);
        }
        if s2 > 0.0 {
            s2 = (s2 + sensor.speed_noise_rpm[1] * v2 * filter2.filter(gauss())).max(0.0);
        }
        rec.time_s.push(ts);
        rec.driver_rpm.push(s1);
        rec.driven_rpm.push(s2);
    }
    rec
}

#[cfg(test)]
mod tests {
    use super::*;
    use fom::stats::mean_and_variance;

    /// A counter reads the whole gaps within its gate over their span: pulses at 1.05, 2.05,
    /// ... ms stamped on a 0.3 ms clock (0.9, 1.8, 3.0, 3.9, 4.8 ms ...) read at 5.5 ms through
    /// a 4.5 ms gate span the pulses at 1.8-4.8 ms, three gaps over 3.0 ms; a pulse timer reads
    /// the last gap, 0.9 ms.
    #[test]
    fn a_counter_reads_the_whole_gaps_in_its_gate_over_their_span() {
        let true_s: Vec<f64> = (1..=9).map(|k| k as f64 * 1e-3 + 0.05e-3).collect();
        let sensor = SensorModel {
            pulses_per_rev: 10,
            timer_resolution_s: 3e-4,
            gate_s: 4.5e-3,
            ..SensorModel::default()
        };
        let p = sensed_pulses(true_s, &sensor, 1);
        let rpm = |gaps: f64, span_s: f64| 60.0 * gaps / (10.0 * span_s);
        let mut c = 0;
        let counter = read_speed(&p, 5.5e-3, (10, sensor.gate_s), &mut c);
        assert!((counter - rpm(3.0, 3.0e-3)).abs() < 1e-9, "{counter}");
        let mut c = 0;
        let timer = read_speed(&p, 5.5e-3, (10, 0.0), &mut c);
        assert!((timer - rpm(1.0, 0.9e-3)).abs() < 1e-9, "{timer}");
        // A gate shorter than a gap still reads the last one.
        let mut c = 0;
        let short = read_speed(&p, 5.5e-3, (10, 0.5e-3), &mut c);
        assert_eq!(short, timer);
    }

    #[test]
    fn constant_speed_gives_evenly_spaced_pulses_and_the_speed_back() {
        // 600 rpm = 10 rev/s; 1 kHz rows for 1.01 s: pulses every 25 ms up to 1.0 s.
        let t: Vec<f64> = (0..=1010).map(|k| k as f64 * 1e-3).collect();
        let rpm = vec![600.0; t.len()];
        let p = pulse_times(&t, &rpm, 4);
        assert_eq!(p.len(), 40);
        assert!(
            (p[0] - 0.025).abs() < 1e-9 && (p[39] - 1.0).abs() < 1e-9,
            "{p:?}"
        );
        let p = sensed_pulses(p, &SensorModel::default(), 1);
        let mut c = 0;
        assert!((read_speed(&p, 0.5, (4, 0.0), &mut c) - 600.0).abs() < 1e-6);
        let mut c = 0;
        assert_eq!(
            read_speed(&p, 0.03, (4, 0.0), &mut c),
            0.0,
            "one pulse is not a speed"
        );
    }

    #[test]
    fn noise_has_the_requested_spread() {
        let rows: Vec<fom::OutputRow> = (0..=2000)
            .map(|k| fom::OutputRow {
                time_s: k as f64 * 1e-3,
                driver_rpm: 1750.0,
                driven_rpm: 870.0,
                slip_pct: 0.0,
                ..Default::default()
            })
            .collect();
        // Each shaft its own level (1 900 readings: a sample sd's own sd is 1.6 % of it).
        let sensor = SensorModel {
            speed_noise_rpm: [2.0, 0.5],
            ..SensorModel::default()
        };
        let rec = measure(&rows, &sensor);
        for (v, rpm, want) in [
            (&rec.driver_rpm, 1750.0, 2.0),
            (&rec.driven_rpm, 870.0, 0.5),
        ] {
            let (m, var) = mean_and_variance(&v[100..]);
            let sd = var.sqrt();
            assert!((m - rpm).abs() < 0.1 * want, "mean {m}");
            assert!((sd / want - 1.0).abs() < 0.075, "sd {sd}, want {want}");
        }
    }

    #[test]
    fn a_noise_kurtosis_shapes_one_shaft_and_leaves_the_other_bit_for_bit() {
        let gaussian = SensorModel {
            speed_noise_rpm: [2.0; 2],
            ..SensorModel::default()
        };
        let mixed = SensorModel {
            noise_excess_kurtosis: [1.0, 0.0],
            ..gaussian
        };
        let rows = constant_rows(1750.0, 10.0);
        let (a, b) = (measure(&rows, &gaussian), measure(&rows, &mixed));
        assert_eq!(a.driven_rpm, b.driven_rpm);
        let k = crate::gap::features::excess_kurtosis;
        // 9 900 readings: a Gaussian sample's kurtosis has an sd of sqrt(24 / n) = 0.05, a
        // mixture's somewhat more; 0.25 is 5 of the former.
        let (ka, kb) = (k(&a.driver_rpm[100..]), k(&b.driver_rpm[100..]));
        assert!(ka.abs() < 0.25, "Gaussian: {ka}");
        assert!((kb - 1.0).abs() < 0.25, "mixture of kurtosis 1: {kb}");
    }

    /// Sample autocorrelation at lags 1..=8 of `v` about its mean.
    fn acf_of(v: &[f64]) -> [f64; NOISE_TAPS - 1] {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let x: Vec<f64> = v.iter().map(|a| a - m).collect();
        let c0: f64 = x.iter().map(|a| a * a).sum();
        std::array::from_fn(|i| x.iter().zip(&x[i + 1..]).map(|(a, b)| a * b).sum::<f64>() / c0)
    }

    #[test]
    fn noise_taps_give_one_shaft_a_counters_autocorrelation_and_leave_the_other_bit_for_bit() {
        // A counter whose errors are differences of edge jitter four readings apart,
        // (u_k - u_(k-4)) / sqrt 2: autocorrelation -1/2 at lag 4 and none elsewhere; and a
        // three-reading average: 2/3 and 1/3 at lags 1 and 2.
        let jitter = [0.0, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 0.0];
        let average = [2.0 / 3.0, 1.0 / 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        for acf in [jitter, average] {
            let h = noise_taps_for(&acf).unwrap();
            let energy: f64 = h.iter().map(|x| x * x).sum();
            assert!((energy - 1.0).abs() < 1e-12, "{energy}");
            for (lag, want) in acf.iter().enumerate() {
                let got: f64 = (0..NOISE_TAPS - lag - 1)
                    .map(|j| h[j] * h[j + lag + 1])
                    .sum();
                assert!(
                    (got - want).abs() < 1e-6,
                    "lag {}: {got} against {want}",
                    lag + 1
                );
            }
        }
        // An estimate no filter makes exactly (lag-one 0.9 with lag-two -0.9) gets finite taps.
        let mut rough = [0.0; NOISE_TAPS - 1];
        rough[..2].copy_from_slice(&[0.9, -0.9]);
        assert!(noise_taps_for(&rough).is_some_and(|h| h.iter().all(|x| x.is_finite())));
        assert!(noise_taps_for(&[f64::NAN; NOISE_TAPS - 1]).is_none());
        // Through the sensor: the driven shaft's readings take the jitter's autocorrelation and
        // keep their sd; the driver's are those of white noise, bit for bit.
        let white = SensorModel {
            speed_noise_rpm: [2.0; 2],
            ..SensorModel::default()
        };
        let filtered = SensorModel {
            noise_taps: [None, noise_taps_for(&jitter)],
            ..white
        };
        filtered.validate().unwrap();
        let rows = constant_rows(1750.0, 10.0);
        let (a, b) = (measure(&rows, &white), measure(&rows, &filtered));
        assert_eq!(a.driver_rpm, b.driver_rpm);
        let n2 = &b.driven_rpm[100..];
        // 9 900 readings: the sample autocorrelation's se is about sqrt(1.5 / n) = 0.012
        // (Bartlett's formula, Box, Jenkins and Reinsel eq. 2.1.15); 0.05 is 4 of it.
        for (lag, (got, want)) in acf_of(n2).iter().zip(jitter).enumerate() {
            assert!(
                (got - want).abs() < 0.05,
                "lag {}: {got} against {want}",
                lag + 1
            );
        }
        let sd = fom::stats::sample_std(n2);
        assert!((sd - 2.0).abs() < 0.1, "{sd}");
        let bad = SensorModel {
            noise_taps: [Some([0.0; NOISE_TAPS]), None],
            ..white
        };
        assert!(bad.validate().is_err());
    }

    fn constant_rows(rpm: f64, seconds: f64) -> Vec<fom::OutputRow> {
        (0..=(seconds * 1000.0) as usize)
            .map(|k| fom::OutputRow {
                time_s: k as f64 * 1e-3,
                driver_rpm: rpm,
                driven_rpm: 0.5 * rpm,
                slip_pct: 0.0,
                ..Default::default()
            })
            .collect()
    }

    #[test]
    fn a_tachometer_table_sets_the_sensor() {
        let mut cfg = DriveConfig::default_hvac();
        assert_eq!(SensorModel::from_config(&cfg), SensorModel::default());
        cfg.effects
            .set_from_spec("tachometer:pulses_per_rev=4,timer_resolution_s=1e-6")
            .unwrap();
        let s = SensorModel::from_config(&cfg);
        assert_eq!((s.pulses_per_rev, s.timer_resolution_s), (4, 1e-6));
        assert!(cfg
            .effects
            .set_from_spec("tachometer:pulses_per_rev=0")
            .is_err());
    }

    #[test]
    fn timer_resolution_quantises_speed_in_the_analytic_step() {
        let (rpm, tau) = (1750.0, 1e-6);
        let sensor = SensorModel {
            speed_noise_rpm: [0.0; 2],
            timer_resolution_s: tau,
            ..SensorModel::default()
        };
        let rec = measure(&constant_rows(rpm, 1.0), &sensor);
        let mut levels: Vec<f64> = rec.driver_rpm[100..].to_vec();
        levels.sort_by(f64::total_cmp);
        levels.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
        assert!(levels.len() >= 2, "{levels:?}");
        // Adjacent levels 60 / (P m tau) and 60 / (P (m + 1) tau): a step of n^2 P tau / 60.
        let want = rpm * rpm * 60.0 * tau / 60.0;
        for w in levels.windows(2) {
            assert!(
                ((w[1] - w[0]) / want - 1.0).abs() < 0.01,
                "{levels:?} vs {want}"
            );
        }
    }

    #[test]
    fn edge_jitter_scatters_a_pulse_timer_by_its_analytic_spread() {
        // A reading from one pulse gap T = 60 / (P n) whose two edges each move by sigma:
        // n (1 - (e2 - e1) / T), an sd of n sqrt(2) sigma / T (first order in sigma / T).
        let (rpm, sigma_s) = (1750.0, 1e-6);
        let sensor = SensorModel {
            speed_noise_rpm: [0.0; 2],
            edge_jitter_s: sigma_s,
            ..SensorModel::default()
        };
        let rec = measure(&constant_rows(rpm, 2.0), &sensor);
        let (m, var) = mean_and_variance(&rec.driver_rpm[100..]);
        let sd = var.sqrt();
        let want = rpm * 2f64.sqrt() * sigma_s / (60.0 / (60.0 * rpm));
        assert!((m - rpm).abs() < 0.1 * want, "mean {m}");
        assert!((sd / want - 1.0).abs() < 0.075, "sd {sd}, want {want}");
        // Without jitter the same sensor reads the speed exactly.
        let exact = measure(
            &constant_rows(rpm, 2.0),
            &SensorModel {
                edge_jitter_s: 0.0,
                ..sensor
            },
        );
        assert!(exact.driver_rpm[100..]
            .iter()
            .all(|&n| (n - rpm).abs() < 1e-6));
    }

    #[test]
    fn missing_pulses_are_bridged_not_read_as_a_speed_drop() {
        let sensor = SensorModel {
            speed_noise_rpm: [0.0; 2],
            missing_pulse_share: 0.05,
            ..SensorModel::default()
        };
        let rec = measure(&constant_rows(1750.0, 2.0), &sensor);
        let p = sensed_pulses(pulse_times(&[0.0, 2.0], &[0.0, 1750.0], 60), &sensor, 1);
        // Pulses were dropped (about 5 % of 3500), some of them in a row...
        assert!(p.times.len() < 3450, "{} pulses", p.times.len());
        assert!(p.spans.iter().any(|&k| k >= 3.0));
        // ...and every reading after start-up is the true speed (a missed pulse unbridged
        // would read half of it).
        assert!(
            rec.driver_rpm[100..]
                .iter()
                .all(|&n| (n - 1750.0).abs() < 0.01),
            "a reading strayed"
        );
    }
}
