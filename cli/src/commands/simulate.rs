//! `rom simulate`: one full-order run.

use fom::belt_kind::tooth_record::{tooth_loads_csv, ToothRecord};
use fom::output::{run_csv, tension_profile_csv, OutputSet};
use fom::{DesignPoint, RunOptions};
use twin::sensor::SensorModel;

use super::{drive_config, print_report, CommandResult};
use crate::args::{ReportFormat, SimulateArgs};
use crate::progress;

pub fn run(a: SimulateArgs) -> CommandResult {
    // Every output path is checked before any work, and the files are renamed into place
    // together at the end (docs/decisions/output-files.md).
    let mut outputs = OutputSet::new();
    for (path, flag) in [
        (&a.out, "--out"),
        (&a.tension_profile, "--tension-profile"),
        (&a.tooth_loads, "--tooth-loads"),
    ] {
        if let Some(p) = path {
            outputs.add(p, flag)?;
        }
    }
    if let Some(dir) = &a.measurement_out {
        check_measurement_dir(dir)?;
    }
    let base = drive_config(a.config.as_deref())?;
    if a.side_gap.is_some() && base.belt.teeth.is_none() {
        return Err("--side-gap needs a toothed belt (belt.kind = \"toothed\")".into());
    }
    let cfg = run_config(&a, &base)?;
    let sensor = sensor_model(&a, &cfg);
    sensor.validate()?;
    if let Some(label) = &a.label {
        twin::sensor::check_label(label)?;
    }
    // A data set the run would be appended to is read before the run, so that a bad manifest
    // there is reported before any simulation and before any file is written.
    if let Some(dir) = &a.measurement_out {
        if dir.join("manifest.toml").exists() {
            twin::measured::read_manifest(dir)?;
        }
    }
    if a.tooth_loads.is_some() && cfg.belt.teeth.is_none() {
        return Err(format!(
            "--tooth-loads needs a toothed belt (belt.kind = \"toothed\"); this drive's belt is \
             \"{}\"",
            cfg.belt.kind.name()
        )
        .into());
    }
    let bar = progress::simulation(&cfg);
    let callback = bar.as_ref().map(progress::simulation_callback);
    let result = fom::simulate(
        &cfg,
        RunOptions {
            progress: callback.as_ref().map(|c| c as &(dyn Fn(f64, f64) + Sync)),
            ..RunOptions::default()
        },
    )?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    if !result.summary.settling.is_settled() {
        eprintln!("warning: {}", result.summary.settling_text());
    }
    if let Some(w) = result.summary.energy_warning() {
        eprintln!("warning: {w}");
    }
    if let Some(w) = result.model.strain_warning() {
        eprintln!("warning: {w}");
    }
    if let Some(out) = &a.out {
        outputs.write(out, |w| run_csv(w, &result.rows))?;
    }
    if let Some(p) = &a.tension_profile {
        outputs.write(p, |w| tension_profile_csv(w, &result.tension_profile))?;
    }
    if let (Some(p), Some(rec)) = (&a.tooth_loads, result.record::<ToothRecord>()) {
        outputs.write(p, |w| tooth_loads_csv(w, rec))?;
    }
    // The measurement is appended before the files are renamed into place: it is the step
    // that can still fail on the data set's side.
    let measurement = match (&a.measurement_out, &a.label) {
        (Some(dir), Some(label)) => Some((
            dir,
            twin::sensor::append_synthetic_run(dir, label, &cfg, &result.rows, &sensor)?,
        )),
        _ => None,
    };
    outputs.commit()?;
    // With JSON on stdout, the files written are named on stderr.
    let json = a.format == ReportFormat::Json;
    let wrote = |line: String| {
        if json {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    if let Some(out) = &a.out {
        wrote(format!("wrote {}", out.display()));
    }
    if let Some((dir, file)) = &measurement {
        wrote(format!(
            "wrote {} (manifest {})",
            dir.join(file).display(),
            dir.join("manifest.toml").display()
        ));
    }
    if let (Some(p), Some(_)) = (&a.tooth_loads, result.record::<ToothRecord>()) {
        wrote(format!("wrote {}", p.display()));
    }
    let mut text = format!(
        "centre distance    {:.4} m, effective friction {:.3}, static span tension {:.1} N\n",
        cfg.center_distance_m(),
        cfg.effective_friction(),
        result.static_tension_n
    );
    if !cfg.effects.is_empty() {
        text += &format!("effects            {}\n", cfg.effects.names().join(", "));
    }
    text += &format!("{}\n", result.summary.to_text());
    if let Some(rec) = result.record::<ToothRecord>() {
        text += &format!("{}\n", rec.to_text());
    }
    let summary = RunReport {
        center_distance_m: cfg.center_distance_m(),
        effective_friction: cfg.effective_friction(),
        static_tension_n: result.static_tension_n,
        effects: cfg.effects.names(),
        summary: &result.summary,
    };
    print_report(a.format, &text, &summary)
}

/// The drive of this run: the configuration at the flags' point, with the run's own duration,
/// settling rule and effects on top, checked again.
fn run_config(
    a: &SimulateArgs,
    base: &fom::DriveConfig,
) -> Result<fom::ValidConfig, Box<dyn std::error::Error>> {
    let point = DesignPoint::nominal_with(base, a.d, a.mu, a.tension).with_tooth_inputs(
        a.side_gap,
        a.load_torque,
        a.shaft_load,
    );
    let mut cfg = point.apply(base)?;
    if a.until_settled || a.duration.is_some() || !a.effects.is_empty() {
        // The run's own settings on top of the point: a changed configuration, checked again.
        let mut edit = cfg.into_inner();
        if a.until_settled {
            edit.simulation.until_settled = Some(fom::config::UntilSettled::default());
            edit.simulation.steady_start_s = None;
            // Without --duration, the training campaign's longest run.
            let longest_s = training::CampaignSettings::default().duration_s;
            edit.simulation.duration_s = a.duration.unwrap_or(longest_s);
        } else if let Some(t) = a.duration {
            edit.simulation.duration_s = t;
        }
        for spec in &a.effects {
            let spec = spec.to_spec();
            edit.effects
                .set_from_spec(&spec)
                .map_err(|e| format!("--effect {spec}: {e}"))?;
        }
        cfg = edit.check()?;
    }
    Ok(cfg)
}

/// The sensor of a synthetic measurement: the flags, else the configuration's tachometer.
fn sensor_model(a: &SimulateArgs, cfg: &fom::ValidConfig) -> SensorModel {
    let from_cfg = SensorModel::from_config(cfg);
    SensorModel {
        sample_rate_hz: a.sample_rate,
        pulses_per_rev: a.pulses_per_rev.unwrap_or(from_cfg.pulses_per_rev),
        speed_noise_rpm: [a.speed_noise_rpm; 2],
        timer_resolution_s: a.timer_resolution.unwrap_or(from_cfg.timer_resolution_s),
        missing_pulse_share: a
            .missing_pulse_share
            .unwrap_or(from_cfg.missing_pulse_share),
        gate_s: a.gate,
        noise_excess_kurtosis: [0.0; 2],
        noise_taps: [None; 2],
        edge_jitter_s: a.edge_jitter,
        seed: a.noise_seed,
    }
}

/// What `rom simulate --format json` prints: the run's point and its steady summary.
#[derive(serde::Serialize)]
struct RunReport<'a> {
    center_distance_m: f64,
    effective_friction: f64,
    static_tension_n: f64,
    effects: Vec<String>,
    summary: &'a fom::output::RunSummary,
}

/// `--measurement-out`: a directory (or a new path), whose manifest, when there is one, is a
/// file the run can be appended to (`fom::output::check_output_path`).
fn check_measurement_dir(dir: &std::path::Path) -> CommandResult {
    match std::fs::symlink_metadata(dir) {
        Ok(m) if m.is_dir() => {
            fom::output::check_output_path(&dir.join("manifest.toml"), "--measurement-out")?;
            Ok(())
        }
        Ok(_) => Err(format!(
            "--measurement-out {}: not a directory (a measured data set is a directory with \
             manifest.toml)",
            dir.display()
        )
        .into()),
        Err(_) => Ok(()),
    }
}
