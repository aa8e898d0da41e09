//! `rom validate`: the surrogate against fresh full-order runs.

use super::{load_model, set_threads, CommandResult};
use crate::args::ValidateArgs;
use crate::progress;

pub fn run(a: ValidateArgs) -> CommandResult {
    set_threads(a.threads)?;
    let (file, _) = load_model(a.model.as_deref(), None)?;
    let seed = a.seed.unwrap_or(file.header.seed.wrapping_add(1));
    let bar = progress::validation(a.points);
    let report = rom::validate::validate(&file.surrogate, a.points, seed, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&report)?;
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    println!("{}", report.to_text());
    Ok(())
}
