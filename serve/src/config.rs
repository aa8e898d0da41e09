//! `serve.toml`: the drives' models, storage retention, the MQTT broker and the gap checks
//! (docs/guide/serve.md, "serve.toml").

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use rom::{ModelFile, SurrogateFile};
use serde::Deserialize;

use crate::gap_check::{DueRule, GapSettings};
use crate::MqttSettings;

/// Most threads a gap check's pool may have.
pub const MAX_GAP_THREADS: usize = 256;

/// One `[[drive]]` of `serve.toml`: the drive's id (its MQTT topic's drive id, or a replayed
/// data set's label) and its model; paths relative to `serve.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveEntry {
    pub id: String,
    /// Drive configuration (TOML) the surrogate was trained on. [default: the model's own]
    #[serde(default)]
    pub config: Option<PathBuf>,
    /// Surrogate file. [default: the shipped one]
    #[serde(default)]
    pub model: Option<PathBuf>,
}

/// The whole `serve.toml`.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServeConfig {
    /// Days of segments, diagnoses and alarms kept in the database. [default: keep all]
    #[serde(default)]
    pub retention_days: Option<f64>,
    #[serde(default)]
    pub drive: Vec<DriveEntry>,
    #[serde(default)]
    pub mqtt: Option<MqttSettings>,
    /// A background gap check after this many new segments of a drive; 0: never on this
    /// count. [default: 50]
    #[serde(default)]
    pub gap_every_segments: Option<u64>,
    /// A gap check when this many of a drive's latest `gap_misfit_window` segments carry
    /// misfit flags; 0: never on misfits. [default: 3]
    #[serde(default)]
    pub gap_misfit_segments: Option<usize>,
    /// Segments the misfit count looks back over. [default: 10]
    #[serde(default)]
    pub gap_misfit_window: Option<usize>,
    /// Threads of the gap checks' own pool. [default: 1]
    #[serde(default)]
    pub gap_threads: Option<usize>,
    /// Folder where each gap check's data set is kept, to rerun `rom gap` on. [default: none]
    #[serde(default)]
    pub gap_keep_dir: Option<PathBuf>,
    /// Where the file was read from (relative paths in it are relative to its folder).
    #[serde(skip)]
    pub dir: PathBuf,
}

/// A drive's model: the surrogate, the drive configuration it is used with, and what named it.
pub struct DriveModel {
    /// The model file's path, or `shipped` for the embedded default.
    pub name: String,
    pub file: SurrogateFile,
    pub cfg: fom::ValidConfig,
    /// The surrogate's side of every segment's diagnosis, made once (`twin::diagnose::Prior`).
    pub prior: twin::diagnose::Prior,
}

/// What went wrong reading `serve.toml` or a model it names.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ConfigError {
    pub path: String,
    pub message: String,
}

impl ServeConfig {
    /// Reads and checks `serve.toml` at `path`.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let err = |message: String| ConfigError {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let mut c: ServeConfig =
            toml::from_str(&text).map_err(|e| err(e.to_string().trim().to_string()))?;
        if let Some(r) = c.retention_days {
            if !(r.is_finite() && r > 0.0) {
                return Err(err(format!(
                    "`retention_days` must be a positive number of days, got {r}"
                )));
            }
        }
        let g = c.gap_settings();
        if g.rule.misfit_window == 0 || g.rule.misfit_segments > g.rule.misfit_window {
            return Err(err(format!(
                "`gap_misfit_segments` = {} must be at most `gap_misfit_window` = {}, which \
                 must be at least 1",
                g.rule.misfit_segments, g.rule.misfit_window
            )));
        }
        if !(1..=MAX_GAP_THREADS).contains(&g.threads) {
            return Err(err(format!(
                "`gap_threads` = {} must lie in 1..={MAX_GAP_THREADS}",
                g.threads
            )));
        }
        for (i, d) in c.drive.iter().enumerate() {
            if d.id.trim().is_empty() || d.id.contains('/') {
                return Err(err(format!(
                    "drive {}: `id` = {:?} must be non-empty, without `/`",
                    i + 1,
                    d.id
                )));
            }
            if c.drive[..i].iter().any(|o| o.id == d.id) {
                return Err(err(format!(
                    "drive {}: `id` = {:?} appears twice; each drive is listed once",
                    i + 1,
                    d.id
                )));
            }
        }
        c.dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(c)
    }

    /// The gap checks' settings: the keys given, defaults for the others; `gap_keep_dir`
    /// relative to the file's folder.
    pub fn gap_settings(&self) -> GapSettings {
        let d = GapSettings::default();
        GapSettings {
            rule: DueRule {
                every_segments: self.gap_every_segments.unwrap_or(d.rule.every_segments),
                misfit_segments: self.gap_misfit_segments.unwrap_or(d.rule.misfit_segments),
                misfit_window: self.gap_misfit_window.unwrap_or(d.rule.misfit_window),
            },
            threads: self.gap_threads.unwrap_or(d.threads),
            keep_dir: self.gap_keep_dir.as_ref().map(|p| self.dir.join(p)),
        }
    }

    /// Loads every drive's model once (drives naming the same files share one), and the
    /// shipped default for drives not listed.
    pub fn models(&self) -> Result<Models, Box<dyn std::error::Error>> {
        let mut by_files: BTreeMap<(Option<PathBuf>, Option<PathBuf>), Arc<DriveModel>> =
            BTreeMap::new();
        let mut per_drive = BTreeMap::new();
        for d in &self.drive {
            let model = d.model.as_ref().map(|p| self.dir.join(p));
            let config = d.config.as_ref().map(|p| self.dir.join(p));
            let key = (model.clone(), config.clone());
            let m = match by_files.get(&key) {
                Some(m) => m.clone(),
                None => {
                    let m = Arc::new(
                        load(model.as_deref(), config.as_deref())
                            .map_err(|e| format!("drive {:?}: {e}", d.id))?,
                    );
                    by_files.insert(key, m.clone());
                    m
                }
            };
            per_drive.insert(d.id.clone(), m);
        }
        let default = match by_files.get(&(None, None)) {
            Some(m) => m.clone(),
            None => Arc::new(load(None, None)?),
        };
        Ok(Models { per_drive, default })
    }
}

/// Each drive's model, and the one for drives `serve.toml` does not list.
pub struct Models {
    pub per_drive: BTreeMap<String, Arc<DriveModel>>,
    pub default: Arc<DriveModel>,
}

impl Models {
    /// The shipped model for every drive.
    pub fn shipped() -> Result<Self, Box<dyn std::error::Error>> {
        Ok(Models {
            per_drive: BTreeMap::new(),
            default: Arc::new(load(None, None)?),
        })
    }

    pub fn of(&self, drive: &str) -> Arc<DriveModel> {
        self.per_drive.get(drive).unwrap_or(&self.default).clone()
    }
}

/// A surrogate file (default: the shipped one, `rom::shipped`) and the configuration it is
/// used with (checked against the one it was trained on; default: its own).
pub fn load(
    model: Option<&Path>,
    config: Option<&Path>,
) -> Result<DriveModel, Box<dyn std::error::Error>> {
    let (name, file) = match model {
        Some(p) => (
            p.display().to_string(),
            ModelFile::load(p)?.into_slip(&p.display().to_string())?,
        ),
        None => ("shipped".to_string(), rom::shipped::slip_model()?),
    };
    let cfg = file.drive_config(config)?;
    let prior = twin::diagnose::Prior::new(&file.surrogate, &cfg)?;
    Ok(DriveModel {
        name,
        file,
        cfg,
        prior,
    })
}
