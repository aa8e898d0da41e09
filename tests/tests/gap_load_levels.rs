//! Two load levels in the gap diagnosis (docs/decisions/gap-load-levels.md): full-order data
//! sets of the default drive whose labels at the fan's own load are joined by labels at the
//! same centre distances with the fan throttled (the manifest's `load_torque_nm`). The slip's
//! rise with the load is the belt's stiffness under load: as the twin's on a healthy belt,
//! softer with belt hysteresis.

use std::f64::consts::PI;
use std::path::Path;

use fom::{DesignPoint, RunOptions};
use rayon::prelude::*;
use twin::gap::GapReport;
use twin::measured::{read_manifest, write_manifest, LOAD_TORQUE_KEY};
use twin::sensor::{append_synthetic_run, SensorModel};

/// The throttled fan's share of the fan law's coefficient (a damper half closed).
const THROTTLE: f64 = 0.6;

/// A label: its name, centre distance (m) and whether the fan is throttled.
type Label = (&'static str, f64, bool);

/// Writes a data set of the default drive with `effect` switched on (a `rom simulate
/// --effect` spec) into `dir`, one recording of `duration_s` from standstill per label,
/// 60-pulse tachometers with 1 rpm noise; a throttled label's manifest entry gives the fan's
/// torque at its mean speed over the last 2 s.
fn make_dataset(dir: &Path, labels: &[Label], effect: Option<&str>, duration_s: f64) {
    let file = beltwin_tests::shipped_surrogate();
    let base = file.surrogate.config().unwrap();
    let runs: Vec<_> = labels
        .par_iter()
        .map(|&(label, d, throttled)| {
            let q = DesignPoint {
                center_distance_m: d,
                ..DesignPoint::nominal(&base)
            };
            let mut cfg = q.apply(&base).unwrap().into_inner();
            cfg.simulation.duration_s = duration_s;
            if throttled {
                cfg.driven.load.as_mut().unwrap().fan_nm_s2 *= THROTTLE;
            }
            if let Some(spec) = effect {
                cfg.effects.set_from_spec(spec).unwrap();
            }
            let rows = fom::simulate(&cfg.check().unwrap(), RunOptions::default())
                .unwrap()
                .rows;
            (label, throttled, cfg, rows)
        })
        .collect();
    let mut torques = Vec::new();
    for (k, (label, throttled, cfg, rows)) in runs.iter().enumerate() {
        let sensor = SensorModel {
            seed: 300 + k as u64,
            ..SensorModel::default()
        };
        append_synthetic_run(dir, label, cfg, rows, &sensor).unwrap();
        if *throttled {
            let end = rows.last().unwrap().time_s;
            let last: Vec<f64> = rows
                .iter()
                .filter(|r| r.time_s >= end - 2.0)
                .map(|r| r.driven_rpm * PI / 30.0)
                .collect();
            let w = last.iter().sum::<f64>() / last.len() as f64;
            let load = cfg.driven.load.as_ref().unwrap();
            torques.push((*label, load.constant_nm + load.fan_nm_s2 * w * w));
        }
    }
    let mut m = read_manifest(dir).unwrap();
    for (label, t) in torques {
        for r in m.runs.iter_mut().filter(|r| r.label == label) {
            r.metadata
                .insert(LOAD_TORQUE_KEY.into(), toml::Value::Float(t));
        }
    }
    write_manifest(dir, &m).unwrap();
}

fn diagnose(labels: &[Label], effect: Option<&str>, duration_s: f64) -> GapReport {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path(), labels, effect, duration_s);
    crate::gap::diagnose_dir(dir.path())
}

/// A healthy belt: the slip rises with the load as in the twin, which rules out a belt
/// hysteresis of g 0.2 (the hysteresis test's), and the throttled label stays out of the
/// calibration and the ranking.
#[test]
fn a_healthy_belt_at_two_loads_is_as_stiff_as_the_twin() {
    let labels = [
        ("d0", 0.424, false),
        ("d1", 0.421, false),
        ("d2", 0.418, false),
        ("d0-low", 0.424, true),
    ];
    let r = diagnose(&labels, None, 3.5);
    let ll = r.load_levels.as_ref().expect("a label at another load");
    assert_eq!(ll.reference_load_torque_nm, None, "the drive's own load");
    assert!(ll.not_compared.is_empty(), "{:?}", ll.not_compared);
    assert_eq!(ll.pairs.len(), 1);
    let p = &ll.pairs[0];
    assert_eq!((p.label.as_str(), p.partner.as_str()), ("d0-low", "d0"));
    assert!(p.load_torque_nm[1] < 0.7 * p.load_torque_nm[0], "{p:?}");
    let f = ll.fit.as_ref().unwrap();
    assert!(
        f.stiffness_ratio_interval90[1] < 0.1 && (0.9..1.1).contains(&f.rise_ratio),
        "{f:?}"
    );
    assert!(ll.finding.contains("as in the twin"), "{}", ll.finding);
    assert!(r.verdict.contains(&ll.finding));
    assert!(
        r.calibration.fitted_on.iter().all(|l| l != "d0-low")
            && r.where_cells.iter().all(|c| c.label != "d0-low"),
        "the throttled label is compared through the load levels only"
    );
}

/// Belt hysteresis g 0.2 (relaxation 10 ms): the slip rises with the load more than in the
/// twin, the fitted g's interval lies above zero and about the truth, and hysteresis is still
/// not named (two load levels do not tell it from a softer belt).
#[test]
#[ignore = "long (six full-order runs of 5 s and a gap diagnosis, about 3 min of CPU): run with --ignored"]
fn belt_hysteresis_at_two_loads_shows_a_belt_softer_than_the_twin() {
    let labels = [
        ("d0", 0.424, false),
        ("d1", 0.421, false),
        ("d2", 0.418, false),
        ("d3", 0.416, false),
        ("d0-low", 0.424, true),
        ("d2-low", 0.418, true),
    ];
    let r = diagnose(
        &labels,
        Some("belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01"),
        5.0,
    );
    let ll = r.load_levels.as_ref().expect("labels at another load");
    assert_eq!(ll.pairs.len(), 2, "{:?}", ll.not_compared);
    let f = ll.fit.as_ref().unwrap();
    let [lo, hi] = f.stiffness_ratio_interval90;
    assert!(lo > 0.1 && hi < 0.35 && f.rise_ratio > 1.15, "{f:?}");
    assert!(f.score < -10.0, "very strong evidence: {f:?}");
    assert!(ll.finding.contains("softer under load"), "{}", ll.finding);
    assert!(r.named.iter().all(|n| n.effect != "belt-hysteresis"));
}
