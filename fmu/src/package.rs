//! Packing an FMU (FMI 2.0.4 standard, section 2.3): `modelDescription.xml`, the binary under
//! `binaries/linux64/`, and `resources/` with the drive configuration, the surrogate (for the
//! surrogate kind) and a small manifest the binary reads at instantiation.

use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::description::{model_description, Header};
use crate::variables::{fom_variables, surrogate_variables, Var};

/// The manifest's file name in `resources/`.
pub const MANIFEST_FILE: &str = "beltwin-fmu.toml";
/// The drive configuration's file name in `resources/`.
const CONFIG_FILE: &str = "drive.toml";
/// The surrogate's file name in `resources/`.
const MODEL_FILE: &str = "surrogate.json";
/// The FMI 2.0 platform folder of 64-bit Linux.
pub const PLATFORM: &str = "linux64";

/// What the binary reads first from `resources/`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The model description's `guid` (the instantiation token).
    pub guid: String,
    /// The drive configuration, relative to `resources/`.
    pub config: String,
    /// The slip surrogate, relative to `resources/`; absent for the full-order FMU.
    pub model: Option<String>,
}

/// The model an FMU wraps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmuKind {
    /// The slip surrogate (`rom predict`).
    Surrogate,
    /// The full-order model (`rom simulate`).
    Fom,
}

impl FmuKind {
    /// The model identifier: the binary's name in the FMU.
    pub fn model_identifier(self) -> &'static str {
        match self {
            FmuKind::Surrogate => "beltwin_slip_surrogate",
            FmuKind::Fom => "beltwin_belt_drive",
        }
    }
}

/// What an export packed, for the command's report.
#[derive(Debug, Clone)]
pub struct Packed {
    pub guid: String,
    pub variables: Vec<Var>,
    pub binary_bytes: usize,
}

/// The stable instantiation token: a hash of everything the FMU holds but its binary (the
/// kind, the variable table, the configuration, the surrogate, the crate version), written as
/// a UUID.
fn guid(kind: FmuKind, vars: &[Var], config: &str, model: Option<&[u8]>) -> String {
    let mut h = Sha256::new();
    h.update(kind.model_identifier());
    h.update(env!("CARGO_PKG_VERSION"));
    h.update(format!("{vars:?}"));
    h.update(config);
    h.update(model.unwrap_or_default());
    let x: String = h.finalize().iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &x[0..8],
        &x[8..12],
        &x[12..16],
        &x[16..20],
        &x[20..32]
    )
}

/// Reads the FMU binary at `lib`, refusing a file that is not the beltwin FMU library.
pub fn read_binary(lib: &Path) -> Result<Vec<u8>, String> {
    let bytes = std::fs::read(lib).map_err(|e| format!("{}: cannot read: {e}", lib.display()))?;
    let exports = |name: &[u8]| bytes.windows(name.len()).any(|w| w == name);
    if !bytes.starts_with(b"\x7fELF") || !exports(b"fmi2DoStep") {
        return Err(format!(
            "{}: not the beltwin FMU library (a shared object exporting fmi2DoStep); build it \
             with `cargo build --release -p beltwin-fmu`",
            lib.display()
        ));
    }
    Ok(bytes)
}

/// Everything an FMU holds but its binary.
pub struct Contents {
    pub guid: String,
    pub variables: Vec<Var>,
    pub model_description: String,
    /// Files of `resources/`: name and bytes.
    pub resources: Vec<(String, Vec<u8>)>,
}

/// The contents of the FMU of `kind`: the surrogate `model` (with its file's bytes; surrogate
/// kind) on the configuration `cfg`.
pub fn contents(
    kind: FmuKind,
    cfg: &fom::ValidConfig,
    model: Option<(&rom::SurrogateFile, &[u8])>,
) -> Result<Contents, String> {
    let config = cfg.to_toml_string();
    let (vars, name, description, stop_s, step_s) = match (kind, model) {
        (FmuKind::Surrogate, Some((file, _))) => {
            let vars = surrogate_variables(cfg, &file.surrogate.settings.ranges());
            let vars: Vec<Var> = vars.into_iter().map(|(v, _)| v).collect();
            let text = format!(
                "beltwin slip surrogate {} (rom predict as a co-simulation FMU)",
                file.header.sha256
            );
            (vars, "beltwin slip surrogate", text, 1.0, 1.0)
        }
        (FmuKind::Fom, None) => (
            fom_variables(cfg)?,
            "beltwin belt drive",
            "beltwin full-order belt drive (rom simulate as a co-simulation FMU)".to_string(),
            cfg.simulation.duration_s,
            cfg.simulation.output_interval_s,
        ),
        _ => return Err("a surrogate FMU needs its surrogate, a full-order FMU none".into()),
    };
    let model_bytes = model.map(|(_, b)| b);
    let guid = guid(kind, &vars, &config, model_bytes);
    let xml = model_description(
        &Header {
            model_name: name,
            model_identifier: kind.model_identifier(),
            guid: &guid,
            description: &description,
            stop_time_s: stop_s,
            step_s,
        },
        &vars,
    );
    let manifest = Manifest {
        guid: guid.clone(),
        config: CONFIG_FILE.into(),
        model: model_bytes.map(|_| MODEL_FILE.into()),
    };
    let manifest = toml::to_string(&manifest).map_err(|e| e.to_string())?;
    let mut resources = vec![
        (MANIFEST_FILE.to_string(), manifest.into_bytes()),
        (CONFIG_FILE.to_string(), config.into_bytes()),
    ];
    if let Some(b) = model_bytes {
        resources.push((MODEL_FILE.to_string(), b.to_vec()));
    }
    Ok(Contents {
        guid,
        variables: vars,
        model_description: xml,
        resources,
    })
}

/// Writes the FMU of `kind` to `out` ([`contents`] and the binary `binary`).
pub fn write_fmu(
    out: &Path,
    kind: FmuKind,
    cfg: &fom::ValidConfig,
    model: Option<(&rom::SurrogateFile, &[u8])>,
    binary: &[u8],
) -> Result<Packed, String> {
    let c = contents(kind, cfg, model)?;
    let id = kind.model_identifier();
    let mut files: Vec<(String, &[u8], u32)> = vec![
        (
            "modelDescription.xml".into(),
            c.model_description.as_bytes(),
            0o644,
        ),
        (format!("binaries/{PLATFORM}/{id}.so"), binary, 0o755),
    ];
    for (name, bytes) in &c.resources {
        files.push((format!("resources/{name}"), bytes, 0o644));
    }
    zip_files(out, &files).map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(Packed {
        guid: c.guid,
        variables: c.variables,
        binary_bytes: binary.len(),
    })
}

/// A zip archive of `files` (name, bytes, Unix mode), deflated, with no time stamps beyond the
/// format's default (the same inputs give the same archive).
fn zip_files(out: &Path, files: &[(String, &[u8], u32)]) -> Result<(), String> {
    let file = std::fs::File::create(out).map_err(|e| e.to_string())?;
    let mut zip = zip::ZipWriter::new(std::io::BufWriter::new(file));
    for (name, bytes, mode) in files {
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .unix_permissions(*mode);
        zip.start_file(name.as_str(), options)
            .map_err(|e| e.to_string())?;
        zip.write_all(bytes).map_err(|e| e.to_string())?;
    }
    zip.finish()
        .map_err(|e| e.to_string())?
        .flush()
        .map_err(|e| e.to_string())
}
