//! A run that ends once it has settled, and a fixed-length run too short to settle.

use beltwin_tests::cheap_drive;
use fom::config::UntilSettled;
use fom::simulation::{simulate, RunOptions};
use fom::steady::Settling;

#[test]
fn a_run_until_settled_stops_early_with_its_steady_window() {
    let mut cfg = cheap_drive();
    cfg.simulation.duration_s = 3.0;
    cfg.simulation.until_settled = Some(UntilSettled {
        min_duration_s: 0.6,
        steady_length_s: 0.4,
    });
    let r = simulate(&cfg.check().unwrap(), RunOptions::default()).unwrap();
    let s = &r.summary;
    let Settling::Settled { window } = &s.settling else {
        panic!("{:?}", s.settling)
    };
    // It stopped before the longest run, with at least the steady length behind it.
    assert!(s.simulated_s < 3.0 - 1e-9, "{}", s.simulated_s);
    assert!(s.simulated_s - window.start_s >= 0.4 - 1e-9, "{window:?}");
    assert_eq!(s.steady_start_s, window.start_s);
    // The statistics are over that window only.
    let n = r
        .rows
        .iter()
        .filter(|x| x.time_s > window.start_s && x.slip_pct.is_finite())
        .count();
    assert_eq!(s.steady_rows, n);
}

#[test]
fn an_energy_balance_off_by_more_than_two_percent_is_flagged() {
    let mut e = fom::output::EnergyBalance {
        input_j: 100.0,
        load_j: 90.0,
        dissipated_j: 8.5,
        stored_change_j: 0.0,
    };
    assert!(!e.is_off(), "{}", e.residual_pct());
    e.dissipated_j = 12.5;
    assert!(e.is_off(), "{}", e.residual_pct());
    e.input_j = f64::NAN;
    assert!(e.is_off());
}

#[test]
fn a_fixed_run_ended_during_start_up_is_flagged_unsettled() {
    let mut cfg = cheap_drive();
    // 0.25 s from standstill: the fan is still running up.
    cfg.simulation.duration_s = 0.25;
    let r = simulate(&cfg.check().unwrap(), RunOptions::default()).unwrap();
    match &r.summary.settling {
        Settling::Unsettled { reason, .. } => assert!(!reason.is_empty()),
        other => panic!("{other:?}"),
    }
    assert!(r.summary.to_text().contains("UNSETTLED"));
}
