//! `rom export-fmu`: the surrogate or the full-order model as an FMI 2.0 co-simulation FMU
//! (`fmu::write_fmu`; why FMI 2.0 and a hand-written binary: docs/decisions/fmi-version.md).

use std::path::PathBuf;

use fmu::variables::Causality;
use fmu::FmuKind;
use rom::ModelFile;

use super::{drive_config, CommandResult};
use crate::args::{ExportFmuArgs, FmuKindArg};

/// The FMU binary's file name beside the `rom` executable (the workspace builds it there:
/// docs/guide/export-fmu.md).
const LIB_NAME: &str = "libbeltwin_fmu.so";

pub fn run(a: ExportFmuArgs) -> CommandResult {
    // The FMU is staged and renamed into place at the end (docs/decisions/output-files.md).
    let mut outputs = fom::output::OutputSet::new();
    outputs.add(&a.out, "--out")?;
    if a.out.extension().and_then(|e| e.to_str()) != Some("fmu") {
        return Err(format!("--out {}: an FMU's file name ends in .fmu", a.out.display()).into());
    }
    let lib = match &a.fmu_lib {
        Some(p) => p.clone(),
        None => beside_executable()?,
    };
    let binary = fmu::read_binary(&lib).map_err(|e| format!("--fmu-lib {e}"))?;
    let (kind, cfg, model) = match a.kind {
        FmuKindArg::Surrogate => {
            let (file, cfg) = ModelFile::open(a.model.as_deref(), a.config.as_deref())?;
            let file = file.into_slip("rom export-fmu --kind surrogate")?;
            let bytes = match &a.model {
                Some(p) => std::fs::read(p)
                    .map_err(|e| format!("--model {}: cannot read: {e}", p.display()))?,
                None => rom::shipped::SLIP.bytes.to_vec(),
            };
            (FmuKind::Surrogate, cfg, Some((file, bytes)))
        }
        FmuKindArg::Fom => {
            if a.model.is_some() {
                return Err(super::UsageError {
                    kind: clap::error::ErrorKind::ArgumentConflict,
                    message: "--model belongs to --kind surrogate (the full-order FMU runs the \
                              drive of --config)"
                        .into(),
                }
                .into());
            }
            (FmuKind::Fom, drive_config(a.config.as_deref())?, None)
        }
    };
    let model_ref = model.as_ref().map(|(f, b)| (f, b.as_slice()));
    let mut packed = None;
    outputs.write_with(&a.out, |tmp| -> CommandResult {
        packed = Some(fmu::write_fmu(tmp, kind, &cfg, model_ref, &binary)?);
        Ok(())
    })?;
    outputs.commit()?;
    let packed = packed.expect("written above");
    let count = |c: Causality| packed.variables.iter().filter(|v| v.causality == c).count();
    println!(
        "wrote {} (FMI 2.0 co-simulation, {} inputs, {} parameters, {} outputs; guid {})",
        a.out.display(),
        count(Causality::Input),
        count(Causality::Parameter),
        count(Causality::Output),
        packed.guid
    );
    Ok(())
}

/// The FMU binary beside the running `rom` executable, or in the `deps/` folder there (where
/// cargo leaves it when the library was built only as a dependency).
fn beside_executable() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot locate rom itself: {e}"))?;
    let dir = exe.parent().ok_or("rom has no folder")?;
    let beside = dir.join(LIB_NAME);
    let in_deps = dir.join("deps").join(LIB_NAME);
    Ok(if !beside.exists() && in_deps.exists() {
        in_deps
    } else {
        beside
    })
}
