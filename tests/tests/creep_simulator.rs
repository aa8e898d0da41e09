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

/// A belt sliding after start-up on another simulator than the twin: the creep simulator
/// with a Stribeck friction drop at the loosest matrix setting, recorded for 3 s from
/// standstill while its slip still falls. `rom diagnose`'s extrapolation of the settle must
/// hold, within its 90 % interval, the slip the same drive settles at in a 6 s run, and the
/// belt is critical.
#[test]
fn a_sliding_belt_recorded_too_short_is_diagnosed_at_the_slip_it_settles_at() {
    let mut cfg = beltwin_tests::default_drive();
    cfg.effects
        .set_from_spec("stribeck-friction:dynamic_ratio=0.5,stribeck_speed_m_s=0.05")
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_dataset(
        dir.path(),
        &cfg,
        &[("d3", 0.416)],
        &CreepRun::at(0.416, 3.0),
        1,
    )
    .unwrap();
    let settled = final_slip_pct(
        &simulate(&cfg, &CreepRun::at(0.416, 6.0)).unwrap().rows,
        0.5,
    );
    let set = twin::measured::read_dataset(dir.path(), 100).unwrap();
    let file = beltwin_tests::shipped_surrogate();
    let twin_cfg = file.surrogate.config().unwrap();
    let v = twin::diagnose::diagnose(&file.surrogate, &twin_cfg, &set)
        .unwrap()
        .remove(0);
    assert!(v.cannot_diagnose.is_none(), "{:?}", v.cannot_diagnose);
    let m = v.measured.unwrap();
    let f = &m.settling[0];
    assert!(
        f.last_window_pct > settled + 0.5,
        "the recording ends at {:.3} %, not yet settled ({settled:.3} %)",
        f.last_window_pct
    );
    assert!(
        f.steady_90_pct[0] <= settled && settled <= f.steady_90_pct[1],
        "extrapolated {f:?}, settled {settled:.3} %"
    );
    assert_eq!(v.estimate.unwrap().class, "critical");
}
