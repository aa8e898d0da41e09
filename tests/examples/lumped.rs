//! Writes a measured-data set (`belt-measurements/1`) made by the independent lumped-parameter
//! simulator (`beltwin_tests::lumped`) of the default drive: the "other simulator" of issue 11.
//!
//! ```sh
//! cargo run --release -p beltwin-tests --example lumped -- DIR [--duration S] [--drag NM]
//!     [--creep FACTOR] [--labels d0=0.424,d1=0.421,...] [--seed N] [--from S]
//! ```
//! One recording per label, the default 60-pulse tachometer with 1 rpm noise.

use beltwin_tests::lumped::{simulate, LumpedRun};
use twin::sensor::{append_synthetic_run, SensorModel};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first() else {
        eprintln!("usage: lumped DIR [--duration S] [--drag NM] [--creep F] [--labels L=D,...] [--seed N]");
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
    let cfg = beltwin_tests::default_drive();
    std::fs::create_dir_all(dir).expect("the data set directory");
    let seed = num("--seed", 1.0) as u64;
    for (k, (label, d)) in labels.iter().enumerate() {
        let run = LumpedRun {
            extra_drag_nm: num("--drag", 0.0),
            creep_stiffness_factor: num("--creep", 1.0),
            ..LumpedRun::at(*d, num("--duration", 4.0))
        };
        let mut rows = simulate(&cfg, &run);
        // `--from S`: a recording that starts in steady running, S s after the motor start
        // (times restart at 0).
        let from = num("--from", 0.0);
        rows.retain(|r| r.time_s >= from - 1e-9);
        for r in &mut rows {
            r.time_s -= from;
        }
        let sensor = SensorModel {
            seed: seed * 1000 + k as u64,
            ..SensorModel::default()
        };
        let at =
            beltwin_tests::at_distance(&cfg, *d).expect("the drive moves to the label's distance");
        let file = append_synthetic_run(std::path::Path::new(dir), label, &at, &rows, &sensor)
            .expect("the recording is written");
        println!(
            "{file}: d {d} m, final slip {:.4} %",
            beltwin_tests::lumped::final_slip_pct(&rows, 0.5)
        );
    }
}
