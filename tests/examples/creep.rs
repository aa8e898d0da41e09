//! Writes a measured-data set (`belt-measurements/1`) made by the continuous-belt creep
//! simulator (`beltwin_tests::creep`) of the default drive: the third simulator of the
//! model-form confusion matrix (`docs/validation/gap-model-forms.md`).
//!
//! ```sh
//! cargo run --release -p beltwin-tests --example creep -- DIR [--duration S] [--from S]
//!     [--labels d0=0.424,d1=0.421,...] [--seed N] [--effect NAME:KEY=VALUE,...]...
//!     [--gate S] [--jitter S]
//! ```
//! One recording per label, read by a counter (M/T method, 60 pulses, 4 ms gate, 1.5 us edge
//! jitter); `--effect` (repeatable) switches on a catalogue effect with the keys of its
//! `[effects.<name>]` table, with the creep model's own physics of it (`tachometer:` sets the
//! counter's pulses, clock and missed pulses); `--from S`: recordings that start S seconds
//! after the motor start.

use beltwin_tests::creep::{write_dataset, CounterSensor, CreepRun};

fn fail(message: String) -> ! {
    eprintln!("error: {message}");
    std::process::exit(1)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first().filter(|a| !a.starts_with("--")) else {
        eprintln!(
            "usage: creep DIR [--duration S] [--from S] [--labels L=D,...] [--seed N] \
             [--effect NAME:KEY=VALUE,...]... [--gate S] [--jitter S]"
        );
        std::process::exit(2);
    };
    let value = |flag: &str| {
        args.iter().position(|a| a == flag).map(|i| {
            args.get(i + 1)
                .cloned()
                .unwrap_or_else(|| fail(format!("{flag} needs a value")))
        })
    };
    let num = |flag: &str, default: f64| {
        value(flag).map_or(default, |v| {
            v.parse()
                .unwrap_or_else(|_| fail(format!("{flag}: `{v}` is not a number")))
        })
    };
    let labels: Vec<(String, f64)> = value("--labels")
        .unwrap_or_else(|| "d0=0.424,d1=0.421,d2=0.418,d3=0.416".into())
        .split(',')
        .map(|p| {
            let (l, d) = p
                .split_once('=')
                .unwrap_or_else(|| fail(format!("--labels: `{p}` is not LABEL=DISTANCE")));
            let d = d
                .parse()
                .unwrap_or_else(|_| fail(format!("--labels: `{d}` is not a distance in m")));
            (l.to_string(), d)
        })
        .collect();
    let labels: Vec<(&str, f64)> = labels.iter().map(|(l, d)| (l.as_str(), *d)).collect();
    let mut cfg = beltwin_tests::default_drive();
    for (i, a) in args.iter().enumerate() {
        if a == "--effect" {
            let spec = args
                .get(i + 1)
                .unwrap_or_else(|| fail("--effect needs a value".into()));
            cfg.effects
                .set_from_spec(spec)
                .unwrap_or_else(|e| fail(format!("--effect {spec}: {e}")));
        }
    }
    let sensor = CounterSensor {
        gate_s: num("--gate", CounterSensor::default().gate_s),
        edge_jitter_s: num("--jitter", CounterSensor::default().edge_jitter_s),
        ..CounterSensor::default()
    };
    let run = CreepRun {
        from_s: num("--from", 0.0),
        sensor,
        ..CreepRun::at(0.42, num("--duration", 5.0))
    };
    let seed = num("--seed", 1.0) as u64 * 1000;
    let written = write_dataset(std::path::Path::new(dir), &cfg, &labels, &run, seed)
        .unwrap_or_else(|e| fail(e.to_string()));
    for ((file, slip), (_, d)) in written.iter().zip(&labels) {
        println!("{file}: d {d} m, final slip {slip:.4} %");
    }
}
