//! What a model file is, in one struct ([`ModelInfo`]) that `rom info` prints as text or JSON
//! and the shipped models' manifest (`artifacts/manifest.json`) lists: its kind, inputs with
//! trained ranges, provenance, its id, and a validation summary computed from its `rom
//! validate` files ([`ValidationSummary::of_files`]).

use serde::{Deserialize, Serialize};

use crate::kind::{Kind, ModelFile, SCHEMA_VERSION};
use crate::RomError;

/// One input of a model with its trained range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputInfo {
    /// Configuration key (unit in its suffix: `_m`, `_n`, `_nm`).
    pub input: String,
    /// Words for it, with the unit.
    pub description: String,
    /// Trained range, [low, high].
    pub trained: [f64; 2],
}

/// Where a model came from: what its header records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    pub format: String,
    pub crate_version: String,
    pub created_utc: String,
    pub samples: usize,
    pub seed: u64,
    pub training_runs: usize,
    pub failed_runs: usize,
    /// SHA-256 of the training configuration's canonical TOML.
    pub config_sha256: String,
}

/// One region of a validation summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionSummary {
    pub region: String,
    /// Points with a settled full-order run.
    pub points: usize,
    /// Mean and largest |model - full-order| of the mean, in `ValidationSummary::error_unit`.
    pub mean_abs_error: f64,
    pub max_abs_error: f64,
    /// Share of points whose full-order mean lies in the model's 90 % interval.
    pub coverage90_share: Option<f64>,
}

/// A validation summary per region, from `rom validate --json` files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationSummary {
    /// The files it is computed from (paths relative to the workspace root).
    pub files: Vec<String>,
    /// Unit of the errors: `pp` (percentage points of slip) or `% of the full-order value`.
    pub error_unit: String,
    pub regions: Vec<RegionSummary>,
}

/// What a model file is (`rom info`; one entry of the manifest).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    pub schema_version: u32,
    /// The model's id: the SHA-256 its header records over the sealed file (`ModelFile::model_id`).
    pub model_id: String,
    /// `slip` or `tooth-load`.
    pub kind: String,
    /// The file, relative to the workspace root (shipped models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// The commit that last changed the file (manifest only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub commit: Option<String>,
    pub inputs: Vec<InputInfo>,
    pub provenance: Provenance,
    /// `None`: not recorded (run `rom validate`).
    pub validation: Option<ValidationSummary>,
}

/// The shipped models' manifest (`artifacts/manifest.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub schema_version: u32,
    pub models: Vec<ModelInfo>,
}

impl Kind {
    /// Short name in reports (`slip`, `tooth-load`).
    pub fn short_name(self) -> &'static str {
        match self {
            Kind::Slip => "slip",
            Kind::ToothLoad => "tooth-load",
        }
    }
}

impl ModelInfo {
    /// The information of `m`, without a validation summary.
    pub fn of(m: &ModelFile) -> Self {
        let inputs = m
            .ranges()
            .into_iter()
            .map(|(v, r)| InputInfo {
                input: v.key().to_string(),
                description: v.describe().to_string(),
                trained: r,
            })
            .collect();
        // The slip and tooth-load headers carry the same provenance fields.
        macro_rules! provenance {
            ($h:expr) => {
                Provenance {
                    format: $h.format.clone(),
                    crate_version: $h.crate_version.clone(),
                    created_utc: $h.created_utc.clone(),
                    samples: $h.samples,
                    seed: $h.seed,
                    training_runs: $h.training_runs,
                    failed_runs: $h.failed_runs,
                    config_sha256: $h.config_sha256.clone(),
                }
            };
        }
        let provenance = match m {
            ModelFile::Slip(f) => provenance!(f.header),
            ModelFile::ToothLoad(f) => provenance!(f.header),
        };
        Self {
            schema_version: SCHEMA_VERSION,
            model_id: m.model_id().to_string(),
            kind: m.kind().short_name().to_string(),
            file: None,
            commit: None,
            inputs,
            provenance,
            validation: None,
        }
    }

    /// The readable report (`rom info`), with a final newline.
    pub fn to_text(&self) -> String {
        let p = &self.provenance;
        let n = fom::readable::readable;
        let mut t = format!(
            "model {} ({} surrogate{})\n",
            &self.model_id[..16.min(self.model_id.len())],
            self.kind,
            self.file
                .as_ref()
                .map_or(String::new(), |f| format!(", shipped: {f}"))
        );
        t += "inputs (trained ranges):\n";
        for i in &self.inputs {
            t += &format!(
                "  {:<34} {} to {}\n",
                i.description,
                n(i.trained[0]),
                n(i.trained[1])
            );
        }
        t += &format!(
            "provenance: {} by beltwin {}, created {}; {} samples, seed {}, {} training runs \
             ({} failed); configuration sha256 {}\n",
            p.format,
            p.crate_version,
            p.created_utc,
            p.samples,
            p.seed,
            p.training_runs,
            p.failed_runs,
            &p.config_sha256[..16.min(p.config_sha256.len())]
        );
        match &self.validation {
            None => t += "validation: not recorded: run rom validate\n",
            Some(v) => {
                let n = v.files.len();
                t += &format!(
                    "validation ({n} file{}; |error| of the mean in {}):\n",
                    if n == 1 { "" } else { "s" },
                    v.error_unit
                );
                for r in &v.regions {
                    t += &format!(
                        "  {:<8} {:>4} points  mean {:.4}  max {:.4}  90 % interval coverage {}\n",
                        r.region,
                        r.points,
                        r.mean_abs_error,
                        r.max_abs_error,
                        r.coverage90_share
                            .map_or("not recorded".into(), |c| format!("{:.0} %", 100.0 * c))
                    );
                }
            }
        }
        t
    }
}

/// A region's running sums.
#[derive(Default)]
struct Acc {
    points: usize,
    sum: f64,
    max: f64,
    covered: usize,
    with_interval: usize,
}

impl Acc {
    fn add(&mut self, abs_error: f64, covered: Option<bool>) {
        self.points += 1;
        self.sum += abs_error;
        self.max = self.max.max(abs_error);
        if let Some(c) = covered {
            self.with_interval += 1;
            self.covered += usize::from(c);
        }
    }

    fn summary(&self, region: &str) -> RegionSummary {
        RegionSummary {
            region: region.to_string(),
            points: self.points,
            mean_abs_error: self.sum / self.points.max(1) as f64,
            max_abs_error: self.max,
            coverage90_share: (self.with_interval > 0)
                .then(|| self.covered as f64 / self.with_interval as f64),
        }
    }
}

impl ValidationSummary {
    /// The summary of a model of `kind` over its validation files, each given as (name, JSON
    /// text): a slip model's `rom validate --json` reports (per region, settled points, error
    /// of the mean slip in pp), or a tooth-load model's checks (one region, error of the mean
    /// pass peak in % of the full-order value).
    pub fn of_files(kind: Kind, files: &[(String, String)]) -> Result<Self, RomError> {
        let bad = |name: &str, m: String| RomError::Data(format!("{name}: {m}"));
        let mut regions: Vec<(String, Acc)> = Vec::new();
        let mut acc_of = |region: &str| -> usize {
            match regions.iter().position(|(r, _)| r == region) {
                Some(i) => i,
                None => {
                    regions.push((region.to_string(), Acc::default()));
                    regions.len() - 1
                }
            }
        };
        let mut adds: Vec<(usize, f64, Option<bool>)> = Vec::new();
        for (name, text) in files {
            let v: serde_json::Value =
                serde_json::from_str(text).map_err(|e| bad(name, e.to_string()))?;
            match kind {
                Kind::Slip => {
                    let points = v["points"]
                        .as_array()
                        .ok_or_else(|| bad(name, "no `points` array".into()))?;
                    for p in points.iter().filter(|p| p["error"].is_null()) {
                        let (Some(region), Some(e)) =
                            (p["region"].as_str(), p["mean_slip_error_pct"].as_f64())
                        else {
                            continue;
                        };
                        adds.push((acc_of(region), e.abs(), p["covered"].as_bool()));
                    }
                }
                Kind::ToothLoad => {
                    let checks = v
                        .as_array()
                        .ok_or_else(|| bad(name, "not a list of checks".into()))?;
                    for c in checks {
                        let f = |k: &str| c[k].as_f64().unwrap_or(f64::NAN);
                        let (fom, rom) = (f("fom_mean_peak_n"), f("rom_mean_peak_n"));
                        let iv = &c["rom_mean_peak_interval_n"];
                        let covered = match (iv[0].as_f64(), iv[1].as_f64()) {
                            (Some(lo), Some(hi)) => Some(fom >= lo && fom <= hi),
                            _ => None,
                        };
                        adds.push((acc_of("all"), 100.0 * ((rom - fom) / fom).abs(), covered));
                    }
                }
            }
        }
        for (i, e, c) in adds {
            regions[i].1.add(e, c);
        }
        Ok(Self {
            files: files.iter().map(|(n, _)| n.clone()).collect(),
            error_unit: match kind {
                Kind::Slip => "pp".into(),
                Kind::ToothLoad => "% of the full-order value".into(),
            },
            regions: regions.iter().map(|(r, a)| a.summary(r)).collect(),
        })
    }
}

impl Manifest {
    /// The embedded manifest of the shipped models (`shipped::MANIFEST`).
    pub fn shipped() -> Result<Self, RomError> {
        serde_json::from_str(crate::shipped::MANIFEST)
            .map_err(|e| RomError::Data(format!("artifacts/manifest.json: {e}")))
    }

    /// The entry of the model with id `model_id`, if it is a shipped one.
    pub fn entry(&self, model_id: &str) -> Option<&ModelInfo> {
        self.models.iter().find(|m| m.model_id == model_id)
    }

    /// The manifest of the shipped models: each with the validation files it lists
    /// (`shipped::VALIDATION_FILES`), read by `read` (a path relative to the workspace root
    /// to its text) and the commit that last changed it by `commit` (the file's path).
    pub fn build(
        read: impl Fn(&str) -> Result<String, RomError>,
        commit: impl Fn(&str) -> Option<String>,
    ) -> Result<Self, RomError> {
        let mut models = Vec::new();
        for (shipped, files) in crate::shipped::VALIDATION_FILES {
            let m = ModelFile::from_bytes(shipped.bytes, shipped.path)?;
            let texts = files
                .iter()
                .map(|f| Ok((f.to_string(), read(f)?)))
                .collect::<Result<Vec<_>, RomError>>()?;
            let mut info = ModelInfo::of(&m);
            info.file = Some(shipped.path.to_string());
            info.commit = commit(shipped.path);
            info.validation = Some(ValidationSummary::of_files(m.kind(), &texts)?);
            models.push(info);
        }
        Ok(Self {
            schema_version: SCHEMA_VERSION,
            models,
        })
    }
}
