//! The manifest of a measured data set: `manifest.toml`'s header and `[[run]]` tables, read
//! and checked (docs/measured-data.md).

use super::{
    err, Manifest, MeasuredError, RunEntry, FORMAT, LOAD_TORQUE_KEY, MANIFEST, MAX_MANIFEST_BYTES,
    STATIC_TENSION_KEY, STATIC_TENSION_SD_KEY,
};
use std::collections::BTreeMap;
use std::path::Path;

/// A run table's error with the run's number in front of its message.
fn in_run<T>(n: usize, r: Result<T, MeasuredError>) -> Result<T, MeasuredError> {
    r.map_err(|e| MeasuredError {
        message: format!("run {n}: {}", e.message),
        ..e
    })
}

fn positive(path: &Path, key: &str, v: &toml::Value) -> Result<f64, MeasuredError> {
    let x = v
        .as_float()
        .or_else(|| v.as_integer().map(|i| i as f64))
        .ok_or_else(|| err(path, None, format!("`{key}` must be a number, got {v}")))?;
    if !(x.is_finite() && x > 0.0) {
        return Err(err(
            path,
            None,
            format!("`{key}` must be positive, got {x}"),
        ));
    }
    Ok(x)
}

/// The data set's own path: a mistyped folder, or a recording passed in its place. Any other
/// failure to read it is the manifest reader's to name.
fn check_data_set_dir(dir: &Path) -> Result<(), MeasuredError> {
    match std::fs::metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(err(
            dir,
            None,
            "no such directory (a measured data set is a directory with manifest.toml)",
        )),
        Ok(m) if !m.is_dir() => Err(err(
            dir,
            None,
            "is a file, not a directory: give the data set's directory, the one holding \
             manifest.toml and the recordings",
        )),
        _ => Ok(()),
    }
}

/// Reads and checks `manifest.toml` in `dir`.
pub fn read_manifest(dir: &Path) -> Result<Manifest, MeasuredError> {
    check_data_set_dir(dir)?;
    let path = dir.join(MANIFEST);
    let text = crate::data_files::read_inside(dir, Path::new(MANIFEST))
        .and_then(|f| crate::data_files::read_text(f, MAX_MANIFEST_BYTES))
        .map_err(|e| {
            err(
                &path,
                None,
                e.message(
                    "missing manifest (a measured data set is a directory with manifest.toml)",
                ),
            )
        })?;
    let table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| err(&path, None, e.to_string().trim().to_string()))?;
    match table.get("format") {
        Some(toml::Value::String(f)) if f == FORMAT => {}
        Some(v) => {
            return Err(err(
                &path,
                None,
                format!("unknown format {v}; this version reads \"{FORMAT}\""),
            ))
        }
        None => {
            return Err(err(
                &path,
                None,
                format!("missing `format` (must be \"{FORMAT}\")"),
            ))
        }
    }
    let mut m = Manifest {
        description: table
            .get("description")
            .and_then(|v| v.as_str())
            .map(str::to_string),
        ..Manifest::default()
    };
    for key in ["driver_pulley_diameter_m", "driven_pulley_diameter_m"] {
        if let Some(v) = table.get(key) {
            let x = positive(&path, key, v)?;
            if key.starts_with("driver") {
                m.driver_pulley_diameter_m = Some(x);
            } else {
                m.driven_pulley_diameter_m = Some(x);
            }
        }
    }
    let runs = match table.get("run") {
        Some(toml::Value::Array(a)) => a,
        Some(_) => {
            return Err(err(
                &path,
                None,
                "`run` must be an array of tables ([[run]])",
            ))
        }
        None => return Err(err(&path, None, "no runs (add [[run]] tables)")),
    };
    if runs.is_empty() {
        return Err(err(
            &path,
            None,
            "no runs: `run` is empty (add [[run]] tables)",
        ));
    }
    let spans = RunSpans::of(&text);
    for (i, r) in runs.iter().enumerate() {
        let run = read_run(&path, &spans, i, r, &m.runs)?;
        m.runs.push(run);
    }
    Ok(m)
}

/// Run `i` (`r`, its table) of the manifest at `path`, checked against the runs before it.
fn read_run(
    path: &Path,
    spans: &RunSpans,
    i: usize,
    r: &toml::Value,
    earlier: &[RunEntry],
) -> Result<RunEntry, MeasuredError> {
    let n = i + 1;
    let t = r
        .as_table()
        .ok_or_else(|| err(path, None, format!("run {n}: not a table")))?;
    let string = |key: &str| match t.get(key) {
        Some(toml::Value::String(s)) if !s.trim().is_empty() => Ok(s.clone()),
        Some(v) => Err(err(
            path,
            None,
            format!("run {n}: `{key}` must be a non-empty string, got {v}"),
        )),
        None => Err(err(path, None, format!("run {n}: missing `{key}`"))),
    };
    let file = string("file")?;
    // The exchange format: "path relative to the manifest". An absolute path or one that
    // climbs out of the data set's directory is refused before anything is read.
    let inside = std::path::Path::new(&file).components().all(|c| {
        matches!(
            c,
            std::path::Component::Normal(_) | std::path::Component::CurDir
        )
    });
    if !inside {
        return Err(err(
            path,
            None,
            format!(
                "run {n}: `file` = \"{file}\" must be a path relative to the manifest, \
                 inside the data set's directory (no absolute path, no `..`)"
            ),
        ));
    }
    if let Some(first) = earlier.iter().position(|r| same_file(&r.file, &file)) {
        return Err(err(
            path,
            spans.line(i, "file"),
            format!(
                "run {n}: `file` = \"{file}\" is already run {}'s; each run file is listed \
                 once",
                first + 1
            ),
        ));
    }
    let label = string("label")?;
    if label.chars().any(char::is_control) {
        return Err(err(
            path,
            spans.line(i, "label"),
            format!(
                "run {n}: `label` = {label:?} holds a control character (a line break, tab, \
                 ...); a label is one line of printable text"
            ),
        ));
    }
    let center_distance_m = match t.get("center_distance_m") {
        Some(v) => Some(in_run(n, positive(path, "center_distance_m", v))?),
        None => None,
    };
    check_load_torque(path, spans, (i, &label), t, earlier)?;
    for key in [STATIC_TENSION_KEY, STATIC_TENSION_SD_KEY] {
        positive_in_run(path, spans, i, t, key)?;
    }
    if t.contains_key(STATIC_TENSION_SD_KEY) && !t.contains_key(STATIC_TENSION_KEY) {
        return Err(err(
            path,
            spans.line(i, STATIC_TENSION_SD_KEY),
            format!(
                "run {n}: `{STATIC_TENSION_SD_KEY}` without `{STATIC_TENSION_KEY}`: the \
                 standard deviation belongs to a tension reading"
            ),
        ));
    }
    let metadata = t
        .iter()
        .filter(|(k, _)| !matches!(k.as_str(), "file" | "label" | "center_distance_m"))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    Ok(RunEntry {
        file,
        label,
        center_distance_m,
        metadata,
    })
}

/// Run `i`'s value of `key` (its table `t`), where it gives one: a positive number, an error
/// naming the run and the key's line otherwise.
fn positive_in_run(
    path: &Path,
    spans: &RunSpans,
    i: usize,
    t: &toml::Table,
    key: &str,
) -> Result<Option<f64>, MeasuredError> {
    t.get(key)
        .map(|v| {
            in_run(i + 1, positive(path, key, v)).map_err(|e| MeasuredError {
                line: spans.line(i, key),
                ..e
            })
        })
        .transpose()
}

/// Run `i`'s `load_torque_nm`, where it gives one: a positive number, and the same as the
/// earlier runs of its label give (or none where they give none).
fn check_load_torque(
    path: &Path,
    spans: &RunSpans,
    (i, label): (usize, &str),
    t: &toml::Table,
    runs: &[RunEntry],
) -> Result<(), MeasuredError> {
    let (n, key) = (i + 1, LOAD_TORQUE_KEY);
    if let Some(x) = positive_in_run(path, spans, i, t, key)? {
        if let Some((k, other)) = runs.iter().enumerate().find_map(|(k, r)| {
            (r.label == label)
                .then(|| r.number(key))
                .filter(|o| *o != Some(x))
                .map(|o| (k, o))
        }) {
            return Err(err(
                path,
                spans.line(i, key),
                format!(
                    "run {n}: `{key}` = {x} differs from run {}'s ({}) of the same label \
                     \"{label}\"; runs of one label are one condition, so give a run at another \
                     load its own label",
                    k + 1,
                    other.map_or("none".to_string(), |o| format!("{o}"))
                ),
            ));
        }
    } else if let Some(k) = runs
        .iter()
        .position(|r| r.label == label && r.number(key).is_some())
    {
        return Err(err(
            path,
            None,
            format!(
                "run {n}: no `{key}`, while run {} of the same label \"{label}\" gives one; \
                 runs of one label are one condition",
                k + 1
            ),
        ));
    }
    Ok(())
}

/// Whether two manifest `file` entries name one file (`a.csv` and `./a.csv` do).
fn same_file(a: &str, b: &str) -> bool {
    let parts = |s: &str| -> Vec<std::ffi::OsString> {
        Path::new(s)
            .components()
            .filter(|c| !matches!(c, std::path::Component::CurDir))
            .map(|c| c.as_os_str().to_os_string())
            .collect()
    };
    parts(a) == parts(b)
}

/// Where each `[[run]]`'s keys sit in the manifest's text, for the line of a message.
#[derive(serde::Deserialize, Default)]
struct RunSpans {
    #[serde(default)]
    run: Vec<BTreeMap<String, toml::Spanned<toml::Value>>>,
    #[serde(skip)]
    text: String,
}

impl RunSpans {
    fn of(text: &str) -> Self {
        let mut s: Self = toml::from_str(text).unwrap_or_default();
        s.text = text.to_string();
        s
    }

    /// The 1-based line of `key` in run `i` (0-based), when known.
    fn line(&self, i: usize, key: &str) -> Option<usize> {
        let at = self.run.get(i)?.get(key)?.span().start;
        Some(self.text.get(..at)?.matches('\n').count() + 1)
    }
}
