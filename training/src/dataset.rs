//! The training data set on disk.
//!
//! ```text
//! DIR/
//!   campaign.toml          settings, configuration hash, crate version
//!   drive.toml             the full-order configuration every run starts from
//!   design.csv             index,center_distance_m,friction,installation_tension_n
//!   runs/point-0007.csv    time series of point 7 (columns of `rom simulate`)
//!   runs/point-0007.toml   its status: ok or failed (with the error), wall time, mean slip
//!   points.csv             the design with status, wall time, mean slip and error per point
//!                          (written when every point has finished: by an unsharded run or by
//!                          the merge step)
//! ```
//! Every file is written atomically; a point's status file is written after its time series,
//! so a point with a status file is finished and a resumed campaign skips it.

use std::path::{Path, PathBuf};

use fom::output::write_atomic;
use fom::DriveConfig;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::settings::CampaignSettings;
use crate::TrainingError;
use fom::params::Variable;
use fom::DesignPoint;

pub const CAMPAIGN_FILE: &str = "campaign.toml";
pub const DRIVE_FILE: &str = "drive.toml";
pub const DESIGN_FILE: &str = "design.csv";
pub const POINTS_FILE: &str = "points.csv";
pub const RUNS_DIR: &str = "runs";
/// The design variables written in a data set's files: the three that every design has,
/// and each optional one (stiffness) that any point sets.
fn design_variables<'a>(points: impl Iterator<Item = &'a DesignPoint> + Clone) -> Vec<Variable> {
    Variable::ALL
        .into_iter()
        .filter(|v| points.clone().any(|p| p.get(*v).is_some()))
        .collect()
}

/// Header cells `index` and the variables' keys.
fn design_header(vars: &[Variable]) -> Vec<&'static str> {
    std::iter::once("index")
        .chain(vars.iter().map(|v| v.key()))
        .collect()
}

/// A point's cells for `vars` (`{}` prints the shortest text that reads back to the same f64).
fn design_cells(p: &DesignPoint, vars: &[Variable]) -> Vec<String> {
    vars.iter()
        .map(|v| p.get(*v).map_or(String::new(), |x| x.to_string()))
        .collect()
}

/// SHA-256 (hex) of a configuration's canonical TOML text: what a surrogate was trained on.
pub fn config_hash(cfg: &DriveConfig) -> String {
    hex(&Sha256::digest(cfg.to_toml_string().as_bytes()))
}

/// Lower-case hex of bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The header file of a campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignHeader {
    pub format: String,
    pub crate_version: String,
    pub config_sha256: String,
    pub settings: CampaignSettings,
}

pub const CAMPAIGN_FORMAT: &str = "beltwin-campaign/2";

/// Outcome of one design point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointStatus {
    /// `ok` (settled, energy balance closed), `unsettled` (not settled within the longest
    /// run), `unbalanced` (settled, energy balance off: `fom::output::Unusable`) or `failed`.
    pub status: String,
    pub wall_time_s: f64,
    /// Simulated time, s, for a run that finished.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulated_s: Option<f64>,
    /// Start of the steady window (`fom::steady`), s, for a settled run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady_start_s: Option<f64>,
    /// Mean steady-window slip, %, for a finished run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_slip_pct: Option<f64>,
    /// Energy-balance residual over the steady (or last) window, %, for a finished run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy_residual_pct: Option<f64>,
    /// Why a run is not `ok`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Largest instantaneous flank load of a toothed run, N (`fom::belt_kind::tooth_record::ToothRecord`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_tooth_load_n: Option<f64>,
}

impl PointStatus {
    pub fn is_ok(&self) -> bool {
        self.status == "ok"
    }
}

/// One row of a run's time series as the surrogate needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesRow {
    pub time_s: f64,
    pub driver_rpm: f64,
    pub driven_rpm: f64,
    /// NaN where the driver is at standstill.
    pub slip_pct: f64,
}

/// A design point with its outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct PointRecord {
    pub index: usize,
    pub point: DesignPoint,
    pub status: PointStatus,
}

/// A complete (merged) training data set.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub dir: PathBuf,
    pub header: CampaignHeader,
    pub config: fom::ValidConfig,
    pub points: Vec<PointRecord>,
}

pub fn run_csv_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(RUNS_DIR).join(format!("point-{index:04}.csv"))
}

pub fn status_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(RUNS_DIR).join(format!("point-{index:04}.toml"))
}

/// A toothed run's tooth-root load peaks, one per tooth pass in the tooth-load window
/// (`fom::belt_kind::tooth_record::tooth_load_window_start_s`), column `peak_n`.
pub fn tooth_peaks_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(RUNS_DIR)
        .join(format!("point-{index:04}-teeth.csv"))
}

/// Column of a tooth-peaks file.
const TOOTH_PEAK_COLUMN: &str = "peak_n";

/// Writes a toothed run's pass peaks, N.
pub fn write_tooth_peaks(path: &Path, peaks_n: &[f64]) -> Result<(), TrainingError> {
    write_atomic(path, |w| {
        writeln!(w, "{TOOTH_PEAK_COLUMN}")?;
        for p in peaks_n {
            writeln!(w, "{p:.6}")?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Reads a toothed run's pass peaks, N (each finite and non-negative).
pub fn read_tooth_peaks(path: &Path) -> Result<Vec<f64>, TrainingError> {
    let (mut rd, idx) = open_csv(path, &[TOOTH_PEAK_COLUMN])?;
    let mut out = Vec::new();
    for (k, rec) in rd.records().enumerate() {
        let line = k + 2;
        let rec = rec.map_err(|e| data_err(path, format!("line {line}: {e}")))?;
        let v = parse_f64(path, line, TOOTH_PEAK_COLUMN, &rec[idx[0]])?;
        if v < 0.0 {
            return Err(data_err(
                path,
                format!("line {line}: {TOOTH_PEAK_COLUMN} = {v} is negative"),
            ));
        }
        out.push(v);
    }
    Ok(out)
}

fn io(context: String) -> impl FnOnce(std::io::Error) -> TrainingError {
    move |source| TrainingError::Io { context, source }
}

fn data_err(path: &Path, message: impl Into<String>) -> TrainingError {
    TrainingError::Data {
        path: path.display().to_string(),
        message: message.into(),
    }
}

pub fn write_text(path: &Path, text: &str) -> Result<(), TrainingError> {
    write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

pub fn read_text(path: &Path) -> Result<String, TrainingError> {
    std::fs::read_to_string(path).map_err(io(format!("reading {}", path.display())))
}

pub fn write_design(path: &Path, design: &[DesignPoint]) -> Result<(), TrainingError> {
    let vars = design_variables(design.iter());
    let mut text = design_header(&vars).join(",") + "\n";
    for (i, p) in design.iter().enumerate() {
        text += &format!("{i},{}\n", design_cells(p, &vars).join(","));
    }
    write_text(path, &text)
}

fn parse_f64(path: &Path, line: usize, col: &str, field: &str) -> Result<f64, TrainingError> {
    field
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            data_err(
                path,
                format!("line {line}: column {col}: `{field}` is not a finite number"),
            )
        })
}

/// Opens a CSV file and returns the reader and the index of each wanted column.
fn open_csv(
    path: &Path,
    wanted: &[&str],
) -> Result<(csv::Reader<std::fs::File>, Vec<usize>), TrainingError> {
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .map_err(|e| data_err(path, e.to_string()))?;
    let headers = rd
        .headers()
        .map_err(|e| data_err(path, e.to_string()))?
        .clone();
    let idx = wanted
        .iter()
        .map(|w| {
            headers
                .iter()
                .position(|h| h.trim() == *w)
                .ok_or_else(|| data_err(path, format!("missing column `{w}`")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((rd, idx))
}

pub fn read_design(path: &Path) -> Result<Vec<DesignPoint>, TrainingError> {
    // The three variables every design has are required; an optional one is read when present.
    let required = &Variable::ALL[..3];
    let (mut rd, idx) = open_csv(path, &design_header(required))?;
    let headers = rd
        .headers()
        .map_err(|e| data_err(path, e.to_string()))?
        .clone();
    let optional: Vec<(Variable, usize)> = Variable::ALL[3..]
        .iter()
        .filter_map(|v| {
            headers
                .iter()
                .position(|h| h.trim() == v.key())
                .map(|c| (*v, c))
        })
        .collect();
    let mut out = Vec::new();
    for (k, rec) in rd.records().enumerate() {
        let line = k + 2;
        let rec = rec.map_err(|e| data_err(path, format!("line {line}: {e}")))?;
        if parse_f64(path, line, "index", &rec[idx[0]])? as usize != k {
            return Err(data_err(path, format!("line {line}: index is not {k}")));
        }
        let mut p = DesignPoint::from_columns(&[], &[]);
        for (v, c) in required.iter().zip(&idx[1..]) {
            p.set(*v, parse_f64(path, line, v.key(), &rec[*c])?);
        }
        for (v, c) in &optional {
            p.set(*v, parse_f64(path, line, v.key(), &rec[*c])?);
        }
        out.push(p);
    }
    Ok(out)
}

/// Reads time, speeds and slip of a run CSV written by the full-order model.
pub fn read_series(path: &Path) -> Result<Vec<SeriesRow>, TrainingError> {
    let (mut rd, idx) = open_csv(path, &["time_s", "slip_pct", "driver_rpm", "driven_rpm"])?;
    let mut out = Vec::new();
    for (k, rec) in rd.records().enumerate() {
        let line = k + 2;
        let rec = rec.map_err(|e| data_err(path, format!("line {line}: {e}")))?;
        let time_s = parse_f64(path, line, "time_s", &rec[idx[0]])?;
        let slip = rec[idx[1]].trim();
        let slip_pct = if slip.is_empty() {
            f64::NAN
        } else {
            parse_f64(path, line, "slip_pct", slip)?
        };
        out.push(SeriesRow {
            time_s,
            driver_rpm: parse_f64(path, line, "driver_rpm", &rec[idx[2]])?,
            driven_rpm: parse_f64(path, line, "driven_rpm", &rec[idx[3]])?,
            slip_pct,
        });
    }
    Ok(out)
}

pub fn read_status(path: &Path) -> Result<PointStatus, TrainingError> {
    let text = read_text(path)?;
    toml::from_str(&text).map_err(|e| data_err(path, e.to_string().trim().to_string()))
}

pub fn write_status(path: &Path, status: &PointStatus) -> Result<(), TrainingError> {
    write_text(path, &toml::to_string(status).expect("status serialises"))
}

/// Writes `points.csv`: the design with each point's outcome.
pub fn write_points(path: &Path, records: &[PointRecord]) -> Result<(), TrainingError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let io_csv = |e: csv::Error| data_err(path, e.to_string());
    let vars = design_variables(records.iter().map(|r| &r.point));
    let mut head = design_header(&vars);
    head.extend([
        "status",
        "wall_time_s",
        "simulated_s",
        "steady_start_s",
        "mean_slip_pct",
        "energy_residual_pct",
        "error",
    ]);
    // A toothed campaign's runs also give their largest tooth load.
    let toothed = records.iter().any(|r| r.status.max_tooth_load_n.is_some());
    if toothed {
        head.push("max_tooth_load_n");
    }
    w.write_record(&head).map_err(io_csv)?;
    for r in records {
        let mut row = vec![r.index.to_string()];
        row.extend(design_cells(&r.point, &vars));
        row.extend([
            r.status.status.clone(),
            format!("{:.3}", r.status.wall_time_s),
            r.status
                .simulated_s
                .map_or(String::new(), |s| format!("{s:.3}")),
            r.status
                .steady_start_s
                .map_or(String::new(), |s| format!("{s:.4}")),
            r.status
                .mean_slip_pct
                .map_or(String::new(), |s| format!("{s:.6}")),
            r.status
                .energy_residual_pct
                .map_or(String::new(), |s| format!("{s:.3}")),
            r.status.error.clone().unwrap_or_default(),
        ]);
        if toothed {
            row.push(
                r.status
                    .max_tooth_load_n
                    .map_or(String::new(), |v| format!("{v:.4}")),
            );
        }
        w.write_record(&row).map_err(io_csv)?;
    }
    let bytes = w.into_inner().map_err(|e| data_err(path, e.to_string()))?;
    write_atomic(path, |out| out.write_all(&bytes))?;
    Ok(())
}

pub fn read_header(dir: &Path) -> Result<CampaignHeader, TrainingError> {
    let path = dir.join(CAMPAIGN_FILE);
    if !path.exists() {
        return Err(data_err(
            &path,
            "no training campaign here (missing campaign.toml); run a campaign into this directory first",
        ));
    }
    let header: CampaignHeader = toml::from_str(&read_text(&path)?)
        .map_err(|e| data_err(&path, e.to_string().trim().to_string()))?;
    if header.format != CAMPAIGN_FORMAT {
        return Err(data_err(
            &path,
            format!("format `{}` is not `{CAMPAIGN_FORMAT}`", header.format),
        ));
    }
    Ok(header)
}

impl Dataset {
    /// Loads a complete data set (after the campaign or the merge step wrote `points.csv`).
    pub fn load(dir: &Path) -> Result<Self, TrainingError> {
        let header = read_header(dir)?;
        let drive_path = dir.join(DRIVE_FILE);
        let config = DriveConfig::from_toml_str(
            &read_text(&drive_path)?,
            &drive_path.display().to_string(),
        )?;
        if config_hash(&config) != header.config_sha256 {
            return Err(data_err(
                &drive_path,
                "does not match the configuration hash in campaign.toml (edited after training?)",
            ));
        }
        let design = read_design(&dir.join(DESIGN_FILE))?;
        // The Latin hypercube's points, then any refinement rounds (`campaign::add_points`).
        if design.len() < header.settings.samples {
            return Err(data_err(
                &dir.join(DESIGN_FILE),
                format!(
                    "{} points, campaign.toml says {} (plus refinements)",
                    design.len(),
                    header.settings.samples
                ),
            ));
        }
        let points_path = dir.join(POINTS_FILE);
        if !points_path.exists() {
            return Err(TrainingError::Incomplete(format!(
                "{} has no points.csv: the campaign has not finished (a sharded campaign \
                 needs its shards merged)",
                dir.display()
            )));
        }
        let mut points = Vec::with_capacity(design.len());
        for (index, point) in design.into_iter().enumerate() {
            let status = read_status(&status_path(dir, index))?;
            points.push(PointRecord {
                index,
                point,
                status,
            });
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            header,
            config,
            points,
        })
    }

    /// The tooth-root load peaks of one finished point of a toothed campaign, N.
    pub fn tooth_peaks(&self, index: usize) -> Result<Vec<f64>, TrainingError> {
        read_tooth_peaks(&tooth_peaks_path(&self.dir, index))
    }

    /// The time series of one finished point.
    pub fn series(&self, index: usize) -> Result<Vec<SeriesRow>, TrainingError> {
        read_series(&run_csv_path(&self.dir, index))
    }
}
