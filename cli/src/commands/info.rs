//! `rom info`: what a model file is (`rom::info::ModelInfo`), text or JSON from one struct;
//! a shipped model's validation summary comes from the embedded manifest.

use rom::info::{Manifest, ModelInfo};
use rom::ModelFile;

use super::{print_report, CommandResult};
use crate::args::InfoArgs;

pub fn run(a: InfoArgs) -> CommandResult {
    let (model, _) = ModelFile::open(a.model.as_deref(), a.config.as_deref())?;
    let info = describe(&model)?;
    print_report(a.format, &info.to_text(), &info)
}

/// The information of `model`: a shipped model's manifest entry (the same bytes, by id), else
/// what its header records.
fn describe(model: &ModelFile) -> Result<ModelInfo, rom::RomError> {
    let manifest = Manifest::shipped()?;
    Ok(match manifest.entry(model.model_id()) {
        Some(entry) => entry.clone(),
        None => ModelInfo::of(model),
    })
}

/// The shipped models' trained ranges, for `rom predict --help`.
pub fn trained_ranges_help() -> String {
    let mut t = String::from("Trained ranges of the shipped models (rom info shows more):");
    for kind in rom::Kind::ALL {
        let Ok(m) = kind.shipped() else { continue };
        let n = fom::readable::readable;
        let ranges: Vec<String> = m
            .ranges()
            .into_iter()
            .map(|(v, [lo, hi])| format!("{} {} to {}", v.describe(), n(lo), n(hi)))
            .collect();
        t += &format!("\n  {}: {}", kind.name(), ranges.join("; "));
    }
    t += "\nOutside them a prediction is refused unless --allow-extrapolation; a point outside \
          physics is refused always (docs/decisions/physical-domain.md).";
    t
}
