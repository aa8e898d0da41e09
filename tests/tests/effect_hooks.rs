//! The step's extension points (`fom::effects`): an effect plugs in without editing the step,
//! acts where it says, and an effect that changes nothing leaves the run exactly as it was.

use std::sync::Arc;

use beltwin_tests::{cheap_drive, with_prescribed_driver};
use fom::contact::FrictionLaw;
use fom::effects::{Effect, Effects};
use fom::simulation::{simulate, RunOptions, RunResult};
use fom::DriveConfig;

/// A short run of the cheap drive with a prescribed driver: 0.6 s, steady from 0.4 s.
fn drive() -> DriveConfig {
    let mut cfg = with_prescribed_driver(cheap_drive(), 1750.0, 0.2);
    cfg.simulation.duration_s = 0.6;
    cfg.simulation.steady_start_s = Some(0.4);
    cfg
}

fn run_with(effect: Option<Arc<dyn Effect>>) -> RunResult {
    let mut effects = Effects::default();
    if let Some(e) = effect {
        effects.push(e);
    }
    simulate(
        &drive().check().unwrap(),
        RunOptions {
            effects,
            ..RunOptions::default()
        },
    )
    .unwrap()
}

/// Overrides nothing: every hook keeps its baseline default.
#[derive(Debug)]
struct Nothing;
impl Effect for Nothing {
    fn name(&self) -> &str {
        "nothing"
    }
}

/// Load torque on the driven shaft pulsating with twice the shaft angle.
#[derive(Debug)]
struct Pulsation;
impl Effect for Pulsation {
    fn name(&self) -> &str {
        "test-pulsation"
    }
    fn shaft_torque_nm(&self, pulley: usize, _t: f64, angle: f64, _w: f64, base: f64) -> f64 {
        if pulley == 1 {
            base * (1.0 + 0.5 * (2.0 * angle).sin())
        } else {
            base
        }
    }
}

/// Cuts the friction coefficient to a fifth (0.7 -> 0.14): below the ~0.19 the default drive's
/// fan torque needs on the driver's 2.9 rad wrap (Euler-Eytelwein, T1/T2 = 332/189 N).
#[derive(Debug)]
struct Slippery;
impl Effect for Slippery {
    fn name(&self) -> &str {
        "test-slippery"
    }
    fn friction_law(&self, baseline: FrictionLaw) -> FrictionLaw {
        match baseline {
            FrictionLaw::RegularisedCoulomb {
                mu,
                velocity_threshold_m_s,
            } => FrictionLaw::RegularisedCoulomb {
                mu: 0.2 * mu,
                velocity_threshold_m_s,
            },
            other => other,
        }
    }
}

fn driven_rpm_std(r: &RunResult) -> f64 {
    let v: Vec<f64> = r
        .rows
        .iter()
        .filter(|row| row.time_s > 0.4)
        .map(|row| row.driven_rpm)
        .collect();
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

#[test]
fn an_effect_that_overrides_nothing_leaves_the_run_bit_for_bit() {
    let base = run_with(None);
    let same = run_with(Some(Arc::new(Nothing)));
    // Debug prints each f64 so that it reads back to the same bits (and NaN equals NaN).
    assert_eq!(format!("{:?}", base.rows), format!("{:?}", same.rows));
}

#[test]
fn an_angle_dependent_load_torque_makes_the_driven_speed_ripple() {
    let base = run_with(None);
    let pulsed = run_with(Some(Arc::new(Pulsation)));
    // +-50 % of the load at twice shaft speed: the ripple must stand well above the baseline's
    // (a factor 3 leaves room for the baseline's own chordal ripple).
    assert!(
        driven_rpm_std(&pulsed) > 3.0 * driven_rpm_std(&base),
        "{} vs {}",
        driven_rpm_std(&pulsed),
        driven_rpm_std(&base)
    );
}

#[test]
fn a_friction_law_hook_changes_the_contacts() {
    let base = run_with(None);
    let slippery = run_with(Some(Arc::new(Slippery)));
    // Creep slip does not depend on mu (Grashof), so only a friction below what the load
    // needs tells the hook is in force: the belt slides and the fan falls back to where its
    // torque fits the traction, about 17 % slip (the baseline creeps below 1 %).
    assert_ne!(format!("{:?}", base.rows), format!("{:?}", slippery.rows));
    let (b, s) = (base.summary.mean_slip_pct, slippery.summary.mean_slip_pct);
    assert!(b < 1.0 && s > 5.0, "slip {b} % at mu 0.7, {s} % at mu 0.14");
}
