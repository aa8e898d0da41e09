//! Each measured data set's noise scatter per shaft, as `rom gap` reads it
//! (`twin::gap::features::noise_scatter`): per recording the scatter about a 7-reading moving
//! average over the first differences' white level, and per data set the mean over its
//! recordings against `CORRELATED_NOISE_RATIO`, above which `rom gap` takes the shaft's sensor
//! noise as correlated over a few readings (docs/decisions/correlated-sensor-noise.md).
//!
//! `cargo run --release -p beltwin-twin --example noise_scatter -- DIR [DIR ...]`
//! (each DIR a data set in the measured-data exchange format; the default drive's geometry,
//! eight fan blades).

use fom::DriveConfig;
use twin::gap::band_context;
use twin::gap::features::{
    correlated_noise, features, mean_scatter_ratio, Read, CORRELATED_NOISE_RATIO,
};
use twin::measured::read_dataset;

fn main() {
    let cfg = DriveConfig::default_hvac();
    println!("data set,recordings,driver ratio,driven ratio,driver correlated,driven correlated");
    for dir in std::env::args().skip(1) {
        let set = match read_dataset(std::path::Path::new(&dir), 100) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{dir}: {e}");
                std::process::exit(1);
            }
        };
        let ctx = band_context(&cfg, &set);
        let ratio = set.speed_ratio(&cfg);
        let read: Vec<_> = set
            .recordings
            .iter()
            .filter_map(|r| features(r, ratio, &ctx, Read::Own).ok())
            .collect();
        let mean = mean_scatter_ratio(read.iter());
        let correlated = correlated_noise(read.iter());
        println!(
            "{dir},{},{:.3},{:.3},{},{}",
            read.len(),
            mean[0],
            mean[1],
            correlated[0],
            correlated[1]
        );
    }
    eprintln!("threshold {CORRELATED_NOISE_RATIO}");
}
