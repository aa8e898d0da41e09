//! `rom`: the beltwin command line. A thin layer over the library crates.

use clap::{Parser, Subcommand};
use fom::config::{DriveConfig, Overrides};
use fom::output::{write_run_csv, write_tension_profile_csv};
use fom::simulation::{simulate, RunOptions};
use rom::{Query, Surrogate, SurrogateFile};
use std::path::PathBuf;
use std::process::ExitCode;
use training::{CampaignSettings, Event};

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
    /// Run the training campaign (Latin hypercube through the full-order model) and fit the
    /// surrogate to it.
    Train(TrainArgs),
    /// Predict the steady slip distribution at a centre distance with the surrogate.
    Predict(PredictArgs),
    /// Compare the surrogate with fresh full-order runs at points it was not trained on.
    Validate(ValidateArgs),
    /// Diagnose belt looseness from measured speeds (format belt-measurements/1).
    Diagnose(DiagnoseArgs),
    /// Calibrate the twin to measured slip (model updating).
    Calibrate(CalibrateArgs),
}

#[derive(clap::Args)]
struct CalibrateArgs {
    /// Measured data set directory (with manifest.toml).
    #[arg(long, required_unless_present = "table", conflicts_with = "table")]
    measured: Option<PathBuf>,
    /// Instead of recordings: a CSV of mean slips per condition (columns `condition`,
    /// `experiment_mean_slip_pct`; `#` comments), e.g. the seed paper's Table 2.
    #[arg(long)]
    table: Option<PathBuf>,
    /// Free parameters: friction, tension, ratio, stiffness, distances | spaced-distances
    /// (comma list).
    /// Default: friction,tension, plus distances when a condition's distance is unknown.
    #[arg(long)]
    free: Option<rom::twin::calibrate::FreeSet>,
    /// Largest acceptable error per condition, %.
    #[arg(long, default_value_t = 5.0)]
    tolerance: f64,
    /// Skip the full-order confirmation of the fitted point.
    #[arg(long)]
    no_confirm: bool,
    /// Also calibrate on all conditions but one and predict that one, for each.
    #[arg(long)]
    leave_one_out: bool,
    /// Write the calibrated configuration (TOML) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Surrogate file (default: the shipped one).
    #[arg(long, default_value = DEFAULT_MODEL)]
    model: PathBuf,
    /// Drive configuration the surrogate must have been trained on (default: its own).
    #[arg(long)]
    config: Option<PathBuf>,
}

#[derive(clap::Args)]
struct DiagnoseArgs {
    /// Measured data set directory (with manifest.toml).
    #[arg(long)]
    measured: PathBuf,
    /// Write diagnosis.txt, diagnosis.json and slip-boxplots.svg into this directory.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Surrogate file (default: the shipped one).
    #[arg(long, default_value = DEFAULT_MODEL)]
    model: PathBuf,
    /// Drive configuration the surrogate must have been trained on (default: its own).
    #[arg(long)]
    config: Option<PathBuf>,
}

/// Surrogate shipped with the sources (trained on the default drive by `rom train`).
const DEFAULT_MODEL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../artifacts/hvac-surrogate.json"
);

#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    Text,
    Json,
    Csv,
}

#[derive(clap::Args)]
struct PredictArgs {
    /// Centre distance, m.
    #[arg(long)]
    d: f64,
    /// Nominal effective friction coefficient (default: the drive configuration's).
    #[arg(long)]
    mu: Option<f64>,
    /// Installation tension, N (default: the drive configuration's).
    #[arg(long)]
    tension: Option<f64>,
    /// Effective axial belt stiffness EA, N (only for surrogates trained over a stiffness
    /// range; default: the drive configuration's).
    #[arg(long)]
    stiffness: Option<f64>,
    /// Friction samples propagated through the surrogate (mu +- 1 %).
    #[arg(long, default_value_t = rom::predict::DEFAULT_SAMPLES)]
    samples: usize,
    #[arg(long, value_enum, default_value = "text")]
    format: Format,
    /// Write a box plot (SVG) of the predicted distribution.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the predicted start-up slip series (CSV time_s,slip_pct).
    #[arg(long)]
    startup: Option<PathBuf>,
    /// Surrogate file (default: the shipped one).
    #[arg(long, default_value = DEFAULT_MODEL)]
    model: PathBuf,
    /// Drive configuration the surrogate must have been trained on (default: its own).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Predict outside the trained ranges (the output says so).
    #[arg(long)]
    allow_extrapolation: bool,
}

#[derive(clap::Args)]
struct ValidateArgs {
    /// Number of fresh Latin-hypercube points.
    #[arg(long, default_value_t = 20)]
    points: usize,
    /// Seed of the validation design (default: the training seed + 1).
    #[arg(long)]
    seed: Option<u64>,
    /// Surrogate file (default: the shipped one).
    #[arg(long, default_value = DEFAULT_MODEL)]
    model: PathBuf,
    /// Also write the per-point results as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(clap::Args)]
struct TrainArgs {
    /// Drive configuration (TOML); default: the shipped HVAC drive.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Campaign settings (TOML with samples, seed, ranges, duration_s, steady_start_s);
    /// default: the documented defaults.
    #[arg(long)]
    settings: Option<PathBuf>,
    /// Number of Latin-hypercube points (overrides the settings file).
    #[arg(long)]
    samples: Option<usize>,
    /// Seed of the design (overrides the settings file).
    #[arg(long)]
    seed: Option<u64>,
    /// Data set directory (created, or resumed if it exists).
    #[arg(long, default_value = "training-data")]
    data: PathBuf,
    /// Surrogate file written after the campaign.
    #[arg(long, default_value = DEFAULT_MODEL)]
    model: PathBuf,
    /// Compute only share I of N of the design (cluster job arrays); no surrogate is fitted.
    #[arg(long, conflicts_with = "merge")]
    shard: Option<training::Shard>,
    /// Join the shards written into --data, then fit the surrogate.
    #[arg(long)]
    merge: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
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
    #[arg(long, required_unless_present = "measurement_out")]
    out: Option<PathBuf>,
    /// Also write the run as a synthetic measurement (format belt-measurements/1) into this
    /// data set directory, appending to its manifest.
    #[arg(long, requires = "label")]
    measurement_out: Option<PathBuf>,
    /// Condition label of the synthetic measurement (e.g. d0); the file is LABEL-runN.csv.
    #[arg(long)]
    label: Option<String>,
    /// Sensor read-out rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    sample_rate: f64,
    /// Tachometer pulses per revolution.
    #[arg(long, default_value_t = 60)]
    pulses_per_rev: u32,
    /// Standard deviation of the speed noise, rpm.
    #[arg(long, default_value_t = 1.0)]
    speed_noise_rpm: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    noise_seed: u64,
    /// Output CSV of the axial force along the belt at the end time.
    #[arg(long)]
    tension_profile: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(a) => run_simulate(a),
        Command::Train(a) => run_train(a),
        Command::Predict(a) => run_predict(a),
        Command::Validate(a) => run_validate(a),
        Command::Diagnose(a) => run_diagnose(a),
        Command::Calibrate(a) => run_calibrate(a),
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
    let sensor = rom::twin::sensor::SensorModel {
        sample_rate_hz: a.sample_rate,
        pulses_per_rev: a.pulses_per_rev,
        speed_noise_rpm: a.speed_noise_rpm,
        seed: a.noise_seed,
    };
    sensor.validate()?;
    if let Some(label) = &a.label {
        check_label(label)?;
    }
    let progress = progress_bar(&cfg);
    let result = simulate(&cfg, RunOptions { progress })?;
    finish_progress();
    if let Some(out) = &a.out {
        write_run_csv(out, &result.rows)?;
        println!("wrote {}", out.display());
    }
    if let (Some(dir), Some(label)) = (&a.measurement_out, &a.label) {
        let file = write_measurement(dir, label, &cfg, &result.rows, &sensor)?;
        println!(
            "wrote {} (manifest {})",
            dir.join(&file).display(),
            dir.join("manifest.toml").display()
        );
    }
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
    Ok(())
}

fn check_label(label: &str) -> Result<(), String> {
    if label.trim().is_empty() || label.contains(['/', '\\']) {
        return Err(format!(
            "--label `{label}` must be non-empty and contain no path separator"
        ));
    }
    Ok(())
}

/// Appends the run to a measured data set as `LABEL-runN.csv` (first free N).
fn write_measurement(
    dir: &std::path::Path,
    label: &str,
    cfg: &DriveConfig,
    rows: &[fom::OutputRow],
    sensor: &rom::twin::sensor::SensorModel,
) -> Result<String, Box<dyn std::error::Error>> {
    use rom::twin::measured::{append_run, RunEntry};
    let n = (1..)
        .find(|n| !dir.join(format!("{label}-run{n}.csv")).exists())
        .expect("a free run number");
    let file = format!("{label}-run{n}.csv");
    let rec = rom::twin::sensor::measure(rows, sensor);
    let mut metadata = std::collections::BTreeMap::new();
    metadata.insert("synthetic".to_string(), toml::Value::Boolean(true));
    metadata.insert(
        "friction".to_string(),
        toml::Value::Float(cfg.contact.effective_friction()),
    );
    if let Some(t) = cfg.belt.installation_tension_n {
        metadata.insert("installation_tension_n".to_string(), toml::Value::Float(t));
    }
    let comment = format!(
        "synthetic measurement by beltwin {}: sensor {} Hz, {} pulses/rev, noise {} rpm, seed {}",
        env!("CARGO_PKG_VERSION"),
        sensor.sample_rate_hz,
        sensor.pulses_per_rev,
        sensor.speed_noise_rpm,
        sensor.seed
    );
    append_run(
        dir,
        RunEntry {
            file: file.clone(),
            label: label.to_string(),
            center_distance_m: Some(cfg.center_distance_m()),
            metadata,
        },
        &rec,
        &comment,
        (cfg.driver.pitch_diameter_m, cfg.driven.pitch_diameter_m),
    )?;
    Ok(file)
}

fn run_train(a: TrainArgs) -> Result<(), Box<dyn std::error::Error>> {
    let cfg = match &a.config {
        Some(p) => DriveConfig::from_file(p)?,
        None => DriveConfig::default_hvac(),
    };
    let mut settings = match &a.settings {
        Some(p) => CampaignSettings::from_toml_str(
            &std::fs::read_to_string(p).map_err(|e| format!("reading {}: {e}", p.display()))?,
            &p.display().to_string(),
        )?,
        None => CampaignSettings::default(),
    };
    if let Some(n) = a.samples {
        settings.samples = n;
    }
    if let Some(s) = a.seed {
        settings.seed = s;
    }
    settings.validate()?;
    set_threads(a.threads)?;
    let report = if a.merge {
        training::merge(&a.data)?
    } else {
        let bar = indicatif::ProgressBar::new(0);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "training {bar:40} {pos}/{len} runs, {msg} [{elapsed_precise} < {eta}]",
            )
            .expect("valid template"),
        );
        let failures = std::sync::atomic::AtomicUsize::new(0);
        let on_event = |e: Event| match e {
            Event::Started { pending, done } => {
                bar.set_length(pending as u64);
                bar.set_message(format!("0 failed ({done} done earlier)"));
            }
            Event::Finished { index, error } => {
                if let Some(err) = error {
                    let n = failures.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    bar.println(format!("point {index} failed: {err}"));
                    bar.set_message(format!("{n} failed"));
                }
                bar.inc(1);
            }
        };
        let r = training::run_campaign(&a.data, &cfg, &settings, a.shard, &on_event)?;
        bar.finish_and_clear();
        r
    };
    println!(
        "campaign {}: {} points, {} run now, {} done earlier, {} failed{}",
        a.data.display(),
        report.total,
        report.ran,
        report.skipped,
        report.failed,
        if report.complete {
            ""
        } else {
            " (shard finished; join with --merge when all shards are done)"
        }
    );
    if report.complete {
        fit_and_save(&a.data, &a.model)?;
    }
    Ok(())
}

fn set_threads(threads: Option<usize>) -> Result<(), String> {
    if let Some(t) = threads {
        if t == 0 {
            return Err("--threads must be at least 1".into());
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| format!("--threads {t}: {e}"))?;
    }
    Ok(())
}

fn fit_and_save(
    data: &std::path::Path,
    model: &std::path::Path,
) -> Result<(), Box<dyn std::error::Error>> {
    let t = std::time::Instant::now();
    let ds = training::Dataset::load(data)?;
    let hash = training::config_hash(&ds.config);
    let s = Surrogate::fit(&ds, rom::surrogate::DEFAULT_ENERGY)?;
    let file = SurrogateFile::new(s, hash);
    file.save(model)?;
    let s = &file.surrogate;
    println!(
        "surrogate {}: {} runs ({} failed), start-up {} modes ({:.3} % energy), steady {} modes \
         ({:.3} % energy), leave-one-out sd factor {:.2}, fitted in {:.1} s",
        model.display(),
        s.training_runs,
        s.failed_runs,
        s.startup.gps.len(),
        100.0 * s.startup.basis.energy_kept,
        s.steady.gps.len(),
        100.0 * s.steady.basis.energy_kept,
        s.std_calibration,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Loads the surrogate and the configuration it is used with (checked against --config).
fn load_model(
    model: &std::path::Path,
    config: Option<&std::path::Path>,
) -> Result<(SurrogateFile, DriveConfig), Box<dyn std::error::Error>> {
    let file = SurrogateFile::load(model)?;
    let cfg = match config {
        Some(p) => {
            let cfg = DriveConfig::from_file(p)?;
            file.check_config(&training::config_hash(&cfg), &p.display().to_string())?;
            cfg
        }
        None => file.surrogate.config()?,
    };
    Ok((file, cfg))
}

fn run_predict(a: PredictArgs) -> Result<(), Box<dyn std::error::Error>> {
    let (file, cfg) = load_model(&a.model, a.config.as_deref())?;
    let q = Query {
        center_distance_m: a.d,
        friction: a.mu.unwrap_or(cfg.contact.effective_friction()),
        installation_tension_n: match a.tension {
            Some(t) => t,
            None => cfg.belt.installation_tension_n.ok_or(
                "the surrogate's configuration has no installation tension; pass --tension",
            )?,
        },
        axial_stiffness_n: a.stiffness,
    };
    let dist =
        rom::predict_distribution(&file.surrogate, &cfg, &q, a.samples, a.allow_extrapolation)?;
    let out = match a.format {
        Format::Text => dist.to_text() + "\n",
        Format::Json => serde_json::to_string_pretty(&dist)? + "\n",
        Format::Csv => dist.to_csv(),
    };
    if let Some(p) = &a.plot {
        let q = &dist.quantiles_pct;
        rom::plot::box_plot_svg(
            p,
            &format!("Predicted slip at d = {:.4} m", dist.center_distance_m),
            &[rom::plot::BoxSpec {
                category: format!("d = {:.4} m", dist.center_distance_m),
                series: "twin (surrogate)".into(),
                quantiles: [q.p05, q.p25, q.p50, q.p75, q.p95],
            }],
        )?;
    }
    if let Some(p) = &a.startup {
        let series = file.surrogate.predict_startup(&cfg, &q)?;
        let mut text = String::from("time_s,slip_pct\n");
        for (t, v) in file.surrogate.startup_time_s.iter().zip(series) {
            text += &format!("{t:.3},{v:.5}\n");
        }
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    print!("{out}");
    Ok(())
}

fn run_validate(a: ValidateArgs) -> Result<(), Box<dyn std::error::Error>> {
    set_threads(a.threads)?;
    let file = SurrogateFile::load(&a.model)?;
    let seed = a.seed.unwrap_or(file.header.seed.wrapping_add(1));
    let bar = indicatif::ProgressBar::new(a.points as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "validating {bar:40} {pos}/{len} full-order runs [{elapsed_precise} < {eta}]",
        )
        .expect("valid template"),
    );
    let report = rom::validate::validate(&file.surrogate, a.points, seed, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&report)?;
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    println!("{}", report.to_text());
    Ok(())
}

fn run_diagnose(a: DiagnoseArgs) -> Result<(), Box<dyn std::error::Error>> {
    use rom::twin::diagnose;
    let (file, cfg) = load_model(&a.model, a.config.as_deref())?;
    let set = rom::twin::measured::read_dataset(&a.measured, diagnose::MIN_STEADY_SAMPLES)?;
    let verdicts = diagnose::diagnose(&file.surrogate, &cfg, &set)?;
    let text = diagnose::to_text(&verdicts);
    if let Some(dir) = &a.report {
        let json = serde_json::to_string_pretty(&verdicts)?;
        let mut boxes = Vec::new();
        for v in &verdicts {
            if let (Some(m), Some(e)) = (&v.measured, &v.estimate) {
                boxes.push(rom::plot::BoxSpec {
                    category: v.label.clone(),
                    series: "measured".into(),
                    quantiles: m.quantiles_pct,
                });
                boxes.push(rom::plot::BoxSpec {
                    category: v.label.clone(),
                    series: "twin".into(),
                    quantiles: e.twin_quantiles_pct,
                });
            }
        }
        std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
        if !boxes.is_empty() {
            rom::plot::box_plot_svg(
                &dir.join("slip-boxplots.svg"),
                "Steady slip: measured and twin",
                &boxes,
            )?;
        }
        fom::output::write_atomic(&dir.join("diagnosis.json"), |w| {
            w.write_all(json.as_bytes())
        })?;
        fom::output::write_atomic(&dir.join("diagnosis.txt"), |w| w.write_all(text.as_bytes()))?;
    }
    print!("{text}");
    Ok(())
}

fn run_calibrate(a: CalibrateArgs) -> Result<(), Box<dyn std::error::Error>> {
    use rom::twin::calibrate::{self, Distances, FreeSet, Target};
    let (file, cfg) = load_model(&a.model, a.config.as_deref())?;
    if !(a.tolerance.is_finite() && a.tolerance > 0.0) {
        return Err(format!("--tolerance must be positive, got {}", a.tolerance).into());
    }
    let targets: Vec<Target> = match (&a.measured, &a.table) {
        (_, Some(t)) => calibrate::read_slip_table(t)?,
        (Some(dir), None) => {
            let set =
                rom::twin::measured::read_dataset(dir, rom::twin::diagnose::MIN_STEADY_SAMPLES)?;
            calibrate::targets_from_dataset(
                &set,
                cfg.driven.pitch_diameter_m / cfg.driver.pitch_diameter_m,
            )?
        }
        (None, None) => unreachable!("clap requires one"),
    };
    let free = a.free.unwrap_or(FreeSet {
        friction: true,
        tension: true,
        ratio: false,
        stiffness: false,
        distances: if targets.iter().all(|t| t.known_center_distance_m.is_some()) {
            Distances::Known
        } else {
            Distances::Free
        },
    });
    let s = &file.surrogate;
    let c = calibrate::calibrate(s, &cfg, &targets, free, a.tolerance, !a.no_confirm)?;
    let mut text = c.to_text() + "\n";
    if a.leave_one_out {
        text += "leave-one-out (calibrate on the others, predict this one):\n";
        for i in 0..targets.len() {
            let rest: Vec<Target> = targets
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, t)| t.clone())
                .collect();
            let ci = calibrate::calibrate(s, &cfg, &rest, free, a.tolerance, false)?;
            let d = match (ci.spacing_m, free.distances) {
                (Some([d0, step]), _) => d0 - targets[i].position * step,
                (None, Distances::Known) => targets[i].known_center_distance_m.unwrap_or(f64::NAN),
                _ => f64::NAN,
            };
            let line = if d.is_finite() {
                let pred = calibrate::predict_condition(s, &cfg, &ci, d)?;
                let t = targets[i].mean_slip_pct;
                format!(
                    "  {:<8} d {:.5} m  measured {:.4}  predicted {:.4}  error {:.2} %\n",
                    targets[i].label,
                    d,
                    t,
                    pred,
                    100.0 * (pred - t).abs() / t
                )
            } else {
                format!(
                    "  {:<8} not predictable: its distance is a free parameter of its own\n",
                    targets[i].label
                )
            };
            text += &line;
        }
    }
    if let Some(out) = &a.out {
        let labels: Vec<String> = targets.iter().map(|t| t.label.clone()).collect();
        let toml = calibrate::calibrated_config_toml(&cfg, &c, &labels);
        fom::output::write_atomic(out, |w| w.write_all(toml.as_bytes()))?;
        text += &format!("wrote {}\n", out.display());
    }
    print!("{text}");
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
