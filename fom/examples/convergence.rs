//! Convergence study of the default drive: steady mean slip versus segment count and step,
//! beside creep theory evaluated with the run's own span tensions.
//!
//! cargo run --release -p beltwin-fom --example convergence
use fom::simulation::{simulate, RunOptions};
use fom::{DriveConfig, Model};

fn main() {
    println!("| segments | step (s) | stable-step estimate (s) | mean slip (%) | creep theory (%) | slip / theory | real-time factor |");
    println!("|---:|---:|---:|---:|---:|---:|---:|");
    for (n, dt) in [
        (60, 1e-5),
        (120, 1e-5),
        (240, 1e-5),
        (240, 5e-6),
        (240, 2.5e-6),
        (480, 2.5e-6),
    ] {
        let mut cfg = DriveConfig::default_hvac();
        cfg.belt.segments = n;
        cfg.simulation.step_s = fom::config::StepSize::Seconds(dt);
        let limit = Model::from_config(&cfg).map(|m| m.stable_step_estimate_s());
        let s = match simulate(&cfg, RunOptions::default()) {
            Ok(r) => r.summary,
            Err(e) => {
                println!("| {n} | {dt:.1e} | | error: {e} | | | |");
                continue;
            }
        };
        let ea = cfg.belt.axial_stiffness_n;
        // Creep theory: w2 r2 / (w1 r1) = (EA + T_slack) / (EA + T_tight).
        let theory = 100.0 * (1.0 - (ea + s.mean_slack_tension_n) / (ea + s.mean_tight_tension_n));
        println!(
            "| {n} | {dt:.1e} | {:.2e} | {:.4} | {theory:.4} | {:.3} | {:.2} |",
            limit.unwrap_or(f64::NAN),
            s.mean_slip_pct,
            s.mean_slip_pct / theory,
            s.real_time_factor
        );
    }
}
