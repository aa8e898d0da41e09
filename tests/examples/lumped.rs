//! Writes a measured-data set (`belt-measurements/1`) made by the independent lumped-parameter
//! simulator (`beltwin_tests::lumped`) of the default drive: the "other simulator" of
//! `docs/validation/gap.md`, "Another simulator's data".
//!
//! ```sh
//! cargo run --release -p beltwin-tests --example lumped -- DIR [--duration S] [--drag NM]
//!     [--creep FACTOR] [--labels d0=0.424,d1=0.421,...] [--seed N] [--from S]
//!     [--runout M] [--timer-resolution S] [--fan-scale F]
//! ```
//! One recording per label, the default 60-pulse tachometer with 1 rpm noise; `--from S`:
//! recordings that start S seconds after the motor start, in steady running; `--runout M`: the
//! fan pulley's runout, m; `--timer-resolution S`: the tachometer's timer, s; `--fan-scale F`:
//! the fan law's coefficient times F (a throttled fan: a second load level).

use beltwin_tests::example_args::ExampleArgs;
use beltwin_tests::lumped::{write_dataset, LumpedRun};

fn main() {
    let args = ExampleArgs::from_env();
    let Some(dir) = args.dir() else {
        eprintln!(
            "usage: lumped DIR [--duration S] [--drag NM] [--creep F] [--labels L=D,...] \
             [--seed N] [--from S] [--runout M] [--timer-resolution S] [--fan-scale F]"
        );
        std::process::exit(2);
    };
    let labels = args.labels();
    let labels: Vec<(&str, f64)> = labels.iter().map(|(l, d)| (l.as_str(), *d)).collect();
    let run = LumpedRun {
        extra_drag_nm: args.num("--drag", 0.0),
        creep_stiffness_factor: args.num("--creep", 1.0),
        from_s: args.num("--from", 0.0),
        driven_runout_m: args.num("--runout", 0.0),
        timer_resolution_s: args.num("--timer-resolution", 0.0),
        ..LumpedRun::at(0.42, args.num("--duration", 4.0))
    };
    let seed = args.seed();
    let mut cfg = beltwin_tests::default_drive();
    if let Some(load) = cfg.driven.load.as_mut() {
        load.fan_nm_s2 *= args.num("--fan-scale", 1.0);
    }
    let written = write_dataset(std::path::Path::new(dir), &cfg, &labels, &run, seed)
        .unwrap_or_else(|e| {
            eprintln!("error: {e}");
            std::process::exit(1)
        });
    for ((file, slip), (_, d)) in written.iter().zip(&labels) {
        println!("{file}: d {d} m, final slip {slip:.4} %");
    }
}
