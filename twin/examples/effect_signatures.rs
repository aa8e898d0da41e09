//! The signature each catalogue effect leaves in the two speed signals on the default drive, the
//! smallest magnitude visible above 1 rpm speed noise. (What switching an effect on costs is
//! measured by the benchmark `cargo bench -p beltwin-fom --features bench --bench simulate -- effects`.)
//!
//! `cargo run --release -p beltwin-twin --example effect_signatures` (about 1 min on one core).
//! Each effect runs once at a reference magnitude; the default drive (motor start, 0.25 kg m^2
//! fan) for 4 s, steady window t > 2 s (2000 samples at 1 kHz). Detectable: the signature
//! exceeds three standard deviations of its own estimate under white 1 rpm noise on both
//! speeds: for a line of amplitude A, sd(A) = sigma sqrt(2 / N); for the mean slip
//! s = 100 (1 - R_t n2 / n1), sd = 100 R_t sigma sqrt(1 / n1^2 + (n2 / n1^2)^2) / sqrt(N) with
//! the run's mean speeds (first-order error propagation). Magnitudes scale linearly from the
//! reference run (the line effects are tested linear).

use fom::effects::EffectsConfig;
use fom::simulation::{simulate, RunOptions, RunResult};
use fom::DriveConfig;
use twin::signal::line;

const STEADY_FROM_S: f64 = 2.0;
const NOISE_RPM: f64 = 1.0;

fn run(effects: EffectsConfig) -> RunResult {
    let mut cfg = DriveConfig::default_hvac();
    cfg.simulation.duration_s = 4.0;
    cfg.simulation.steady_start_s = Some(STEADY_FROM_S);
    cfg.effects = effects;
    simulate(&cfg.check().unwrap(), RunOptions::default()).expect("run")
}

/// Driven-speed line (rpm) at `order` x the mean driven shaft speed.
fn driven_line(r: &RunResult, order: f64) -> f64 {
    let rows: Vec<_> = r.rows.iter().filter(|x| x.time_s > STEADY_FROM_S).collect();
    let t: Vec<f64> = rows.iter().map(|x| x.time_s).collect();
    let n2: Vec<f64> = rows.iter().map(|x| x.driven_rpm).collect();
    let mean = n2.iter().sum::<f64>() / n2.len() as f64;
    line(&t, &n2, order * mean / 60.0, t[1] - t[0]).0
}

fn main() {
    let base = run(EffectsConfig::default());
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
    // (label, `--effect` spec, reference magnitude, unit, signature): a driven-speed line at
    // that order of the fan speed, or (None) the change of mean slip.
    type Case<'a> = (&'a str, &'a str, f64, &'a str, Option<f64>);
    let cases: [Case; 5] = [
        (
            "pulley-eccentricity (driven)",
            "pulley-eccentricity:pulley=driven,runout_m=2e-4",
            0.2,
            "mm",
            Some(1.0),
        ),
        (
            "blade-pass-pulsation (z = 8)",
            "blade-pass-pulsation:blades=8,amplitude=0.05",
            0.05,
            "",
            Some(8.0),
        ),
        (
            "bearing-drag (Coulomb)",
            "bearing-drag:coulomb_nm=1",
            1.0,
            "N m",
            None,
        ),
        (
            "stribeck-friction (mu_d/mu_s = 0.6, v_s 0.05 m/s)",
            "stribeck-friction:dynamic_ratio=0.6,stribeck_speed_m_s=0.05",
            0.4,
            "(1 - mu_d/mu_s)",
            None,
        ),
        (
            "belt-hysteresis (tau 0.01 s)",
            "belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01",
            0.2,
            "(g)",
            None,
        ),
    ];
    for (label, spec, magnitude, unit, order) in cases {
        let mut effects = EffectsConfig::default();
        effects.set_from_spec(spec).expect("valid spec");
        let r = run(effects);
        let (what, sig, sd) = match order {
            Some(k) => (
                format!("{k}x driven line in driven speed (rpm)"),
                driven_line(&r, k),
                line_sd,
            ),
            None => (
                "mean slip change (pp)".to_string(),
                r.summary.mean_slip_pct - base.summary.mean_slip_pct,
                slip_sd,
            ),
        };
        let visible = magnitude * 3.0 * sd / sig.abs();
        println!("| {label} | {magnitude} {unit} | {what} | {sig:.4} | {visible:.3} {unit} |");
    }
}
