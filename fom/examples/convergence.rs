//! Convergence study of the default drive: steady mean slip and span tensions versus segment
//! count and step, beside creep theory evaluated with the run's own span tensions.
//!
//! cargo run --release -p beltwin-fom --example convergence [-- N:STEP ...]
//! (STEP in seconds or `auto`; without arguments the table of `docs/validation/convergence.md`,
//! "Segments and step").
use fom::config::StepSize;
use fom::simulation::{simulate, RunOptions};
use fom::{DriveConfig, Model};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let cases: Vec<(usize, StepSize)> = if args.is_empty() {
        [
            (60, StepSize::Auto),
            (120, StepSize::Auto),
            (240, StepSize::Seconds(1e-5)),
            (240, StepSize::Seconds(5e-6)),
            (240, StepSize::Seconds(2.5e-6)),
            (480, StepSize::Seconds(2.5e-6)),
        ]
        .into()
    } else {
        args.iter()
            .map(|a| {
                let (n, dt) = a.split_once(':').expect("N:STEP");
                let dt = match dt {
                    "auto" => StepSize::Auto,
                    s => StepSize::Seconds(s.parse().expect("a step in seconds")),
                };
                (n.parse().expect("a segment count"), dt)
            })
            .collect()
    };
    println!("| segments | step (s) | stable-step estimate (s) | mean slip (%) | tight span (N) | slack span (N) | creep theory (%) | slip / theory | real-time factor |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (n, step) in cases {
        let mut cfg = DriveConfig::default_hvac();
        cfg.belt.segments = n;
        cfg.simulation.step_s = step;
        let cfg = match cfg.check() {
            Ok(c) => c,
            Err(e) => {
                println!("| {n} | {step:?} | | error: {e} | | | | | |");
                continue;
            }
        };
        let (dt, limit) = match Model::from_config(&cfg) {
            Ok(m) => (m.params.step_s, m.stable_step_estimate_s()),
            Err(e) => {
                println!("| {n} | {step:?} | | error: {e} | | | | | |");
                continue;
            }
        };
        let s = match simulate(&cfg, RunOptions::default()) {
            Ok(r) => r.summary,
            Err(e) => {
                println!("| {n} | {dt:.3e} | | error: {e} | | | | | |");
                continue;
            }
        };
        let ea = cfg.belt.axial_stiffness_n;
        // Creep theory: w2 r2 / (w1 r1) = (EA + T_slack) / (EA + T_tight).
        let theory = 100.0 * (1.0 - (ea + s.mean_slack_tension_n) / (ea + s.mean_tight_tension_n));
        println!(
            "| {n} | {dt:.3e} | {limit:.2e} | {:.4} | {:.2} | {:.2} | {theory:.4} | {:.3} | {:.2} |",
            s.mean_slip_pct,
            s.mean_tight_tension_n,
            s.mean_slack_tension_n,
            s.mean_slip_pct / theory,
            s.real_time_factor
        );
    }
}
