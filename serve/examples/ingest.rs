//! Ingestion benchmark of the online twin: N drives (default 100) at 1 kHz each for S seconds
//! of their clock (default 30), fed to one engine on one thread with a real SQLite database,
//! as 0.1 s batches interleaved across drives. Prints the real-time factor (stream seconds per
//! wall second), the time spent buffering vs diagnosing, and the latency from a segment's
//! close to its diagnosis stored and published. With `gap`, background gap checks run all the
//! while (a check due after every segment, one at a time on one thread of their own), and
//! the latency is given apart for segments closed while a check ran. Figures:
//! docs/validation/serve.md.
//!
//! `cargo run --release -p beltwin-serve --example ingest [-- DRIVES SECONDS [gap]]`

use std::collections::BTreeMap;
use std::time::Instant;

use serve::config::Models;
use serve::gap_check::{DueRule, GapSettings};
use serve::store::Store;
use serve::{Batch, Engine};

const RATE_HZ: f64 = 1000.0;
const BATCH: usize = 100;

/// Deterministic noise in [-1, 1] (xorshift64, Marsaglia, J. Stat. Softw. 8(14), 2003).
struct Noise(u64);

impl Noise {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let drives: usize = args.first().map_or(100, |a| a.parse().expect("DRIVES"));
    let seconds: f64 = args.get(1).map_or(30.0, |a| a.parse().expect("SECONDS"));
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&dir.path().join("bench.db"), None).unwrap();
    let mut engine = Engine::new(Models::shipped().unwrap(), Some(store), Vec::new()).unwrap();
    if args.get(2).is_some_and(|a| a == "gap") {
        let rule = DueRule {
            every_segments: 1,
            misfit_segments: 0,
            misfit_window: 10,
        };
        let settings = GapSettings {
            rule,
            ..GapSettings::default()
        };
        engine.start_gap_checks(settings).unwrap();
    }
    let mut during_check = Vec::new();
    let mut noise = Noise(0x9E37_79B9_7F4A_7C15);
    let n_batches = (seconds * RATE_HZ) as usize / BATCH;
    let (mut ingest_s, mut worst_batch_s) = (0.0, 0.0f64);
    let mut latencies = Vec::new();
    let start = Instant::now();
    for k in 0..n_batches {
        for d in 0..drives {
            let t0 = (k * BATCH) as f64 / RATE_HZ;
            let time_s: Vec<f64> = (0..BATCH).map(|i| t0 + i as f64 / RATE_HZ).collect();
            let driver: Vec<f64> = (0..BATCH).map(|_| 1500.0 + noise.next()).collect();
            // Slip 0.7 % on the 2:1 drive (seed paper eq. 1), 1 rpm of noise.
            let driven: Vec<f64> = driver
                .iter()
                .map(|n1| n1 / 2.0 * (1.0 - 0.007) + noise.next())
                .collect();
            let b = Batch {
                drive: format!("drive-{d:03}"),
                seq: Some(k as u64),
                time_s,
                driver_rpm: driver,
                driven_rpm: driven,
                extra: BTreeMap::new(),
            };
            let segments = engine.counters().segments;
            let checking = engine.gap_queue().0.is_some();
            let t = Instant::now();
            engine.ingest(b).unwrap();
            let dt = t.elapsed().as_secs_f64();
            if engine.counters().segments > segments {
                let view = engine.view();
                let v = view.read().unwrap();
                if let Some(ms) = v.drives[&format!("drive-{d:03}")].publish_latency_ms {
                    if checking {
                        during_check.push(ms);
                    } else {
                        latencies.push(ms);
                    }
                }
            } else {
                ingest_s += dt;
                worst_batch_s = worst_batch_s.max(dt);
            }
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let c = engine.counters().clone();
    let checks = (c.gap_checks, c.gap_checks_failed);
    let quantiles = |mut x: Vec<f64>| {
        x.sort_by(f64::total_cmp);
        let q = |p: f64| x[((x.len() - 1) as f64 * p).round() as usize];
        if x.is_empty() {
            "none".to_string()
        } else {
            format!(
                "median {:.1}, p90 {:.1}, max {:.1} ({} segments)",
                q(0.5),
                q(0.9),
                q(1.0),
                x.len()
            )
        }
    };
    let readings = c.readings as f64;
    println!(
        "{drives} drives x {seconds} s at {RATE_HZ} Hz: {readings} readings, {} segments",
        c.segments
    );
    println!(
        "wall {wall:.2} s; real-time factor {:.2} (stream s per wall s)",
        seconds / wall
    );
    println!(
        "buffering only: {:.3} s, {:.2} M readings/s, worst batch {:.3} ms",
        ingest_s,
        readings / ingest_s / 1e6,
        worst_batch_s * 1e3
    );
    println!(
        "segment close -> stored and published, ms: {}",
        quantiles(latencies)
    );
    println!(
        "... while a gap check ran, ms: {}; gap checks finished: {} ({} failed)",
        quantiles(during_check),
        checks.0,
        checks.1
    );
    println!(
        "diagnosis share of one core: {:.2} cores needed for real time",
        (wall - ingest_s) / seconds
    );
}
