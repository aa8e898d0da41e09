//! The sensor each measured data set's recordings show, as `rom gap`'s sensor stage reads it
//! (`twin::gap::sensor_id::identify`), as JSON, one data set per line.
//!
//! `cargo run --release -p beltwin-twin --example sensor_id -- DIR [DIR ...]` (each DIR a data
//! set in the measured-data exchange format; the default drive's geometry).

use fom::DriveConfig;
use twin::gap::features::{steady_speeds, Read};
use twin::gap::sensor_id::{identify, ShaftReadings};
use twin::measured::read_dataset;
use twin::sensor::SensorModel;

fn main() {
    let cfg = DriveConfig::default_hvac();
    for dir in std::env::args().skip(1) {
        let set = match read_dataset(std::path::Path::new(&dir), 100) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{dir}: {e}");
                std::process::exit(1);
            }
        };
        let ratio = set.speed_ratio(&cfg);
        let speeds: Vec<_> = set
            .recordings
            .iter()
            .filter_map(|r| steady_speeds(r, ratio, Read::Own).ok())
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
        let id = identify(&windows, &driver, &SensorModel::from_config(&cfg));
        println!(
            "{dir}: {}",
            serde_json::to_string(&id).expect("the sensor serialises")
        );
    }
}
