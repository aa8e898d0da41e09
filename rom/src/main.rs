//! `rom`: the beltwin command line. A thin layer over the library crates.

use clap::{Parser, Subcommand};
use fom::config::{DriveConfig, Overrides};
use fom::output::{write_run_csv, write_tension_profile_csv};
use fom::simulation::{simulate, RunOptions};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "rom",
    version,
    about = "beltwin: digital twin of belt-pulley drives"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the full-order model (finite-segment belt) and write its time series.
    Simulate(SimulateArgs),
}

#[derive(clap::Args)]
struct SimulateArgs {
    /// Drive configuration (TOML); default: the shipped HVAC drive fom/configs/hvac.toml.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Centre distance, m (moves the driven pulley along the line of centres).
    #[arg(long)]
    d: Option<f64>,
    /// Effective friction coefficient.
    #[arg(long)]
    mu: Option<f64>,
    /// Installation tension, N: static span tension at the reference centre distance.
    #[arg(long)]
    tension: Option<f64>,
    /// Simulated duration, s.
    #[arg(long)]
    duration: Option<f64>,
    /// Output CSV of the time series.
    #[arg(long)]
    out: PathBuf,
    /// Output CSV of the axial force along the belt at the end time.
    #[arg(long)]
    tension_profile: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(a) => run_simulate(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_simulate(a: SimulateArgs) -> Result<(), Box<dyn std::error::Error>> {
    let cfg = match &a.config {
        Some(p) => DriveConfig::from_file(p)?,
        None => DriveConfig::default_hvac(),
    };
    let cfg = cfg.with_overrides(&Overrides {
        center_distance_m: a.d,
        friction: a.mu,
        installation_tension_n: a.tension,
        duration_s: a.duration,
    })?;
    let progress = progress_bar(&cfg);
    let result = simulate(&cfg, RunOptions { progress })?;
    finish_progress();
    write_run_csv(&a.out, &result.rows)?;
    if let Some(p) = &a.tension_profile {
        write_tension_profile_csv(p, &result.tension_profile)?;
    }
    println!(
        "centre distance    {:.4} m, effective friction {:.3}, static span tension {:.1} N",
        cfg.center_distance_m(),
        cfg.contact.effective_friction(),
        result.static_tension_n
    );
    println!("{}", result.summary.to_text());
    println!("wrote {}", a.out.display());
    Ok(())
}

static BAR: std::sync::OnceLock<indicatif::ProgressBar> = std::sync::OnceLock::new();

/// A progress bar for runs expected to take more than about a second.
fn progress_bar(cfg: &DriveConfig) -> Option<fn(f64, f64)> {
    let steps = cfg.simulation.duration_s / cfg.simulation.step_s;
    let segment_steps = steps * cfg.belt.segments as f64;
    // ~50 ns per segment-step on one core (README figure); below ~1 s, no bar.
    if segment_steps * 5e-8 < 1.0 {
        return None;
    }
    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "simulating {bar:40} {msg} [{elapsed_precise} < {eta}]",
        )
        .expect("valid template"),
    );
    let _ = BAR.set(bar);
    Some(|t, total| {
        if let Some(b) = BAR.get() {
            b.set_position((1000.0 * t / total) as u64);
            b.set_message(format!("{t:.2}/{total:.2} s"));
        }
    })
}

fn finish_progress() {
    if let Some(b) = BAR.get() {
        b.finish_and_clear();
    }
}
