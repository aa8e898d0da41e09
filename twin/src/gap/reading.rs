//! How the twin's runs are read: through the sensor the recordings show (`sensor_id`), with
//! each shaft's white noise beyond the sensor's own scatter, and, where the sensor stage read
//! a timer lattice, at the measured speeds for the cells that lattice shapes
//! (docs/decisions/gap-sensor-cells.md).

use super::baseline::LabelTwin;
use super::features::{
    cell_index, features, noise_sd, steady_speeds, Band, BandContext, Cell, Features, Measure,
    Signal, Statistic, Window, CELLS,
};
use super::sensor_id::IdentifiedSensor;
use super::twin_runs::{scaled_twin_recording, twin_recording};
use crate::error::Result;
use crate::sensor::{added_noise_kurtosis, SensorModel};
use Signal::{DrivenSpeed, DriverSpeed};

/// The twin's cells of a run read through `sensor`. Where the sensor stage has read a timer
/// lattice in the recordings, the cells that lattice shapes are read at the measured speeds
/// ([`at_measured_speeds`]).
pub(super) fn twin_features(
    lt: &LabelTwin,
    rows: &[fom::OutputRow],
    sensor: &SensorModel,
    model_ratio: f64,
    ratio: f64,
    ctx: &BandContext,
) -> Result<Features> {
    let rec = twin_recording(rows, model_ratio, ratio, lt.slip_shift_pct, sensor);
    let own = features(&rec, ratio, ctx, lt.read())?;
    if !lt.lattice_read {
        return Ok(own);
    }
    let [m1, m2] = [DriverSpeed, DrivenSpeed].map(|signal| {
        cell_index(Cell::new(
            Window::Steady,
            signal,
            Statistic::Mean,
            Band::Level,
        ))
    });
    let scale = [
        lt.measured.cells[m1].value / own.cells[m1].value,
        lt.measured.cells[m2].value / own.cells[m2].value,
    ];
    if !scale
        .iter()
        .all(|k| k.is_finite() && (*k - 1.0).abs() < MAX_SPEED_SCALE)
    {
        return Ok(own);
    }
    let read_at = |scale: [f64; 2]| {
        let rec = scaled_twin_recording(rows, model_ratio, ratio, lt.slip_shift_pct, scale, sensor);
        features(&rec, ratio, ctx, lt.read())
    };
    let there = read_at(scale)?;
    // The measured means are known to their standard error, and so is where the plant's
    // pulse gaps fall between two levels: the twin is read there too, one standard error
    // above and below.
    let rel = [m1, m2].map(|i| lt.measured.cells[i].se / lt.measured.cells[i].value);
    if !rel.iter().all(|r| r.is_finite() && *r >= 0.0) {
        return Ok(at_measured_speeds(own, &there, &[]));
    }
    let shifted = [1.0, -1.0].map(|sign| {
        read_at([
            scale[0] * (1.0 + sign * rel[0]),
            scale[1] * (1.0 + sign * rel[1]),
        ])
    });
    let [hi, lo] = shifted;
    Ok(at_measured_speeds(own, &there, &[hi?, lo?]))
}

/// The cells of a twin run with a candidate effect on (`twin_features`), except its own line's
/// cells (`line`, `twin_runs::Variant::line_cells`): those are the baseline's reading plus the
/// line's change between the effect's run and the baseline run, both read by [`quiet`], with
/// that change's standard error. Through a coarse timer the twin's readings carry a
/// quantisation floor of their own, which is not common to two runs (their pulses fall apart
/// on the clock): on another simulator's fan runout with a 4 us timer the twin's 1 mm line
/// (about 0.2 rpm) lay within twice the floor's standard error of the difference (0.1 rpm per
/// run), was dropped as insignificant, and a line of 2.3 rpm in the recordings went
/// unexplained (docs/decisions/gap-signature-line.md, "The twin's line without its sensor").
pub(super) fn variant_features(
    lt: &LabelTwin,
    rows: &[fom::OutputRow],
    line: &[usize],
    (model_ratio, ratio): (f64, f64),
    ctx: &BandContext,
) -> Result<Features> {
    let mut f = twin_features(lt, rows, &lt.sensor, model_ratio, ratio, ctx)?;
    if line.is_empty() {
        return Ok(f);
    }
    let read = |rows: &[fom::OutputRow]| {
        let rec = twin_recording(
            rows,
            model_ratio,
            ratio,
            lt.slip_shift_pct,
            &quiet(&lt.sensor),
        );
        features(&rec, ratio, ctx, lt.read())
    };
    let (with, without) = (read(rows)?, read(&lt.baseline_rows)?);
    for &i in line {
        let (a, b) = (with.cells[i], without.cells[i]);
        f.cells[i].value = lt.baseline.cells[i].value + (a.value - b.value);
        f.cells[i].se = a.se.hypot(b.se);
    }
    Ok(f)
}

/// `sensor` without what scatters its readings: its pulses per revolution and read-out rate,
/// exact pulse times (no timer, no counting gate), no missing pulses, no added noise.
fn quiet(sensor: &SensorModel) -> SensorModel {
    SensorModel {
        timer_resolution_s: 0.0,
        gate_s: 0.0,
        missing_pulse_share: 0.0,
        edge_jitter_s: 0.0,
        speed_noise_rpm: [0.0; 2],
        noise_excess_kurtosis: [0.0; 2],
        noise_taps: [None; 2],
        ..*sensor
    }
}

/// Largest relative change of a shaft's speed by which the twin is read at the measured speed
/// (`twin_features`): beyond it the drive is not the same drive.
const MAX_SPEED_SCALE: f64 = 0.05;

/// The twin's cells with those a timer lattice shapes taken from its read at the measured
/// speeds (`there`): the slip's sd, the readings' kurtosis, the fan speed's broadband content
/// and the timer-lattice cell. On a lattice of levels n_k = 60 / (P tau k) (`crate::sensor`),
/// these are set by where each shaft's true pulse gap falls between two levels, which runs
/// through a whole cycle as the speed moves by one level (0.7 % at the motor with 60 pulses
/// and a 4 us timer; example `tachometer_kurtosis`), while a twin of another model form places
/// the speed to a few tenths of a per cent at best. The levels (means) and the lines stay the
/// twin's own; the slip's percentiles are set aside (`cells::label_cells`)
/// (docs/decisions/gap-sensor-cells.md). Each such cell's standard error also carries the
/// RMS of its change to the reads in `shifted` (the twin read one standard error of the
/// measured means away): where a shaft's speed ripple is small against a level step, its
/// kurtosis swings by tenths over a few hundredths of an rpm.
pub(super) fn at_measured_speeds(
    mut own: Features,
    there: &Features,
    shifted: &[Features],
) -> Features {
    for (i, c) in CELLS.iter().enumerate() {
        if matches!(
            (c.window, c.signal, c.statistic),
            (Window::Steady, Signal::Slip, Statistic::Std)
                | (
                    Window::Steady,
                    _,
                    Statistic::Kurtosis | Statistic::TimerLattice
                )
                | (Window::Steady, Signal::DrivenSpeed, Statistic::Std)
        ) {
            let c = there.cells[i];
            let moves: Vec<f64> = shifted
                .iter()
                .map(|f| f.cells[i].value - c.value)
                .filter(|d| d.is_finite())
                .collect();
            let spread = if moves.is_empty() {
                0.0
            } else {
                fom::stats::rms(&moves)
            };
            own.cells[i] = Measure {
                value: c.value,
                se: c.se.hypot(spread),
            };
        }
    }
    own
}

/// The tachometer sensor for a label: `pulses` per revolution on a timer of `tau` s, with the
/// counting gate, the edges' jitter and the share of missing pulses of the identified sensor
/// `id`, and, on each shaft, the white noise left once its own scatter is taken from the
/// measured noise (all of the white noise about the levels of a timer lattice the sensor stage
/// read), of the shape whose second differences read `id.twin_noise_excess_kurtosis` per shaft
/// (`sensor_id::noise_kurtosis`; 0: Gaussian).
pub(super) fn tachometer_sensor(
    lt: &LabelTwin,
    (pulses, tau): (u32, f64),
    id: &IdentifiedSensor,
    (model_ratio, ratio): (f64, f64),
) -> Option<SensorModel> {
    let shape = id.twin_noise_excess_kurtosis;
    let mut s = SensorModel {
        sample_rate_hz: 1.0 / lt.sample_interval_s,
        pulses_per_rev: pulses,
        speed_noise_rpm: [0.0; 2],
        timer_resolution_s: tau,
        missing_pulse_share: id.twin_missing_pulse_share,
        gate_s: id.twin_gate_s,
        edge_jitter_s: id.twin_edge_jitter_s,
        noise_excess_kurtosis: [0.0; 2],
        // The readings' autocorrelation where their noise is correlated over a few readings.
        noise_taps: lt.noise_taps,
        seed: 0x7713,
    };
    let rec = twin_recording(&lt.baseline_rows, model_ratio, ratio, lt.slip_shift_pct, &s);
    let quiet = steady_speeds(&rec, ratio, lt.read()).ok()?;
    let own_each = [noise_sd(&quiet.driver_rpm), noise_sd(&quiet.driven_rpm)];
    // On a read lattice the measured noise is the white noise about its levels, which the
    // sensor adds after the timer (`crate::sensor::measure`): all of it is added.
    s.speed_noise_rpm = [0, 1].map(|i| {
        let (measured, own) = (lt.noise_rpm[i], own_each[i]);
        if lt.lattice_read {
            measured
        } else {
            (measured * measured - own * own).max(0.0).sqrt()
        }
    });
    s.noise_excess_kurtosis =
        [0, 1].map(|i| added_noise_kurtosis(shape[i], s.speed_noise_rpm[i], own_each[i]));
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::baseline::tests::label_twin_of;
    use crate::gap::cells::{fit_cell, label_cells, set_aside_on_counter, set_aside_on_lattice};
    use crate::gap::features::Read;

    /// A 60-pulse tachometer on a 4 us timer with `noise_rpm` of white noise on each shaft.
    fn timer_4us(noise_rpm: f64) -> SensorModel {
        SensorModel {
            timer_resolution_s: 4e-6,
            speed_noise_rpm: [noise_rpm; 2],
            ..SensorModel::default()
        }
    }

    fn drive_ctx() -> BandContext {
        BandContext {
            blades: 8,
            belt_length_m: 1.6,
            driver_diameter_m: 0.1,
        }
    }

    /// Rows of a drive at `n1` rpm on the motor and a slip of 0.5 % (R = 2), with a 1 Hz
    /// wobble of 0.2 rpm on both shafts, over 6 s.
    fn drive_rows(n1: f64) -> Vec<fom::OutputRow> {
        (0..=6000)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let w = 1.0 + 0.2 / n1 * (2.0 * std::f64::consts::PI * t).sin();
                fom::OutputRow {
                    time_s: t,
                    driver_rpm: n1 * w,
                    driven_rpm: 0.5 * n1 * 0.995 * w,
                    ..Default::default()
                }
            })
            .collect()
    }

    #[test]
    fn a_twin_a_fraction_of_a_lattice_step_off_is_read_at_the_measured_speeds() {
        // A 60-pulse tachometer on a 4 us timer: at 1750 rpm the motor's readings sit on
        // levels 0.7 % apart. The twin runs 0.25 % faster than the plant: about a third of
        // a level, which moves the readings' kurtosis and the slip's spread far beyond their
        // errors while leaving the drive as it is.
        let (sensor, ctx) = (timer_4us(1.0), drive_ctx());
        let rec = twin_recording(&drive_rows(1750.0), 2.0, 2.0, 0.0, &sensor);
        let measured = features(&rec, 2.0, &ctx, Read::Own).unwrap();
        let twin_rows = drive_rows(1750.0 * 1.0025);
        let cell = |statistic, signal| {
            cell_index(Cell::new(Window::Steady, signal, statistic, Band::Level))
        };
        let kurtosis = cell(Statistic::Kurtosis, DriverSpeed);
        let spread = cell(Statistic::Std, Signal::Slip);
        let level = cell(Statistic::Mean, DriverSpeed);
        let z = |f: &Features, i: usize| {
            let (m, t) = (measured.cells[i], f.cells[i]);
            (m.value - t.value) / m.se.hypot(t.se)
        };
        let read = |lattice_read| {
            let lt = label_twin_of(measured.clone(), lattice_read);
            twin_features(&lt, &twin_rows, &sensor, 2.0, 2.0, &ctx).unwrap()
        };
        let (own, there) = (read(false), read(true));
        for i in [kurtosis, spread] {
            assert!(
                z(&own, i).abs() > 5.0,
                "{}: own {}",
                CELLS[i].name(),
                z(&own, i)
            );
            assert!(
                z(&there, i).abs() < 3.0,
                "{}: {}",
                CELLS[i].name(),
                z(&there, i)
            );
        }
        // The levels stay the twin's own: 0.25 % above the measured.
        for f in [&own, &there] {
            let r = f.cells[level].value / measured.cells[level].value;
            assert!((r - 1.0025).abs() < 2e-4, "{r}");
        }
        // The slip's percentiles are set aside with a lattice read, and only they.
        for read in [false, true] {
            let lt = label_twin_of(measured.clone(), read);
            let cells = label_cells(&lt, &there);
            for (i, c) in CELLS.iter().enumerate() {
                let aside = read && set_aside_on_lattice(c);
                let usable = fit_cell(i, cells[i]);
                if aside {
                    assert!(!usable, "{} kept with a lattice read", c.name());
                } else if c.statistic != Statistic::Wasserstein1 && c.window == Window::Steady {
                    assert!(usable, "{} set aside (lattice read: {read})", c.name());
                }
            }
        }
        // With a counter read, the timer-lattice cells too, and only they besides.
        let mut lt = label_twin_of(measured.clone(), true);
        lt.sensor.gate_s = 4e-3;
        let cells = label_cells(&lt, &there);
        let mut lattice_cells = 0;
        for (i, c) in CELLS.iter().enumerate() {
            let usable = fit_cell(i, cells[i]);
            if set_aside_on_counter(c) {
                lattice_cells += 1;
                assert!(!usable, "{} kept with a counter read", c.name());
            } else if !set_aside_on_lattice(c)
                && c.statistic != Statistic::Wasserstein1
                && c.window == Window::Steady
            {
                assert!(usable, "{} set aside with a counter read", c.name());
            }
        }
        assert!(lattice_cells > 0);
    }

    #[test]
    fn a_lattice_cell_carries_where_the_measured_mean_speed_may_put_the_plant() {
        // A 60-pulse tachometer on a 4 us timer with 0.3 rpm of noise: the motor's levels
        // lie about 12 rpm apart and its ripple is 0.2 rpm, so the share of readings on each
        // level, and with it their kurtosis, turns with hundredths of an rpm of mean speed,
        // which the recording knows only to its standard error.
        let (sensor, ctx) = (timer_4us(0.3), drive_ctx());
        let rows = drive_rows(1750.0);
        let measured = features(
            &twin_recording(&rows, 2.0, 2.0, 0.0, &sensor),
            2.0,
            &ctx,
            Read::Own,
        )
        .unwrap();
        let cell = |statistic, signal| {
            cell_index(Cell::new(Window::Steady, signal, statistic, Band::Level))
        };
        let (kurtosis, level) = (
            cell(Statistic::Kurtosis, DriverSpeed),
            cell(Statistic::Mean, DriverSpeed),
        );
        let level_se = measured.cells[level].se;
        let read = |level_se: f64| {
            let mut m = measured.clone();
            m.cells[level].se = level_se;
            let lt = label_twin_of(m, true);
            twin_features(&lt, &rows, &sensor, 2.0, 2.0, &ctx).unwrap()
        };
        let (exact, known) = (read(0.0), read(level_se));
        // The twin read one standard error of the mean speed away, by hand.
        let lt = label_twin_of(measured.clone(), true);
        let own = twin_features(
            &label_twin_of(measured.clone(), false),
            &rows,
            &sensor,
            2.0,
            2.0,
            &ctx,
        )
        .unwrap();
        let scale = measured.cells[level].value / own.cells[level].value;
        let moved: Vec<f64> = [1.0, -1.0]
            .iter()
            .map(|sign| {
                let k = scale * (1.0 + sign * level_se / measured.cells[level].value);
                let rec = scaled_twin_recording(&rows, 2.0, 2.0, 0.0, [k, 1.0], &sensor);
                let f = features(&rec, 2.0, &ctx, lt.read()).unwrap();
                f.cells[kurtosis].value - known.cells[kurtosis].value
            })
            .collect();
        let swing = (moved.iter().map(|d| d * d).sum::<f64>() / 2.0).sqrt();
        // Here one standard error of the mean (0.025 rpm) swings the kurtosis by several
        // times the read's own error.
        let own_se = exact.cells[kurtosis].se;
        assert!(
            level_se > 0.0 && swing > 2.0 * own_se,
            "{level_se} {swing} {own_se}"
        );
        let (a, b) = (exact.cells[kurtosis], known.cells[kurtosis]);
        assert_eq!(a.value.to_bits(), b.value.to_bits());
        assert!(
            (b.se - a.se.hypot(swing)).abs() < 1e-9 * b.se,
            "{a:?} {b:?} {swing}"
        );
        // The levels are the twin's own, with their own errors.
        assert_eq!(exact.cells[level], known.cells[level]);
    }

    #[test]
    fn a_variants_own_line_is_its_change_between_quiet_reads() {
        // A fan pulley's 1x line of 0.25 rpm on the driven shaft, read by a 60-pulse
        // tachometer on a 4 us timer with 0.3 rpm of noise: through the sensor the change
        // between the two runs has a standard error of its own floor; read quietly the line
        // stands clear of it.
        let (sensor, ctx) = (timer_4us(0.3), drive_ctx());
        let with_line = |amplitude_rpm: f64| -> Vec<fom::OutputRow> {
            drive_rows(1750.0)
                .into_iter()
                .map(|mut r| {
                    let f2_hz = r.driven_rpm / 60.0;
                    r.driven_rpm +=
                        amplitude_rpm * (2.0 * std::f64::consts::PI * f2_hz * r.time_s).sin();
                    r
                })
                .collect()
        };
        let line = cell_index(Cell::new(
            Window::Steady,
            DrivenSpeed,
            Statistic::Amplitude,
            Band::Driven1x,
        ));
        let measured = features(
            &twin_recording(&with_line(0.0), 2.0, 2.0, 0.0, &sensor),
            2.0,
            &ctx,
            Read::Own,
        )
        .unwrap();
        let mut lt = label_twin_of(measured, false);
        lt.sensor = sensor;
        lt.baseline_rows = with_line(0.0);
        lt.baseline = twin_features(&lt, &lt.baseline_rows, &sensor, 2.0, 2.0, &ctx).unwrap();
        let rows = with_line(0.25);
        let read = twin_features(&lt, &rows, &sensor, 2.0, 2.0, &ctx).unwrap();
        let quiet = variant_features(&lt, &rows, &[line], (2.0, 2.0), &ctx).unwrap();
        let (a, b) = (read.cells[line], lt.baseline.cells[line]);
        let (q, noisy_se) = (quiet.cells[line], a.se.hypot(b.se));
        let change = q.value - b.value;
        assert!(
            change > 0.0 && q.se < 0.25 * noisy_se && change > 4.0 * q.se,
            "quiet change {change} (se {}), read through the sensor {} (se {noisy_se})",
            q.se,
            a.value - b.value
        );
        // Every other cell is the sensor's reading.
        for (i, (x, y)) in quiet.cells.iter().zip(&read.cells).enumerate() {
            if i != line {
                assert_eq!(x.value.to_bits(), y.value.to_bits(), "{}", CELLS[i].name());
            }
        }
    }
}
