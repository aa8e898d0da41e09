//! `rom validate`: the surrogate against fresh full-order runs.

use super::{load_model, set_threads, CommandResult};
use crate::args::ValidateArgs;
use crate::progress;

pub fn run(a: ValidateArgs) -> CommandResult {
    set_threads(a.threads)?;
    if let Some(m) = a
        .model
        .as_deref()
        .filter(|m| rom::tooth::ToothSurrogateFile::is_tooth_file(m))
    {
        return run_tooth(&a, m);
    }
    if !a.calibrate_intervals.is_empty() {
        return calibrate_intervals(&a);
    }
    let (file, _) = load_model(a.model.as_deref(), None)?;
    let seed = a.seed.unwrap_or(file.header.seed.wrapping_add(1));
    let s = &file.surrogate;
    let mut report = if a.knee {
        let design = rom::validate::knee_design(s, a.points, seed)?;
        if design.is_empty() {
            return Err(
                "--knee: every candidate at the loosest 5 % of the box lies outside the \
                        surrogate's domain"
                    .into(),
            );
        }
        if design.len() < a.points {
            eprintln!(
                "only {} candidates at the loosest 5 % of the box lie inside the surrogate's \
                 domain (asked for {})",
                design.len(),
                a.points
            );
        }
        let bar = progress::validation(design.len());
        let r = rom::validate::validate_at(s, &design, seed, &|_| bar.inc(1))?;
        bar.finish_and_clear();
        r
    } else {
        let bar = progress::validation(a.points);
        let r = rom::validate::validate(s, a.points, seed, &|_| bar.inc(1))?;
        bar.finish_and_clear();
        r
    };
    report.config_sha256 = Some(file.header.config_sha256.clone());
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&report)?;
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    println!("{}", report.to_text());
    Ok(())
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
    let before = (
        s.interval_factor(f64::INFINITY),
        s.interval_factor(f64::NEG_INFINITY),
    );
    let c = s.calibrate_intervals(&runs, &seeds)?;
    let rms = |r: Option<f64>| r.map_or_else(|| "-".to_string(), |v| format!("{v:.3}"));
    println!(
        "90 % interval factor on the processes' sd outside the knee band: {:.3} -> {:.3} ({} \
         held-out runs); in it: {:.3} -> {:.3} ({} runs)\n\
         the likelihoods of rom calibrate, diagnose and gap keep the leave-one-out factors \
         {:.3} / {:.3}; the held-out scores' root mean square: {} / {}",
        before.0,
        c.factor,
        c.runs_outside_band,
        before.1,
        c.factor_knee,
        c.runs_in_band,
        s.std_factor(f64::INFINITY),
        s.std_factor(f64::NEG_INFINITY),
        rms(c.rms_score),
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

/// `rom validate --model TOOTH-SURROGATE`: the tooth-load surrogate against fresh runs.
fn run_tooth(a: &ValidateArgs, model: &std::path::Path) -> CommandResult {
    if a.knee {
        return Err(
            "--knee belongs to the slip surrogate; a tooth-load surrogate has no knee".into(),
        );
    }
    let file = rom::tooth::ToothSurrogateFile::load(model)?;
    let seed = a.seed.unwrap_or(file.header.seed.wrapping_add(1));
    let bar = progress::validation(a.points);
    let checks = rom::tooth::validate_tooth(&file.surrogate, a.points, seed, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&checks)?;
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    println!("{}", rom::tooth::validation_text(&checks));
    Ok(())
}
