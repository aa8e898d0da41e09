//! Calibration (model updating) with the shipped surrogate: recovery of known parameters, and
//! the seed paper's Table 2.

use std::path::Path;

use rom::twin::calibrate::{calibrate, Distances, FreeSet, Target};
use rom::{Query, SurrogateFile};

fn shipped() -> SurrogateFile {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../artifacts/hvac-surrogate.json");
    SurrogateFile::load(&p).unwrap()
}

#[test]
fn known_parameters_are_recovered_from_surrogate_made_targets() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    // Five equally spaced distances, tension 240 N, friction 0.7, slip offset +1 %.
    let (d0, step, t, offset) = (0.4190, 0.0008, 240.0, 1.0);
    let targets: Vec<Target> = (0..5)
        .map(|i| {
            let q = Query {
                center_distance_m: d0 - i as f64 * step,
                friction: 0.7,
                installation_tension_n: t,
            };
            Target {
                label: format!("c{i}"),
                mean_slip_pct: s.predict_point(&cfg, &q).unwrap().mean_slip_pct + offset,
                mean_se_pct: 0.0,
                known_center_distance_m: None,
                position: i as f64,
            }
        })
        .collect();
    let free = FreeSet {
        friction: false,
        tension: true,
        ratio: true,
        distances: Distances::EquallySpaced,
    };
    let c = calibrate(s, &cfg, &targets, free, 5.0, false).unwrap();
    println!("{}", c.to_text());
    // The fit reproduces its own targets closely (they are exactly reachable).
    for r in &c.conditions {
        assert!(r.error_pct < 1.0, "{r:?}");
    }
    // The slip offset is identified by the flat (healthy) conditions: within 0.1 pp.
    assert!(
        (c.slip_offset_pct - offset).abs() < 0.1,
        "{}",
        c.slip_offset_pct
    );
    // Distances and tension trade off along the looseness ridge; the 90 % intervals must hold
    // the truth.
    let truth = [d0, step, t, offset];
    for (p, v) in c.parameters.iter().zip(truth) {
        assert!(
            p.interval90[0] <= v && v <= p.interval90[1],
            "{} = {v} outside {:?}",
            p.name,
            p.interval90
        );
    }
}

#[test]
fn bad_free_parameter_lists_are_refused() {
    for bad in ["stiffness", "friction,spaced-distances,distances", "mass"] {
        let e = bad.parse::<FreeSet>().unwrap_err();
        assert!(!e.is_empty());
    }
    let e = "stiffness".parse::<FreeSet>().unwrap_err();
    assert!(e.contains("unknown free parameter `stiffness`"), "{e}");
}

/// Reads the seed paper's Table 2 (measured mean slip for d0..d4; a copy of
/// `shared/data/paper-table2-mean-slip.csv`).
fn table2() -> Vec<Target> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/paper-table2-mean-slip.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("condition"))
        .enumerate()
        .map(|(i, l)| {
            let f: Vec<&str> = l.split(',').collect();
            Target {
                label: f[0].to_string(),
                mean_slip_pct: f[2].parse().unwrap(),
                mean_se_pct: 0.0,
                known_center_distance_m: None,
                position: i as f64,
            }
        })
        .collect()
}

#[test]
fn paper_table2_is_reproduced_within_five_percent() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let targets = table2();
    let free = FreeSet {
        friction: false,
        tension: true,
        ratio: true,
        distances: Distances::EquallySpaced,
    };
    let c = calibrate(s, &cfg, &targets, free, 5.0, true).unwrap();
    println!("{}", c.to_text());
    // The bound: every condition within 5 % after the full-order confirmation.
    for r in &c.conditions {
        assert!(r.fom_error_pct.unwrap() < 5.0, "{r:?}");
    }
    // Equally spaced and decreasing from d0 to d4.
    let d = &c.distances_m;
    assert!(d.windows(2).all(|w| w[1] < w[0]), "{d:?}");
    // Flat, then steep: d0..d2 within 5 % of each other, d4 at least twice d0.
    let slip: Vec<f64> = c
        .conditions
        .iter()
        .map(|r| r.fom_mean_slip_pct.unwrap())
        .collect();
    assert!(
        slip[2] / slip[0] < 1.05 && slip[4] > 2.0 * slip[0],
        "{slip:?}"
    );
}
