//! Measured speed recordings in the exchange format `belt-measurements/1`
//! (docs/measured-data.md): a directory with `manifest.toml` and one CSV per run.

use fom::slip::slip_pct;
use fom::stats::inverse_variance_mean;
use fom::steady::{is_running, max_driver_rpm};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

mod manifest;
pub use manifest::read_manifest;

/// The largest manifest read, bytes: far above any data set's (a few hundred bytes a run).
const MAX_MANIFEST_BYTES: u64 = 64 << 20;

/// The format string this version reads and writes.
pub const FORMAT: &str = "belt-measurements/1";
pub const MANIFEST: &str = "manifest.toml";

/// Bad input: the file, the line where there is one, and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredError {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for MeasuredError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}: line {l}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for MeasuredError {}

fn err(path: &Path, line: Option<usize>, message: impl Into<String>) -> MeasuredError {
    MeasuredError {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// One `[[run]]` of the manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct RunEntry {
    pub file: String,
    pub label: String,
    pub center_distance_m: Option<f64>,
    /// Every other key of the run table, kept as metadata.
    pub metadata: BTreeMap<String, toml::Value>,
}

/// The run key that gives the driven load's torque in steady running, N m (beltwin's own key,
/// kept as metadata by the exchange format; `docs/measured-data.md`, "Two load levels").
pub const LOAD_TORQUE_KEY: &str = "load_torque_nm";

/// The run key that gives the belt's static span tension at the run's setting, N, read on the
/// stopped drive by a tension meter (beltwin's own key; `docs/measured-data.md`, "A tension
/// reading").
pub const STATIC_TENSION_KEY: &str = "static_tension_n";

/// The run key that gives that reading's standard deviation, N (absent:
/// `TENSION_READING_SD_SHARE` of the reading).
pub const STATIC_TENSION_SD_KEY: &str = "static_tension_sd_n";

/// A tension reading's standard deviation where the data set gives none, as a share of the
/// reading: a field meter's reading of the span's frequency, its mass per length and span
/// length taken together (docs/decisions/tension-reading.md).
pub const TENSION_READING_SD_SHARE: f64 = 0.05;

/// A belt setting's static span tension as read by a tension meter, N, with its standard
/// deviation, N.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TensionReading {
    pub tension_n: f64,
    pub sd_n: f64,
}

impl RunEntry {
    /// A numeric metadata key's value, where the run gives it.
    fn number(&self, key: &str) -> Option<f64> {
        self.metadata
            .get(key)
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
    }

    /// The driven load's torque in steady running, N m, where the run gives it (`None`: the
    /// drive configuration's load). Checked positive and alike within a label when read.
    pub fn load_torque_nm(&self) -> Option<f64> {
        self.number(LOAD_TORQUE_KEY)
    }

    /// The belt's static span tension read at the run's setting, where the run gives it, with
    /// its standard deviation. Checked positive when read.
    pub fn tension_reading(&self) -> Option<TensionReading> {
        let tension_n = self.number(STATIC_TENSION_KEY)?;
        Some(TensionReading {
            tension_n,
            sd_n: self
                .number(STATIC_TENSION_SD_KEY)
                .unwrap_or(TENSION_READING_SD_SHARE * tension_n),
        })
    }
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Manifest {
    pub description: Option<String>,
    pub driver_pulley_diameter_m: Option<f64>,
    pub driven_pulley_diameter_m: Option<f64>,
    pub runs: Vec<RunEntry>,
}

/// One recording: time (s) and both speeds (rpm).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    pub time_s: Vec<f64>,
    pub driver_rpm: Vec<f64>,
    pub driven_rpm: Vec<f64>,
}

impl Recording {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Slip per sample, paper eq. (1): 100 (1 - R_t n_driven / n_driver), of the running
    /// samples only (`fom::steady::is_running`, docs/decisions/running-sample.md).
    pub fn slip_samples(&self, ratio: f64) -> Vec<(f64, f64)> {
        let max = max_driver_rpm(&self.driver_rpm);
        (0..self.len())
            .filter(|&i| is_running(self.driver_rpm[i], max))
            .map(|i| {
                (
                    self.time_s[i],
                    slip_pct(ratio, self.driver_rpm[i], self.driven_rpm[i]),
                )
            })
            .collect()
    }
}

/// A data set read from disk.
#[derive(Debug, Clone, PartialEq)]
pub struct DataSet {
    pub dir: PathBuf,
    pub manifest: Manifest,
    pub recordings: Vec<Recording>,
}

impl DataSet {
    /// R_t of paper eq. (1): driven / driver pitch diameter, each from the manifest where it
    /// gives one (the exchange format: "where present they override the twin's defaults"),
    /// else the drive configuration's.
    pub fn speed_ratio(&self, cfg: &fom::DriveConfig) -> f64 {
        fom::slip::transmission_ratio(
            self.manifest
                .driver_pulley_diameter_m
                .unwrap_or(cfg.driver.pitch_diameter_m),
            self.manifest
                .driven_pulley_diameter_m
                .unwrap_or(cfg.driven.pitch_diameter_m),
        )
    }

    /// The known centre distance of `label`, m: its first run's (`None` when that run gives
    /// none). One definition for the calibration's targets and `rom gap`'s usable labels.
    pub fn known_center_distance_m(&self, label: &str) -> Option<f64> {
        self.manifest
            .runs
            .iter()
            .find(|r| r.label == label)
            .and_then(|r| r.center_distance_m)
    }

    /// `label`'s first run (its per-condition keys are every run's of it: the reader checks).
    fn first_run_of(&self, label: &str) -> Option<&RunEntry> {
        self.manifest.runs.iter().find(|r| r.label == label)
    }

    /// The driven load's torque of `label`'s runs in steady running, N m (`None`: the drive
    /// configuration's load). The reader checks that runs of one label agree.
    pub fn load_torque_nm(&self, label: &str) -> Option<f64> {
        self.first_run_of(label).and_then(RunEntry::load_torque_nm)
    }

    /// The static span tension read at `label`'s setting (`None`: not read): the readings of
    /// its runs (a meter read again before each run) weighted by their inverse variances, as
    /// independent readings of one tension.
    pub fn tension_reading(&self, label: &str) -> Option<TensionReading> {
        let readings = self
            .manifest
            .runs
            .iter()
            .filter(|r| r.label == label)
            .filter_map(RunEntry::tension_reading);
        let (tension_n, sd_n) = inverse_variance_mean(readings.map(|r| [r.tension_n, r.sd_n]))?;
        Some(TensionReading { tension_n, sd_n })
    }

    /// Each label with its load (`None`: the drive configuration's), in the data set's order.
    fn label_loads(&self) -> Vec<(String, Option<f64>)> {
        self.labels()
            .into_iter()
            .map(|l| {
                let t = self.load_torque_nm(&l);
                (l, t)
            })
            .collect()
    }

    /// The reference load, N m: the drive configuration's (`None`) where a label gives no
    /// load, since the surrogate runs at it; else the one most labels give (on a tie the first
    /// label's). The twin's calibration and diagnoses read the labels at it
    /// (docs/decisions/gap-load-levels.md).
    pub fn reference_load_torque_nm(&self) -> Option<f64> {
        let loads = self.label_loads();
        if loads.iter().any(|(_, t)| t.is_none()) {
            return None;
        }
        let count = |t: Option<f64>| loads.iter().filter(|(_, u)| same_load(t, *u)).count();
        let most = loads.iter().map(|(_, t)| count(*t)).max().unwrap_or(0);
        loads
            .iter()
            .map(|(_, t)| *t)
            .find(|t| count(*t) == most)
            .flatten()
    }

    /// The labels at another load than the reference one, in the data set's order.
    pub fn other_load_labels(&self) -> Vec<String> {
        let reference = self.reference_load_torque_nm();
        self.label_loads()
            .into_iter()
            .filter(|(_, t)| !same_load(*t, reference))
            .map(|(l, _)| l)
            .collect()
    }

    /// The data set without its labels at another load than the reference one, and those
    /// labels; `None` when every label is at one load.
    pub fn split_by_load(&self) -> Option<(DataSet, Vec<String>)> {
        let others = self.other_load_labels();
        if others.is_empty() {
            return None;
        }
        let keep: Vec<usize> = (0..self.manifest.runs.len())
            .filter(|&i| !others.contains(&self.manifest.runs[i].label))
            .collect();
        let mut main = self.clone();
        main.manifest.runs = keep
            .iter()
            .map(|&i| self.manifest.runs[i].clone())
            .collect();
        main.recordings = keep.iter().map(|&i| self.recordings[i].clone()).collect();
        Some((main, others))
    }

    /// The data set at its reference load: itself, or without its labels at another load
    /// (`split_by_load`); what a command reading one load (the surrogate's) works on.
    pub fn at_reference_load(&self) -> std::borrow::Cow<'_, DataSet> {
        match self.split_by_load() {
            Some((main, _)) => std::borrow::Cow::Owned(main),
            None => std::borrow::Cow::Borrowed(self),
        }
    }

    /// Indices of the runs carrying `label`, in manifest order.
    pub fn runs_of(&self, label: &str) -> Vec<usize> {
        (0..self.manifest.runs.len())
            .filter(|&i| self.manifest.runs[i].label == label)
            .collect()
    }

    /// The runs carrying `label`, in manifest order: each file's name and recording.
    pub fn recordings_of(&self, label: &str) -> Vec<(&str, &Recording)> {
        self.runs_of(label)
            .into_iter()
            .map(|i| (self.manifest.runs[i].file.as_str(), &self.recordings[i]))
            .collect()
    }

    /// The labels in order of first appearance.
    pub fn labels(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for r in &self.manifest.runs {
            if !out.contains(&r.label) {
                out.push(r.label.clone());
            }
        }
        out
    }
}

/// Loads that differ by less than this share are one load.
const SAME_LOAD_SHARE: f64 = 1.0e-6;

/// Whether two labels' loads (`None`: the drive configuration's) are one load.
fn same_load(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(x), Some(y)) => (x - y).abs() <= SAME_LOAD_SHARE * x.abs().max(y.abs()),
        _ => false,
    }
}

/// `text` as shown in a message: whole when short, else its start and its length.
fn shown(text: &str) -> String {
    const MAX_CHARS: usize = 24;
    let n = text.chars().count();
    if n <= MAX_CHARS {
        text.to_string()
    } else {
        let head: String = text.chars().take(MAX_CHARS).collect();
        format!("{head}... ({n} characters)")
    }
}

fn field(path: &Path, line: usize, col: &str, text: &str) -> Result<f64, MeasuredError> {
    let text = text.trim();
    let v: f64 = text.parse().map_err(|_| {
        err(
            path,
            Some(line),
            format!("column `{col}`: `{}` is not a number", shown(text)),
        )
    })?;
    if !v.is_finite() {
        let why = if v.is_nan() || text.to_ascii_lowercase().contains("inf") {
            "is not a finite number"
        } else {
            "is too large for a number (beyond 1.8e308)"
        };
        return Err(err(
            path,
            Some(line),
            format!("column `{col}`: `{}` {why}", shown(text)),
        ));
    }
    Ok(v)
}

/// Reads one run CSV; `min_samples` is what the calling command needs.
/// A regular file only (a FIFO would block the reader, a device never end); no containment
/// check: [`read_dataset`] keeps a data set's files inside its folder.
pub fn read_recording(path: &Path, min_samples: usize) -> Result<Recording, MeasuredError> {
    let file = crate::data_files::open_regular(path)
        .map_err(|e| err(path, None, e.message(MISSING_RUN_FILE)))?;
    recording_from(file, path, min_samples)
}

const MISSING_RUN_FILE: &str = "missing run file (named in manifest.toml)";

/// Reads one run CSV from the opened `file` (at `path`, for messages).
fn recording_from(
    file: std::fs::File,
    path: &Path,
    min_samples: usize,
) -> Result<Recording, MeasuredError> {
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .flexible(false)
        .trim(csv::Trim::All)
        .from_reader(file);
    let headers = rd
        .headers()
        .map_err(|e| err(path, None, format!("cannot read the header row: {e}")))?
        .clone();
    let cols = ["time_s", "driver_rpm", "driven_rpm"];
    if headers.iter().all(|h| h.is_empty()) {
        return Err(err(
            path,
            None,
            format!(
                "no header row: the file is empty or blank (need the columns {})",
                cols.join(", ")
            ),
        ));
    }
    // The reader stands at the line after the header (the header record's own position is
    // that of the comment lines before it).
    let header_line = Some((rd.position().line() as usize).saturating_sub(1)).filter(|&l| l > 0);
    for (k, h) in headers.iter().enumerate() {
        if !h.is_empty() && headers.iter().skip(k + 1).any(|o| o == h) {
            return Err(err(
                path,
                header_line,
                format!("column `{h}` appears twice in the header; each column is named once"),
            ));
        }
    }
    let mut idx = [0usize; 3];
    for (k, c) in cols.iter().enumerate() {
        idx[k] = headers.iter().position(|h| h == *c).ok_or_else(|| {
            err(
                path,
                None,
                format!(
                    "missing required column `{c}` (header has: {})",
                    headers.iter().collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
    }
    let mut rec = Recording::default();
    for r in rd.records() {
        let r = r.map_err(|e| {
            let line = e.position().map(|p| p.line() as usize);
            err(path, line, format!("malformed row: {e}"))
        })?;
        let line = r.position().map_or(0, |p| p.line() as usize);
        let t = field(path, line, cols[0], &r[idx[0]])?;
        let n1 = field(path, line, cols[1], &r[idx[1]])?;
        let n2 = field(path, line, cols[2], &r[idx[2]])?;
        if let Some(&prev) = rec.time_s.last() {
            if t <= prev {
                return Err(err(
                    path,
                    Some(line),
                    format!("time_s {t} is not after the previous sample's {prev} (must be strictly increasing)"),
                ));
            }
        }
        for (c, v) in [(cols[1], n1), (cols[2], n2)] {
            if v < 0.0 {
                return Err(err(
                    path,
                    Some(line),
                    format!("column `{c}`: negative speed {v}"),
                ));
            }
        }
        rec.time_s.push(t);
        rec.driver_rpm.push(n1);
        rec.driven_rpm.push(n2);
    }
    if rec.len() < min_samples {
        return Err(err(
            path,
            None,
            format!(
                "{} samples; this command needs at least {min_samples}",
                rec.len()
            ),
        ));
    }
    Ok(rec)
}

/// Reads a whole data set; every run needs at least `min_samples` samples.
pub fn read_dataset(dir: &Path, min_samples: usize) -> Result<DataSet, MeasuredError> {
    let manifest = read_manifest(dir)?;
    let recordings = manifest
        .runs
        .iter()
        .map(|r| {
            let path = dir.join(&r.file);
            let file = crate::data_files::read_inside(dir, Path::new(&r.file))
                .map_err(|e| err(&path, None, e.message(MISSING_RUN_FILE)))?;
            recording_from(file, &path, min_samples)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(DataSet {
        dir: dir.to_path_buf(),
        manifest,
        recordings,
    })
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// Writes a manifest (atomically).
pub fn write_manifest(dir: &Path, m: &Manifest) -> Result<(), fom::FomError> {
    let mut t = format!("format = \"{FORMAT}\"\n");
    if let Some(d) = &m.description {
        t += &format!("description = {}\n", toml_string(d));
    }
    if let Some(d) = m.driver_pulley_diameter_m {
        t += &format!("driver_pulley_diameter_m = {d:?}\n");
    }
    if let Some(d) = m.driven_pulley_diameter_m {
        t += &format!("driven_pulley_diameter_m = {d:?}\n");
    }
    for r in &m.runs {
        t += &format!(
            "\n[[run]]\nfile = {}\nlabel = {}\n",
            toml_string(&r.file),
            toml_string(&r.label)
        );
        if let Some(d) = r.center_distance_m {
            t += &format!("center_distance_m = {d:?}\n");
        }
        for (k, v) in &r.metadata {
            let bare = !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
            let key = if bare { k.clone() } else { toml_string(k) };
            t += &format!("{key} = {v}\n");
        }
    }
    fom::output::write_atomic(&dir.join(MANIFEST), |w| w.write_all(t.as_bytes()))
}

/// Writes a recording as CSV (atomically).
pub fn write_recording(path: &Path, rec: &Recording, comment: &str) -> Result<(), fom::FomError> {
    fom::output::write_atomic(path, |w| {
        for line in comment.lines() {
            writeln!(w, "# {line}")?;
        }
        writeln!(w, "time_s,driver_rpm,driven_rpm")?;
        for i in 0..rec.len() {
            writeln!(
                w,
                "{:.6},{:.3},{:.3}",
                rec.time_s[i], rec.driver_rpm[i], rec.driven_rpm[i]
            )?;
        }
        Ok(())
    })
}

/// Adds a run to the data set in `dir` (created if needed): the CSV first, then the manifest,
/// so a manifest never names a missing file. Refuses to overwrite an existing run file.
pub fn append_run(
    dir: &Path,
    entry: RunEntry,
    rec: &Recording,
    comment: &str,
    diameters_m: (f64, f64),
) -> crate::Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| crate::TwinError::Io {
        context: format!("creating {}", dir.display()),
        source,
    })?;
    let mut m = if dir.join(MANIFEST).exists() {
        read_manifest(dir)?
    } else {
        Manifest {
            description: Some("synthetic measurements written by beltwin".into()),
            driver_pulley_diameter_m: Some(diameters_m.0),
            driven_pulley_diameter_m: Some(diameters_m.1),
            runs: Vec::new(),
        }
    };
    if m.runs.iter().any(|r| r.file == entry.file) || dir.join(&entry.file).exists() {
        return Err(crate::TwinError::Unusable(format!(
            "{} already holds a run file {}; choose another label or directory",
            dir.display(),
            entry.file
        )));
    }
    write_recording(&dir.join(&entry.file), rec, comment)?;
    m.runs.push(entry);
    write_manifest(dir, &m)?;
    Ok(())
}
