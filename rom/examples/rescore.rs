//! Scores a surrogate file on the full-order runs stored in `rom validate --json` files,
//! without running the full-order model again: per file, the mean slip within the accuracy
//! target's tolerance and the 90 % interval's coverage, by interval part (creep plateau, onset,
//! knee band), then pooled by region of the settled slip. Two models can so be compared on the same
//! held-out runs (`docs/validation/surrogate.md`).
//!
//! `cargo run --release -p beltwin-rom --example rescore -- MODEL V1.json [V2.json ...]`;
//! `VERBOSE=1` lists every run (part, capacity u, d, mu, T, full-order and surrogate mean,
//! error). Refused predictions are listed and left out, as `rom validate` does.
use rom::features::capacity_feature_n;
use rom::surrogate::{interval_part, IntervalPart};
use rom::validate::{mean_slip_tolerance_pct, read_held_out};
use std::path::Path;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 3 {
        eprintln!("usage: rescore MODEL V1.json [V2.json ...]");
        std::process::exit(2);
    }
    let fail = |e: rom::RomError| -> ! {
        eprintln!("error: {e}");
        std::process::exit(1)
    };
    let f = rom::SurrogateFile::load(Path::new(&a[1])).unwrap_or_else(|e| fail(e));
    let s = &f.surrogate;
    let cfg = s.config().unwrap_or_else(|e| fail(e));
    let band = s.knee_band_upper_n(&cfg);
    let sha = f.header.config_sha256.clone();
    let mut pooled = [[0usize; 2]; 2]; // region (creep, knee) -> [n, within]
    let mut worst = [0.0f64; 2];
    for path in &a[2..] {
        let (seed, runs, _) = read_held_out(Path::new(path), &sha).unwrap_or_else(|e| fail(e));
        let mut tally = [[0usize; 3]; 3]; // part -> [n, within, covered]
        let mut sq = [0.0f64; 3];
        for r in &runs {
            let p = match s.predict_point(&cfg, &r.point) {
                Ok(p) => p,
                Err(e) => {
                    println!("  refused {e}");
                    continue;
                }
            };
            if s.beyond_trained_slip(p.mean_slip_pct).is_some() {
                continue;
            }
            let u = capacity_feature_n(&cfg, &r.point);
            let k = match interval_part(band, u, p.mean_slip_pct) {
                IntervalPart::Creep => 0,
                IntervalPart::Onset => 1,
                IntervalPart::KneeBand => 2,
            };
            let e = p.mean_slip_pct - r.mean_slip_pct;
            let reg = (r.mean_slip_pct >= 1.0) as usize;
            pooled[reg][0] += 1;
            pooled[reg][1] += (e.abs() <= mean_slip_tolerance_pct(r.mean_slip_pct)) as usize;
            worst[reg] = worst[reg].max(e.abs());
            tally[k][0] += 1;
            tally[k][1] += (e.abs() <= mean_slip_tolerance_pct(r.mean_slip_pct)) as usize;
            tally[k][2] += (e.abs() <= 1.645 * p.surrogate_std_pct) as usize;
            sq[k] += e * e;
            if std::env::var("VERBOSE").is_ok() {
                println!(
                    "  {k} u {:.1} d {:.5} mu {:.3} T {:.1} fom {:.3} rom {:.3} e {:+.3}",
                    u,
                    r.point.center_distance_m,
                    r.point.friction,
                    r.point.installation_tension_n,
                    r.mean_slip_pct,
                    p.mean_slip_pct,
                    e
                );
            }
        }
        let names = ["creep", "onset", "band"];
        let cols: Vec<String> = (0..3)
            .filter(|&k| tally[k][0] > 0)
            .map(|k| {
                format!(
                    "{} {}/{} within, {} cov, rms {:.3}",
                    names[k],
                    tally[k][1],
                    tally[k][0],
                    tally[k][2],
                    (sq[k] / tally[k][0] as f64).sqrt()
                )
            })
            .collect();
        println!("{seed}: {}", cols.join(" | "));
    }
    println!(
        "pooled: creep {}/{} within ({:.1} %, worst {:.3} pp), knee {}/{} within ({:.1} %, worst {:.3} pp)",
        pooled[0][1], pooled[0][0], 100.0 * pooled[0][1] as f64 / pooled[0][0] as f64, worst[0],
        pooled[1][1], pooled[1][0], 100.0 * pooled[1][1] as f64 / pooled[1][0] as f64, worst[1]
    );
}
