//! The signature each catalogue effect leaves in the two speed signals on the default drive, the
//! smallest magnitude visible above 1 rpm speed noise. (What switching an effect on costs is
//! measured by the benchmark `cargo bench -p beltwin-fom --bench simulate -- effects`.)
//!
//! `cargo run --release -p beltwin-twin --example effect_signatures` (about 1 min on one core).
//! Each effect runs once at a reference magnitude; the default drive (motor start, 0.25 kg m^2
//! fan) for 4 s, steady window t > 2 s (2000 samples at 1 kHz). Detectable: the signature
//! exceeds three standard deviations of its own estimate under white 1 rpm noise on both
//! speeds: for a line of amplitude A, sd(A) = sigma sqrt(2 / N); for the mean slip
//! s = 100 (1 - R_t n2 / n1), sd = 100 R_t sigma sqrt(1 / n1^2 + (n2 / n1^2)^2) / sqrt(N) with
//! the run's mean speeds (first-order error propagation). Magnitudes scale linearly from the
//! reference run (the line effects are tested linear).

use fom::effects::{
    BearingDrag, BeltHysteresis, BladePassPulsation, EffectsConfig, PulleyEccentricity,
    ShaftSelector, StribeckFriction,
};
use fom::simulation::{simulate, RunOptions, RunResult};
use fom::DriveConfig;
use twin::signal::line;

const STEADY_FROM_S: f64 = 2.0;
const NOISE_RPM: f64 = 1.0;

fn run(effects: EffectsConfig, step_s: Option<f64>) -> RunResult {
    let mut cfg = DriveConfig::default_hvac();
    cfg.simulation.duration_s = 4.0;
    cfg.simulation.steady_start_s = Some(STEADY_FROM_S);
    if let Some(dt) = step_s {
        cfg.simulation.step_s = dt;
    }
    cfg.effects = effects;
    simulate(&cfg, RunOptions::default()).expect("run")
}

/// Driven-speed line (rpm) at `order` x the mean driven shaft speed, and the number of samples.
fn driven_line(r: &RunResult, order: f64) -> (f64, usize) {
    let rows: Vec<_> = r.rows.iter().filter(|x| x.time_s > STEADY_FROM_S).collect();
    let t: Vec<f64> = rows.iter().map(|x| x.time_s).collect();
    let n2: Vec<f64> = rows.iter().map(|x| x.driven_rpm).collect();
    let mean = n2.iter().sum::<f64>() / n2.len() as f64;
    (line(&t, &n2, order * mean / 60.0, t[1] - t[0]).0, t.len())
}

fn main() {
    let base = run(EffectsConfig::default(), None);
    let s0 = &base.summary;
    let n = base.summary.steady_rows as f64;
    let line_sd = NOISE_RPM * (2.0 / n).sqrt();
    let r_t = DriveConfig::default_hvac().transmission_ratio();
    let slip_sd = 100.0
        * r_t
        * NOISE_RPM
        * ((1.0 / s0.mean_driver_rpm).powi(2)
            + (s0.mean_driven_rpm / s0.mean_driver_rpm.powi(2)).powi(2))
        .sqrt()
        / n.sqrt();
    println!(
        "baseline: slip {:.4} %, {:.0} steady samples; 3 sd: line {:.4} rpm, mean slip {:.5} pp",
        s0.mean_slip_pct,
        n,
        3.0 * line_sd,
        3.0 * slip_sd
    );
    println!("| effect | reference magnitude | signature | at reference | smallest visible |");
    println!("|---|---|---|---:|---:|");
    let report = |name: &str, magnitude: f64, unit: &str, what: &str, sig: f64, sd: f64| {
        let visible = magnitude * 3.0 * sd / sig.abs();
        println!("| {name} | {magnitude} {unit} | {what} | {sig:.4} | {visible:.3} {unit} |");
    };

    let e = 0.2e-3;
    let r = run(
        EffectsConfig {
            pulley_eccentricity: Some(PulleyEccentricity {
                pulley: ShaftSelector::Driven,
                runout_m: e,
                phase_deg: 0.0,
            }),
            ..EffectsConfig::default()
        },
        None,
    );
    let (a, _) = driven_line(&r, 1.0);
    report(
        "pulley-eccentricity (driven)",
        e * 1e3,
        "mm",
        "1x driven line in driven speed (rpm)",
        a,
        line_sd,
    );

    let amp = 0.05;
    let r = run(
        EffectsConfig {
            blade_pass_pulsation: Some(BladePassPulsation {
                blades: 8,
                amplitude: amp,
                phase_deg: 0.0,
            }),
            ..EffectsConfig::default()
        },
        None,
    );
    let (a, _) = driven_line(&r, 8.0);
    report(
        "blade-pass-pulsation (z = 8)",
        amp,
        "",
        "8x driven line in driven speed (rpm)",
        a,
        line_sd,
    );

    let drag = 1.0;
    let r = run(
        EffectsConfig {
            bearing_drag: Some(BearingDrag {
                coulomb_nm: drag,
                viscous_nm_s: 0.0,
            }),
            ..EffectsConfig::default()
        },
        None,
    );
    let ds = r.summary.mean_slip_pct - s0.mean_slip_pct;
    report(
        "bearing-drag (Coulomb)",
        drag,
        "N m",
        "mean slip change (pp)",
        ds,
        slip_sd,
    );

    let ratio = 0.6;
    let r = run(
        EffectsConfig {
            stribeck_friction: Some(StribeckFriction {
                dynamic_ratio: ratio,
                stribeck_speed_m_s: 0.05,
            }),
            ..EffectsConfig::default()
        },
        None,
    );
    let ds = r.summary.mean_slip_pct - s0.mean_slip_pct;
    report(
        "stribeck-friction (mu_d/mu_s = 0.6, v_s 0.05 m/s)",
        1.0 - ratio,
        "(1 - mu_d/mu_s)",
        "mean slip change (pp)",
        ds,
        slip_sd,
    );

    let hb = run(EffectsConfig::default(), Some(8e-6));
    let k = 0.2;
    let r = run(
        EffectsConfig {
            belt_hysteresis: Some(BeltHysteresis {
                stiffness_ratio: k,
                relaxation_s: 0.01,
            }),
            ..EffectsConfig::default()
        },
        Some(8e-6),
    );
    let ds = r.summary.mean_slip_pct - hb.summary.mean_slip_pct;
    report(
        "belt-hysteresis (tau 0.01 s, step 8e-6 s)",
        k,
        "(k2/EA)",
        "mean slip change (pp)",
        ds,
        slip_sd,
    );
}
