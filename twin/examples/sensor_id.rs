//! The sensor each measured data set's recordings show, as `rom gap`'s sensor stage reads it
//! (`twin::gap::sensor_id::identify_data_set`, over all of the data set's labels), as JSON, one
//! data set per line.
//!
//! `cargo run --release -p beltwin-twin --example sensor_id -- DIR [DIR ...]` (each DIR a data
//! set in the measured-data exchange format; the default drive's geometry).

use fom::DriveConfig;
use twin::gap::sensor_id::identify_data_set;
use twin::measured::read_dataset;

fn main() {
    let cfg = DriveConfig::default_hvac();
    for dir in std::env::args().skip(1) {
        let set = read_dataset(std::path::Path::new(&dir), 100).unwrap_or_else(|e| {
            eprintln!("{dir}: {e}");
            std::process::exit(1);
        });
        let id = identify_data_set(&set, &set.labels(), set.speed_ratio(&cfg), &cfg);
        println!(
            "{dir}: {}",
            serde_json::to_string(&id).expect("the sensor serialises")
        );
    }
}
