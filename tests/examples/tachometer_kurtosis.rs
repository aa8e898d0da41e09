//! The gap diagnosis's tachometer feature: the timer lattice
//! (`twin::gap::features::timer_lattice_s`) and the excess kurtosis of the steady speeds read by
//! 60- and 360-pulse tachometers on timers of 0-5 us (and the 4.1 us of the long gap test), for the
//! default drive at d 0.424 m at full resolution (240 segments, 1e-5 s) and at the gap diagnosis's
//! reduced one (120 segments, 2e-5 s). The timer's quantisation makes the readings jump between
//! fixed levels; where the true pulse interval sits between them decides the kurtosis, so it swings
//! with the timer (`docs/validation/gap.md`, "The timer lattice"); the lattice's P tau does not.
//! Run: `cargo run --release -p beltwin-tests --example tachometer_kurtosis`.

use fom::{DesignPoint, RunOptions};
use twin::sensor::{measure, SensorModel};

/// Excess kurtosis m4 / m2^2 - 3.
fn kurtosis(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s2 = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n;
    let s4 = v.iter().map(|x| (x - m).powi(4)).sum::<f64>() / n;
    s4 / (s2 * s2) - 3.0
}

fn main() {
    {
        use rand::{Rng, SeedableRng};
        let tau: f64 = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(6).gen_range(2e-6..5e-6);
        println!("gap test's timer: {tau:e}");
    }
    let file = beltwin_tests::shipped_surrogate();
    let base = file.surrogate.config().unwrap();
    let q = DesignPoint {
        center_distance_m: 0.424,
        ..DesignPoint::nominal(&base)
    };
    let mut full = q.apply(&base).unwrap().into_inner();
    full.simulation.duration_s = 3.5;
    let mut red = full.clone();
    red.belt.segments = 120;
    red.simulation.step_s = fom::config::StepSize::Seconds(2e-5);
    for (name, cfg) in [("full", &full), ("reduced", &red)] {
        let rows = fom::simulate(&cfg.check().unwrap(), RunOptions::default())
            .unwrap()
            .rows;
        println!(
            "{name}: output interval {}",
            cfg.simulation.output_interval_s
        );
        for (p, tau) in [
            (60u32, 0.0),
            (60, 2e-6),
            (60, 2.5e-6),
            (60, 3e-6),
            (60, 3.5e-6),
            (60, 4e-6),
            (60, 4.105828442817328e-6),
            (60, 5e-6),
            (360, 3e-7),
        ] {
            let s = SensorModel {
                pulses_per_rev: p,
                timer_resolution_s: tau,
                seed: 100,
                ..SensorModel::default()
            };
            let rec = measure(&rows, &s);
            let v: Vec<f64> = rec
                .time_s
                .iter()
                .zip(&rec.driver_rpm)
                .filter(|(t, _)| **t > 2.0)
                .map(|(_, v)| *v)
                .collect();
            let w: Vec<f64> = rec
                .time_s
                .iter()
                .zip(&rec.driven_rpm)
                .filter(|(t, _)| **t > 2.0)
                .map(|(_, v)| *v)
                .collect();
            println!(
                "  lattice {:.3e} (P tau {:.3e})",
                twin::gap::features::timer_lattice_s(&v),
                p as f64 * tau
            );
            println!(
                "  P {p} tau {tau:e}: driver kurtosis {:.2}, driven {:.2}",
                kurtosis(&v),
                kurtosis(&w)
            );
        }
    }
}
