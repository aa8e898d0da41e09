//! Writes a measured-data set (`belt-measurements/1`) made by the independent lumped-parameter
//! simulator (`beltwin_tests::lumped`) of the default drive: the "other simulator" of
//! `docs/validation/gap.md`, "Another simulator's data".
//!
//! ```sh
//! cargo run --release -p beltwin-tests --example lumped -- DIR [--duration S] [--drag NM]
//!     [--creep FACTOR] [--labels d0=0.424,d1=0.421,...] [--seed N] [--from S]
//!     [--runout M] [--timer-resolution S]
//! ```
//! One recording per label, the default 60-pulse tachometer with 1 rpm noise; `--from S`:
//! recordings that start S seconds after the motor start, in steady running; `--runout M`: the
//! fan pulley's runout, m; `--timer-resolution S`: the tachometer's timer, s.

use beltwin_tests::lumped::{write_dataset, LumpedRun};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first() else {
        eprintln!(
            "usage: lumped DIR [--duration S] [--drag NM] [--creep F] [--labels L=D,...] \
             [--seed N] [--from S] [--runout M] [--timer-resolution S]"
        );
        std::process::exit(2);
    };
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let num = |flag: &str, default: f64| {
        value(flag).map_or(default, |v| {
            v.parse().unwrap_or_else(|_| {
                eprintln!("{flag}: `{v}` is not a number");
                std::process::exit(2)
            })
        })
    };
    let labels: Vec<(String, f64)> = value("--labels")
        .unwrap_or_else(|| "d0=0.424,d1=0.421,d2=0.418,d3=0.416".into())
        .split(',')
        .map(|p| {
            let (l, d) = p
                .split_once('=')
                .expect("--labels takes LABEL=DISTANCE,...");
            (l.to_string(), d.parse().expect("a distance in m"))
        })
        .collect();
    let labels: Vec<(&str, f64)> = labels.iter().map(|(l, d)| (l.as_str(), *d)).collect();
    let run = LumpedRun {
        extra_drag_nm: num("--drag", 0.0),
        creep_stiffness_factor: num("--creep", 1.0),
        from_s: num("--from", 0.0),
        driven_runout_m: num("--runout", 0.0),
        timer_resolution_s: num("--timer-resolution", 0.0),
        ..LumpedRun::at(0.42, num("--duration", 4.0))
    };
    let seed = num("--seed", 1.0) as u64 * 1000;
    let cfg = beltwin_tests::default_drive();
    let written = write_dataset(std::path::Path::new(dir), &cfg, &labels, &run, seed)
        .unwrap_or_else(|e| {
            eprintln!("error: {e}");
            std::process::exit(1)
        });
    for ((file, slip), (_, d)) in written.iter().zip(&labels) {
        println!("{file}: d {d} m, final slip {slip:.4} %");
    }
}
