//! The unmodelled-effect catalogue (`fom::effects`): each effect leaves its physical signature
//! in the speeds and torques, checked against a lumped estimate.
//!
//! Drive: the default HVAC drive with a light fan impeller (0.02 kg m^2, steady within ~0.5 s of
//! motor start), 1.5 s from standstill, lines fitted over t > 0.7 s.

use std::f64::consts::PI;

use beltwin_tests::light_fan_drive;
use fom::effects::{
    BearingDrag, BeltHysteresis, BladePassPulsation, PulleyEccentricity, ShaftSelector,
    StribeckFriction,
};
use fom::integrator::{StepMode, StepWorkspace};
use fom::output::OutputRow;
use fom::simulation::{simulate, RunOptions, RunResult};
use fom::DriveConfig;
use twin::signal::line;

const STEADY_FROM_S: f64 = 0.7;

fn drive() -> DriveConfig {
    let mut cfg = light_fan_drive();
    cfg.simulation.duration_s = 1.5;
    cfg.simulation.steady_start_s = Some(STEADY_FROM_S);
    cfg
}

fn run(cfg: &DriveConfig) -> RunResult {
    simulate(&cfg.check().unwrap(), RunOptions::default()).unwrap()
}

fn steady(r: &RunResult) -> Vec<&OutputRow> {
    r.rows
        .iter()
        .filter(|row| row.time_s > STEADY_FROM_S)
        .collect()
}

/// Driven-speed line (rpm amplitude, phase) at `order` times the mean driven shaft speed.
fn driven_line(r: &RunResult, order: f64) -> (f64, f64) {
    let rows = steady(r);
    let t: Vec<f64> = rows.iter().map(|row| row.time_s).collect();
    let n2: Vec<f64> = rows.iter().map(|row| row.driven_rpm).collect();
    let mean_rpm = n2.iter().sum::<f64>() / n2.len() as f64;
    let dt = t[1] - t[0];
    line(&t, &n2, order * mean_rpm / 60.0, dt)
}

/// Lumped two-inertia estimate of the driven speed amplitude (rad/s) under a shaft torque
/// ripple of amplitude `torque_nm` at angular frequency `w` (rad/s): the fan inertia J2 and the
/// driver's inertia J1 referred to the fan shaft, (r2/r1)^2 J1, joined by the belt's torsional
/// stiffness k = r2^2 2 EA / L_span (both free spans; Den Hartog, Mechanical Vibrations, 1956,
/// ch. 5), the motor's torque-speed slope dT/dw = 2 T_b / (s_b w_s) as damping on the driver
/// (Kloss curve at small slip). Response of J2 to the torque (frequency-domain solution of the
/// two coupled equations).
fn two_inertia_speed_amplitude(cfg: &DriveConfig, torque_nm: f64, w: f64) -> f64 {
    let (r1, r2) = (
        0.5 * cfg.driver.pitch_diameter_m,
        0.5 * cfg.driven.pitch_diameter_m,
    );
    let n = r2 / r1;
    let d = cfg.center_distance_m();
    let span = (d * d - (r2 - r1).powi(2)).sqrt();
    let k = r2 * r2 * 2.0 * cfg.belt.axial_stiffness_n / span;
    let j2 = cfg.driven.inertia_kg_m2;
    let j1 = cfg.driver.inertia_kg_m2 * n * n;
    let m = cfg.driver.motor.as_ref().unwrap();
    let ws = m.synchronous_rpm * 2.0 * PI / 60.0;
    let c1 = 2.0 * m.breakdown_torque_nm / (m.breakdown_slip * ws) * n * n;
    // theta2 / T = (k - J1 w^2 + i c1 w) / [(k - J2 w^2)(k - J1 w^2 + i c1 w) - k^2].
    let (ar, ai) = (k - j1 * w * w, c1 * w);
    let b = k - j2 * w * w;
    let (den_r, den_i) = (b * ar - k * k, b * ai);
    let num = ar.hypot(ai);
    w * torque_nm * num / den_r.hypot(den_i)
}

const RAD_S_TO_RPM: f64 = 60.0 / (2.0 * PI);

#[test]
fn blade_pass_pulsation_puts_a_line_at_z_times_fan_speed_as_the_lumped_model_predicts() {
    let z = 8;
    let mut cfg = drive();
    cfg.effects.blade_pass_pulsation = Some(BladePassPulsation {
        blades: z,
        amplitude: 0.1,
        phase_deg: 0.0,
    });
    let r = run(&cfg);
    let (amp_rpm, _) = driven_line(&r, z as f64);
    let base = run(&drive());
    let (base_rpm, _) = driven_line(&base, z as f64);
    let s = &r.summary;
    let w = z as f64 * s.mean_driven_rpm / RAD_S_TO_RPM;
    let want = RAD_S_TO_RPM * two_inertia_speed_amplitude(&cfg, 0.1 * s.mean_driven_torque_nm, w);
    println!(
        "blade pass: {amp_rpm:.4} rpm (baseline {base_rpm:.4}), lumped estimate {want:.4} rpm"
    );
    // The line is the effect's: far above the baseline's content at that frequency.
    assert!(
        amp_rpm > 10.0 * base_rpm,
        "{amp_rpm} vs baseline {base_rpm}"
    );
    // The target's bound: the lumped two-inertia estimate within 30 %.
    assert!((amp_rpm / want - 1.0).abs() < 0.3, "{amp_rpm} vs {want}");
    // The load torque carries the line too (rows hold the load torque).
    let rows = steady(&r);
    let t: Vec<f64> = rows.iter().map(|row| row.time_s).collect();
    let q: Vec<f64> = rows.iter().map(|row| row.driven_torque_nm).collect();
    let (tq, _) = line(&t, &q, w / (2.0 * PI), t[1] - t[0]);
    assert!(
        (tq / (0.1 * s.mean_driven_torque_nm) - 1.0).abs() < 0.1,
        "load torque line {tq} N m"
    );
}

fn eccentric(runout_m: f64, phase_deg: f64) -> RunResult {
    let mut cfg = drive();
    cfg.effects.pulley_eccentricity = Some(PulleyEccentricity {
        pulley: ShaftSelector::Driven,
        runout_m,
        phase_deg,
    });
    run(&cfg)
}

#[test]
fn pulley_eccentricity_puts_a_line_at_shaft_speed_growing_linearly_with_runout() {
    let r1 = eccentric(0.25e-3, 0.0);
    let (a1, p1) = driven_line(&r1, 1.0);
    let s = &r1.summary;
    let torque = (s.mean_tight_tension_n + s.mean_slack_tension_n) * 0.25e-3;
    let want = RAD_S_TO_RPM
        * two_inertia_speed_amplitude(&drive(), torque, s.mean_driven_rpm / RAD_S_TO_RPM);
    println!("eccentricity lumped estimate {want:.4} rpm");
    let (a2, _) = driven_line(&eccentric(0.5e-3, 0.0), 1.0);
    let (_, p3) = driven_line(&eccentric(0.25e-3, 90.0), 1.0);
    let base = driven_line(&run(&drive()), 1.0).0;
    println!("eccentricity: {a1:.4} / {a2:.4} rpm (baseline {base:.4}), phases {p1:.3} {p3:.3}");
    assert!(a1 > 5.0 * base, "{a1} vs baseline {base}");
    // The target's bound: the lumped two-inertia estimate (torque ripple (T_t + T_s) e at 1x
    // shaft speed: the span forces' moment about the shaft through the runout) within 30 %.
    assert!((a1 / want - 1.0).abs() < 0.3, "{a1} vs {want}");
    // Linear in the runout: doubling e doubles the line within 10 %.
    assert!((a2 / a1 / 2.0 - 1.0).abs() < 0.1, "{a1} -> {a2}");
    // At the configured phase: 90 degrees more phase moves the line by 90 degrees (+-10).
    let shift = (p3 - p1).rem_euclid(2.0 * PI);
    let shift_deg = shift.to_degrees();
    assert!(
        (shift_deg - 270.0).abs() < 10.0 || (shift_deg - 90.0).abs() < 10.0,
        "phase shift {shift_deg} deg"
    );
}

#[test]
fn bearing_drag_closes_the_fan_shaft_torque_balance_and_raises_creep_slip() {
    let drag = BearingDrag {
        coulomb_nm: 1.0,
        viscous_nm_s: 0.01,
    };
    let mut cfg = drive();
    cfg.effects.bearing_drag = Some(drag);
    let r = run(&cfg);
    let base = run(&drive());
    let s = &r.summary;
    let r2 = 0.5 * cfg.driven.pitch_diameter_m;
    // Steady torque balance on the fan shaft: the belt's (T_t - T_s) r2 carries the load, the
    // extra drag and the shaft's bearing damping (`driven_torque_nm` holds load plus drag).
    let w2 = s.mean_driven_rpm / RAD_S_TO_RPM;
    let belt = (s.mean_tight_tension_n - s.mean_slack_tension_n) * r2;
    let resist = s.mean_driven_torque_nm + cfg.driven.bearing_damping_n_m_s * w2;
    assert!(
        (belt / resist - 1.0).abs() < 0.01,
        "belt {belt} vs {resist}"
    );
    // The shaft torque is the configured load at the run's speed plus the drag: the drag is
    // all that was added (1 % of the drag; the load is evaluated at the mean speed).
    let drag_nm = drag.drag_nm(w2);
    let l = cfg.driven.load.as_ref().unwrap();
    let load_nm = l.constant_nm * (w2 / 0.5).tanh() + l.viscous_nm_s * w2 + l.fan_nm_s2 * w2 * w2;
    println!(
        "bearing drag: shaft {:.4} N m = load {load_nm:.4} + drag {drag_nm:.4}; belt {belt:.4} N m",
        s.mean_driven_torque_nm
    );
    assert!(
        (s.mean_driven_torque_nm - load_nm - drag_nm).abs() < 0.01 * drag_nm,
        "shaft {} N m",
        s.mean_driven_torque_nm
    );
    // Slip rises as creep theory says for the higher traction: the rise of the model's slip
    // matches the rise of (1 - (EA + T_s) / (EA + T_t)) with each run's own tensions.
    let ea = cfg.belt.axial_stiffness_n;
    let creep = |x: &fom::output::RunSummary| {
        100.0 * (1.0 - (ea + x.mean_slack_tension_n) / (ea + x.mean_tight_tension_n))
    };
    let rise = s.mean_slip_pct - base.summary.mean_slip_pct;
    let rise_theory = creep(s) - creep(&base.summary);
    println!(
        "slip {:.4} -> {:.4} % (rise {rise:.4}); creep theory {:.4} -> {:.4} % (rise {rise_theory:.4})",
        base.summary.mean_slip_pct,
        s.mean_slip_pct,
        creep(&base.summary),
        creep(s)
    );
    assert!(rise > 0.0 && rise_theory > 0.0, "slip did not rise");
    // The model sits a little below creep theory (`docs/validation/convergence.md`, "Segments and
    // step": 0.982 of it on the default drive, from the segment discretisation); that offset is the
    // model's, not the traction's, so the ratio model / theory must be the same at both tractions,
    // within 1 %.
    let ratio_base = base.summary.mean_slip_pct / creep(&base.summary);
    let ratio_drag = s.mean_slip_pct / creep(s);
    assert!(
        (ratio_drag / ratio_base - 1.0).abs() < 0.01,
        "slip / creep theory {ratio_base:.4} without, {ratio_drag:.4} with the drag"
    );
}

#[test]
fn a_running_drive_with_stribeck_friction_stays_stable() {
    let mut cfg = drive();
    cfg.effects.stribeck_friction = Some(StribeckFriction {
        dynamic_ratio: 0.6,
        stribeck_speed_m_s: 0.05,
    });
    let r = run(&cfg);
    let base = run(&drive());
    let spread = |x: &RunResult| {
        let v: Vec<f64> = steady(x).iter().map(|row| row.driven_rpm).collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|y| (y - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    println!(
        "stribeck: slip {:.4} % (Coulomb {:.4} %), driven speed sd {:.4} rpm (Coulomb {:.4})",
        r.summary.mean_slip_pct,
        base.summary.mean_slip_pct,
        spread(&r),
        spread(&base)
    );
    // In creep the belt barely slides (slip speed ~ mm/s, far below v_s): the run is the
    // Coulomb run's within 2 % of slip, and no stick-slip chatter: the driven speed's spread
    // stays within twice the Coulomb run's plus 0.05 rpm (the 1 rpm sensor noise is 20x that).
    assert!(
        (r.summary.mean_slip_pct / base.summary.mean_slip_pct - 1.0).abs() < 0.02,
        "slip {} vs {}",
        r.summary.mean_slip_pct,
        base.summary.mean_slip_pct
    );
    assert!(spread(&r) < 2.0 * spread(&base) + 0.05, "chatter");
}

#[test]
fn belt_hysteresis_dissipates_the_loop_of_each_elements_strain_cycle() {
    let (ratio, tau) = (0.2, 0.01);
    let mut cfg = drive();
    cfg.simulation.duration_s = 1.0;
    // At the default step: EA is the instantaneous stiffness, so the arm leaves the explicit
    // step limit where it was.
    cfg.effects.belt_hysteresis = Some(BeltHysteresis {
        stiffness_ratio: ratio,
        relaxation_s: tau,
    });
    let r = run(&cfg);
    // The energy balance still closes (the arms' stored energy counts as stored).
    let residual = r.summary.energy.residual_pct();
    assert!(residual.abs() < 1.0, "energy residual {residual} %");
    // One belt revolution more, step by step, recording every element's extension and the
    // energy the arms dissipate.
    let mut model = r.model;
    let b = &model.belt;
    let n = b.n;
    let l0 = b.element.l0_m;
    let v_belt = model.pulleys[0].omega_rad_s * model.pulleys[0].pitch_radius_m;
    let dt = model.params.step_s;
    let steps = (model.unstretched_length_m / v_belt / dt).round() as usize;
    let h0 = b.hysteresis.clone().unwrap();
    let k2 = h0.stiffness_n_m;
    // One-term Prony series: arm g EA, elastic spring (1 - g) EA.
    assert!((k2 / b.element.k_axial - ratio / (1.0 - ratio)).abs() < 1e-12);
    let mut ws = StepWorkspace::default();
    let extensions = |m: &fom::Model| -> Vec<f64> {
        (0..n)
            .map(|e| {
                let j = (e + 1) % n;
                (m.belt.x[j] - m.belt.x[e]).hypot(m.belt.y[j] - m.belt.y[e]) - l0
            })
            .collect()
    };
    let mut x = vec![extensions(&model)];
    for _ in 0..steps {
        model.step(StepMode::Dynamic, &mut ws);
        x.push(extensions(&model));
    }
    let lost_fom = model.belt.hysteresis.as_ref().unwrap().dissipated_j - h0.dissipated_j;
    // The standard linear solid's loss on those strain histories, computed apart: Crank-Nicolson
    // on dF/dt = k2 dx/dt - F / tau from each arm's force at the start, loss = integral of
    // F^2 / (k2 tau) dt, on the histories sampled every 10 steps (1e-4 s, well below tau and
    // the ~20 ms strain transitions at the pulleys), so the check sees the strain cycle, not
    // the model's step-level increments.
    const SAMPLE: usize = 10;
    let c = k2 * tau;
    let h = SAMPLE as f64 * dt;
    let mut lost_law = 0.0;
    for e in 0..n {
        let mut f = h0.force_n[e];
        for w in x.iter().step_by(SAMPLE).collect::<Vec<_>>().windows(2) {
            let f_new =
                (f * (1.0 - h / (2.0 * tau)) + k2 * (w[1][e] - w[0][e])) / (1.0 + h / (2.0 * tau));
            lost_law += 0.5 * (f * f + f_new * f_new) / c * h;
            f = f_new;
        }
    }
    println!(
        "belt hysteresis: {lost_fom:.4} J per revolution in the model, {lost_law:.4} J from the \
         element law on the elements' strain cycles; energy residual {residual:.3} %"
    );
    assert!(lost_law > 0.0);
    assert!(
        (lost_fom / lost_law - 1.0).abs() < 0.1,
        "{lost_fom} vs {lost_law}"
    );
}

#[test]
fn no_effects_section_leaves_the_configuration_text_unchanged() {
    let cfg = drive();
    assert!(cfg.effects.is_empty());
    assert!(!cfg.to_toml_string().contains("effects"));
}
