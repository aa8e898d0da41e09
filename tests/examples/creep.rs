//! Writes a measured-data set (`belt-measurements/1`) made by the continuous-belt creep
//! simulator (`beltwin_tests::creep`) of the default drive: the third simulator of the
//! model-form confusion matrix (`docs/validation/gap-model-forms.md`).
//!
//! ```sh
//! cargo run --release -p beltwin-tests --example creep -- DIR [--duration S] [--from S]
//!     [--labels d0=0.424,d1=0.421,...] [--seed N] [--effect NAME:KEY=VALUE,...]...
//!     [--gate S] [--jitter S] [--fan-scale F] [--tension-reading SHARE]
//! ```
//! One recording per label, read by a counter (M/T method, 60 pulses, 4 ms gate, 1.5 us edge
//! jitter); `--effect` (repeatable) switches on a catalogue effect with the keys of its
//! `[effects.<name>]` table, with the creep model's own physics of it (`tachometer:` sets the
//! counter's pulses, clock and missed pulses); `--from S`: recordings that start S seconds
//! after the motor start; `--fan-scale F`: the fan law's coefficient times F (a throttled fan:
//! a second load level); `--tension-reading SHARE`: each run gives the belt's static tension as
//! a tension meter with a standard deviation of SHARE of its reading reads it.

use beltwin_tests::creep::{write_dataset, CounterSensor, CreepRun};
use beltwin_tests::example_args::{fail, ExampleArgs};

fn main() {
    let args = ExampleArgs::from_env();
    let Some(dir) = args.dir() else {
        eprintln!(
            "usage: creep DIR [--duration S] [--from S] [--labels L=D,...] [--seed N] \
             [--effect NAME:KEY=VALUE,...]... [--gate S] [--jitter S] [--fan-scale F] \
             [--tension-reading SHARE]"
        );
        std::process::exit(2);
    };
    let labels = args.labels();
    let labels: Vec<(&str, f64)> = labels.iter().map(|(l, d)| (l.as_str(), *d)).collect();
    let mut cfg = beltwin_tests::default_drive();
    if let Some(load) = cfg.driven.load.as_mut() {
        load.fan_nm_s2 *= args.num("--fan-scale", 1.0);
    }
    for spec in args.values("--effect") {
        cfg.effects
            .set_from_spec(&spec)
            .unwrap_or_else(|e| fail(format!("--effect {spec}: {e}")));
    }
    let sensor = CounterSensor {
        gate_s: args.num("--gate", CounterSensor::default().gate_s),
        edge_jitter_s: args.num("--jitter", CounterSensor::default().edge_jitter_s),
        ..CounterSensor::default()
    };
    let run = CreepRun {
        from_s: args.num("--from", 0.0),
        sensor,
        tension_reading_sd_share: args.values("--tension-reading").last().map(|v| {
            v.parse()
                .unwrap_or_else(|_| fail(format!("--tension-reading {v}: not a number")))
        }),
        ..CreepRun::at(0.42, args.num("--duration", 5.0))
    };
    let seed = args.seed();
    let written = write_dataset(std::path::Path::new(dir), &cfg, &labels, &run, seed)
        .unwrap_or_else(|e| fail(e.to_string()));
    for ((file, slip), (_, d)) in written.iter().zip(&labels) {
        println!("{file}: d {d} m, final slip {slip:.4} %");
    }
}
