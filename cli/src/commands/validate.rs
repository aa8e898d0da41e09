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
    let (file, _) = load_model(a.model.as_deref(), None)?;
    let seed = a.seed.unwrap_or(file.header.seed.wrapping_add(1));
    let s = &file.surrogate;
    let report = if a.knee {
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
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&report)?;
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    println!("{}", report.to_text());
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
