//! The readings' noise shape (`twin::gap::sensor_id::noise_kurtosis`): a counter by the M/T
//! method (`beltwin_tests::creep::CounterSensor`), whose count of whole pulse gaps in its gate
//! alternates, reads the fan's speed with noise heavier-tailed than Gaussian; the sensor stage
//! identifies it, and the twin's tachometer read through it gives the counter's kurtosis cell.

use beltwin_tests::creep::{measure, simulate, CounterSensor, CreepRun};
use twin::gap::features::{
    cell_index, features, steady_speeds, Band, BandContext, Cell, Read, Signal, Statistic, Window,
};
use twin::gap::sensor_id::{identify, ShaftReadings};
use twin::sensor::{noise_kurtosis_for_second_differences, SensorModel};

#[test]
fn a_counters_noise_is_identified_and_the_twin_read_through_it_gives_its_kurtosis_cell() {
    let cfg = beltwin_tests::default_drive();
    let run = simulate(&cfg, &CreepRun::at(0.424, 3.0)).unwrap();
    let counter = measure(&run, &cfg, &CounterSensor::default(), 0.0);
    let ratio = cfg.transmission_ratio();
    let steady = steady_speeds(&counter, ratio, Read::Own).unwrap();
    let windows = [&steady.driver_rpm, &steady.driven_rpm].map(|rpm| ShaftReadings {
        sample_rate_hz: 1.0 / steady.dt_s,
        rpm,
    });
    let id = identify(&windows, &[true, false], &SensorModel::default());
    let [lo, hi] = id.noise_excess_kurtosis_interval90[1];
    assert!(lo > 0.0, "the fan's readings: [{lo}, {hi}] {id:?}");
    assert!(id.twin_noise_excess_kurtosis[1] > 0.0, "{id:?}");
    // The twin's tachometer (60 pulses, an exact timer) on the same true speeds with the
    // identified level and shape of the fan's noise, and with Gaussian noise.
    let twin = |k: f64| {
        let sensor = SensorModel {
            speed_noise_rpm: id.speed_noise_rpm,
            noise_excess_kurtosis: [0.0, noise_kurtosis_for_second_differences(k)],
            ..SensorModel::default()
        };
        twin::sensor::measure(&run.rows, &sensor)
    };
    let ctx = BandContext {
        blades: 8,
        belt_length_m: 1.6,
        driver_diameter_m: cfg.driver.pitch_diameter_m,
    };
    let cell = cell_index(Cell {
        window: Window::Steady,
        signal: Signal::DrivenSpeed,
        statistic: Statistic::Kurtosis,
        band: Band::Level,
    });
    let kurtosis = |rec| features(&rec, ratio, &ctx, Read::Own).unwrap().cells[cell];
    let measured = kurtosis(counter.clone());
    let z = |rec| {
        let t = kurtosis(rec);
        (t.value - measured.value) / t.se.hypot(measured.se)
    };
    let shaped = z(twin(id.twin_noise_excess_kurtosis[1]));
    assert!(
        shaped.abs() < 3.0,
        "shaped twin: z {shaped:+.2} ({measured:?})"
    );
    // Without the shape the twin's cell is off (what the diagnosis reported unexplained).
    let gaussian = z(twin(0.0));
    assert!(
        gaussian.abs() > shaped.abs(),
        "Gaussian twin: z {gaussian:+.2} vs {shaped:+.2}"
    );
}
