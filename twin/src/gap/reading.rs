//! How the twin's runs are read: through the sensor the recordings show (`sensor_id`), with
//! each shaft's white noise beyond the sensor's own scatter, and, where the sensor stage read
//! a timer lattice, at the measured speeds for the cells that lattice shapes
//! (docs/decisions/gap-sensor-cells.md).

use super::baseline::LabelTwin;
use super::features::{
    cell_index, features, noise_sd, steady_speeds, Band, BandContext, Cell, Features, Read, Signal,
    Statistic, Window, CELLS,
};
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
    let own = features(&rec, ratio, ctx, Read::like(&lt.measured))?;
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
    let rec = scaled_twin_recording(rows, model_ratio, ratio, lt.slip_shift_pct, scale, sensor);
    let there = features(&rec, ratio, ctx, Read::like(&lt.measured))?;
    Ok(at_measured_speeds(own, &there))
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
/// (docs/decisions/gap-sensor-cells.md).
pub(super) fn at_measured_speeds(mut own: Features, there: &Features) -> Features {
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
            own.cells[i] = there.cells[i];
        }
    }
    own
}

/// The tachometer sensor for a label: `pulses` per revolution on a timer of `tau` s, a share
/// `missing` of its pulses missing, with, on each shaft, the white noise left once its own
/// scatter is taken from the measured noise (all of the white noise about the levels of a
/// timer lattice the sensor stage read), of the shape whose second differences read
/// `shape` per shaft (`sensor_id::noise_kurtosis`; 0: Gaussian).
pub(super) fn tachometer_sensor(
    lt: &LabelTwin,
    (pulses, tau): (u32, f64),
    missing: f64,
    shape: [f64; 2],
    (model_ratio, ratio): (f64, f64),
) -> Option<SensorModel> {
    let mut s = SensorModel {
        sample_rate_hz: 1.0 / lt.sample_interval_s,
        pulses_per_rev: pulses,
        speed_noise_rpm: [0.0; 2],
        timer_resolution_s: tau,
        missing_pulse_share: missing,
        noise_excess_kurtosis: [0.0; 2],
        seed: 0x7713,
    };
    let rec = twin_recording(&lt.baseline_rows, model_ratio, ratio, lt.slip_shift_pct, &s);
    let quiet = steady_speeds(&rec, ratio, Read::like(&lt.measured)).ok()?;
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
