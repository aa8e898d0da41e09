//! `rom validate`: the surrogate against fresh full-order runs.

use rom::ModelFile;

use super::{load_model, set_threads, CommandResult};
use crate::args::{ReportFormat, ValidateArgs};
use crate::progress;

pub fn run(a: ValidateArgs) -> CommandResult {
    set_threads(a.threads)?;
    // Output paths are checked before any run (docs/decisions/output-files.md).
    for (path, flag) in [(&a.json, "--json"), (&a.out, "--out")] {
        if let Some(p) = path {
            fom::output::check_output_path(p, flag)?;
        }
    }
    if !a.calibrate_intervals.is_empty() {
        return calibrate_intervals(&a);
    }
    if a.knee || a.onset {
        return knee_or_onset(&a);
    }
    let (model, _) = ModelFile::open(a.model.as_deref(), None)?;
    let seed = a.seed.unwrap_or(model.training_seed().wrapping_add(1));
    let bar = progress::validation(a.points);
    let report = model.validate(a.points, seed, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    write_and_print(&a, report.as_ref())
}

/// Writes `--json` and prints the report (its text, or the same JSON with `--format json`).
fn write_and_print(a: &ValidateArgs, report: &dyn rom::kind::Validation) -> CommandResult {
    let json = report.to_json();
    if let Some(p) = &a.json {
        fom::output::write_atomic(p, |w| w.write_all(json.as_bytes()))?;
    }
    match a.format {
        ReportFormat::Text => println!("{}", report.to_text()),
        ReportFormat::Json => println!("{json}"),
    }
    Ok(())
}

/// `rom validate --knee` or `--onset`: points at the slip surrogate's looseness knee, or at
/// its onset outside the knee band.
fn knee_or_onset(a: &ValidateArgs) -> CommandResult {
    let (file, _) = load_model(a.model.as_deref(), None)?;
    let seed = a.seed.unwrap_or(file.header.seed.wrapping_add(1));
    let s = &file.surrogate;
    let (design, which) = if a.knee {
        (
            rom::validate::knee_design(s, a.points, seed)?,
            "at the loosest 5 % of the box",
        )
    } else {
        (
            rom::validate::onset_design(s, a.points, seed)?,
            "at the knee's onset outside the knee band",
        )
    };
    if design.is_empty() {
        return Err(format!(
            "--{}: no candidate {which} lies inside the surrogate's domain",
            if a.knee { "knee" } else { "onset" }
        )
        .into());
    }
    if design.len() < a.points {
        eprintln!(
            "only {} candidates {which} lie inside the surrogate's domain (asked for {})",
            design.len(),
            a.points
        );
    }
    let bar = progress::validation(design.len());
    let mut report = rom::validate::validate_at(s, &design, seed, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    report.config_sha256 = Some(file.header.config_sha256.clone());
    write_and_print(a, &report)
}

/// `rom validate --calibrate-intervals FILES --out MODEL`: the 90 % intervals calibrated on
/// held-out full-order runs (`Surrogate::calibrate_intervals`); no run is made.
fn calibrate_intervals(a: &ValidateArgs) -> CommandResult {
    let out = a
        .out
        .as_deref()
        .ok_or("--calibrate-intervals needs --out")?;
    let (mut file, _) = load_model(a.model.as_deref(), None)?;
    let (mut runs, mut seeds) = (Vec::new(), Vec::new());
    for path in &a.calibrate_intervals {
        let (seed, r, named) = rom::validate::read_held_out(path, &file.header.config_sha256)?;
        if seed == file.surrogate.settings.seed {
            return Err(format!(
                "{}: its seed {seed} is the training seed: its points are training points, not \
                 held-out ones",
                path.display()
            )
            .into());
        }
        if !named {
            println!(
                "{}: written before validation files named their drive configuration; its runs \
                 are taken as runs of this surrogate's drive",
                path.display()
            );
        }
        println!("{}: {} settled runs (seed {seed})", path.display(), r.len());
        runs.extend(r);
        if !seeds.contains(&seed) {
            seeds.push(seed);
        }
    }
    let s = &mut file.surrogate;
    // Before: the creep plateau's, the onset's and the knee band's factors.
    let before = [
        s.interval_factor(f64::INFINITY, 0.0),
        s.interval_factor(f64::INFINITY, f64::INFINITY),
        s.interval_factor(f64::NEG_INFINITY, 0.0),
    ];
    let c = s.calibrate_intervals(&runs, &seeds)?;
    let rms = |r: Option<f64>| r.map_or_else(|| "-".to_string(), |v| format!("{v:.3}"));
    println!(
        "90 % interval factor on the processes' sd, creep plateau: {:.3} -> {:.3} ({} held-out \
         runs); the knee's onset outside the knee band (predicted slip from {} %): {:.3} -> \
         {:.3} ({} runs{}); the knee band: {:.3} -> {:.3} ({} runs)\n\
         the likelihoods of rom calibrate, diagnose and gap keep the leave-one-out factors \
         {:.3} / {:.3}; the held-out scores' root mean square: {} / {} / {}",
        before[0],
        c.factor,
        c.runs_outside_band,
        rom::surrogate::ONSET_SLIP_PCT,
        before[1],
        c.factor_onset.unwrap_or(c.factor),
        c.runs_onset,
        if c.factor_onset.is_none() {
            ", too few: the creep plateau's factor"
        } else {
            ""
        },
        before[2],
        c.factor_knee,
        c.runs_in_band,
        s.std_factor(f64::INFINITY),
        s.std_factor(f64::NEG_INFINITY),
        rms(c.rms_score),
        rms(c.rms_score_onset),
        rms(c.rms_score_knee),
    );
    file.save(out)?;
    println!(
        "wrote {} (`rom validate` on it refuses seeds {:?})",
        out.display(),
        c.seeds
    );
    Ok(())
}
