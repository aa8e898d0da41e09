//! The continuous-belt creep simulator (`beltwin_tests::creep`), the model-form confusion
//! matrix's third simulator: its healthy slip is creep theory's at its operating point, and
//! the data sets it writes are read by the exchange format's reader.

use beltwin_tests::creep::{simulate, write_dataset, CreepRun};
use beltwin_tests::lumped::final_slip_pct;

/// Creep theory (Johnson, Contact Mechanics, 1985, sec. 8.7): the belt arrives at each pulley
/// at the pulley's speed, so 1 - r2 w2 / (r1 w1) = (eps1 - eps2) / (1 + eps1), with
/// eps1 - eps2 = F / EA for the transmitted force F = fan torque / r2, and eps1 = T1 / EA with
/// T1 = T0 + F / 2 (the tension sum stays 2 T0 to first order in the strain).
#[test]
fn healthy_slip_is_creep_theory_at_the_operating_point() {
    let cfg = beltwin_tests::default_drive();
    let d = 0.424;
    let run = simulate(&cfg, &CreepRun::at(d, 3.0)).unwrap();
    let slip = final_slip_pct(&run.rows, 0.5);
    let last = run.rows.last().unwrap();
    let w2 = last.driven_rpm * std::f64::consts::PI / 30.0;
    let load = cfg.driven.load.as_ref().unwrap();
    let (r1, r2) = fom::statics::pitch_radii_m(&cfg);
    // The fan's torque (fan affinity law plus seal friction) and bearing damping at its speed.
    let torque =
        load.constant_nm + load.fan_nm_s2 * w2 * w2 + cfg.driven.bearing_damping_n_m_s * w2;
    let f = torque / r2;
    let ea = cfg.belt.axial_stiffness_n;
    let l0 = fom::statics::unstretched_length_m(&cfg).unwrap();
    let t0 = fom::statics::static_tension_n(ea, fom::statics::open_belt_length_m(d, r1, r2), l0);
    let theory = 100.0 * (f / ea) / (1.0 + (t0 + 0.5 * f) / ea);
    // Terms of second order in the strain (eps ~ 0.02) are left out of the theory: 0.1 %
    // bounds them (eps^2 / eps = 2 % of the (1 + eps1) correction, itself 1.6 %); the
    // correction itself is 16 times that, so leaving it out would fail.
    assert!(
        (slip / theory - 1.0).abs() < 1e-3,
        "simulated slip {slip:.5} %, creep theory {theory:.5} %"
    );
    // The operating point is short of gross slip: the tension ratio below Euler-Eytelwein's.
    let (wrap1, _) = fom::statics::wrap_angles_rad(d, r1, r2);
    let ratio = last.tight_span_tension_n / last.slack_span_tension_n;
    assert!(
        ratio < (cfg.effective_friction() * wrap1).exp(),
        "ratio {ratio}"
    );
}

#[test]
fn its_data_set_passes_the_exchange_format_reader() {
    let cfg = beltwin_tests::default_drive();
    let dir = tempfile::tempdir().unwrap();
    let labels = [("d0", 0.424), ("d3", 0.416)];
    let run = CreepRun::at(0.42, 3.0);
    let written = write_dataset(dir.path(), &cfg, &labels, &run, 7).unwrap();
    let set = twin::measured::read_dataset(dir.path(), 100).unwrap();
    assert_eq!(set.labels(), vec!["d0".to_string(), "d3".to_string()]);
    assert_eq!(set.known_center_distance_m("d3"), Some(0.416));
    let ratio = set.speed_ratio(&cfg);
    for ((label, _), (_, true_slip)) in labels.iter().zip(&written) {
        let recs = set.recordings_of(label);
        assert_eq!(recs.len(), 1);
        let rec = recs[0].1;
        assert_eq!(rec.len(), 3001, "1 kHz read-outs over 3 s");
        // The twin's steady part of the counter's readings holds the simulated slip within the
        // counter's scatter (0.1 % of slip per read-out, averaged over >= 1000 read-outs that
        // the 4 ms gate correlates over 4: 4 standard errors are 0.025 pp).
        let (samples, steady_s) = twin::signal::steady_slip(rec, ratio).unwrap();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        assert!(steady_s >= 1.0, "{label}: steady {steady_s} s");
        assert!(
            (mean - true_slip).abs() < 0.025,
            "{label}: recorded {mean:.4} %, simulated {true_slip:.4} %"
        );
    }
}
