//! Python bindings of beltwin (`import beltwin`). Each function wraps the library call the
//! matching `rom` command makes and returns the content of that command's JSON (through
//! serde, so the two cannot drift apart); time series and quantile functions come as numpy
//! arrays. No logic lives here beyond converting arguments and results.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use fom::{DesignPoint, DriveConfig, RunOptions, ValidConfig};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde::Serialize;

create_exception!(
    _beltwin,
    BeltwinError,
    pyo3::exceptions::PyException,
    "An error of beltwin: bad input (configuration, data set, model file, argument) or a \
     numerical failure; the message is the one the `rom` command prints."
);

/// The shipped surrogate (trained on the default HVAC drive), embedded so that an installed
/// wheel needs no source tree.
static SHIPPED_MODEL: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../artifacts/hvac-surrogate.json"
));

/// The shipped tooth-load surrogate (trained on `fom/configs/synchronous-arc.toml`).
static SHIPPED_TOOTH_MODEL: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../artifacts/synchronous-arc-tooth-surrogate.json"
));

fn error(e: impl std::fmt::Display) -> PyErr {
    BeltwinError::new_err(e.to_string())
}

/// The library error's message as the CLI shows it, with the Python keyword in place of a flag.
fn rom_message(e: rom::RomError) -> String {
    match e {
        rom::RomError::Extrapolation { reason } => {
            format!("{reason}; pass allow_extrapolation=True to predict anyway")
        }
        other => other.to_string(),
    }
}

fn rom_error(e: rom::RomError) -> PyErr {
    error(rom_message(e))
}

/// A serialisable value as Python objects (dicts, lists, floats; NaN becomes None).
fn to_python<'py>(py: Python<'py>, value: &impl Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(error)?;
    py.import("json")?.call_method1("loads", (text,))
}

fn drive_config(config: Option<PathBuf>) -> PyResult<ValidConfig> {
    match config {
        Some(p) => DriveConfig::from_file(&p).map_err(error),
        None => Ok(ValidConfig::default_hvac()),
    }
}

/// Runs the full-order model (`rom simulate`): the configuration file `config` (default: the
/// shipped HVAC drive) moved to the centre distance `d` (m), friction `mu` and installation
/// tension `tension` (N) where given, for `duration` seconds. Returns a dict of numpy arrays
/// with the run CSV's columns, plus `summary` (the run's steady statistics),
/// `static_tension_n` and `config` (the TOML that ran). Releases the GIL while it runs;
/// Ctrl-C stops it with KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (config=None, d=None, mu=None, tension=None, duration=None))]
fn simulate<'py>(
    py: Python<'py>,
    config: Option<PathBuf>,
    d: Option<f64>,
    mu: Option<f64>,
    tension: Option<f64>,
    duration: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let base = drive_config(config)?;
    let point = DesignPoint::nominal_with(&base, d, mu, tension);
    let mut cfg = point.apply(&base).map_err(error)?;
    if let Some(t) = duration {
        cfg = cfg.with_duration(t).map_err(error)?;
    }
    let stop = AtomicBool::new(false);
    let interrupted: Mutex<Option<PyErr>> = Mutex::new(None);
    // Called at least every 0.5 s of wall time: a pending Ctrl-C stops the run.
    let progress = |_: f64, _: f64| {
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                *interrupted.lock().expect("not poisoned") = Some(e);
                stop.store(true, Ordering::Relaxed);
            }
        })
    };
    let result = py.detach(|| {
        fom::simulate(
            &cfg,
            RunOptions {
                progress: Some(&progress),
                stop: Some(&stop),
                ..RunOptions::default()
            },
        )
    });
    if let Some(e) = interrupted.lock().expect("not poisoned").take() {
        return Err(e);
    }
    let run = result.map_err(error)?;
    let out = PyDict::new(py);
    for (j, name) in fom::output::OUTPUT_COLUMNS.iter().enumerate() {
        let v: Vec<f64> = run.rows.iter().map(|r| r.values()[j]).collect();
        out.set_item(*name, PyArray1::from_vec(py, v))?;
    }
    out.set_item("summary", to_python(py, &run.summary)?)?;
    out.set_item("static_tension_n", run.static_tension_n)?;
    out.set_item("config", cfg.to_toml_string())?;
    Ok(out)
}

/// A fitted surrogate (POD + Gaussian processes) with the drive configuration it is used on.
#[pyclass(frozen, module = "beltwin")]
struct Surrogate {
    file: rom::SurrogateFile,
    cfg: ValidConfig,
}

impl Surrogate {
    fn point(
        &self,
        d: f64,
        mu: Option<f64>,
        tension: Option<f64>,
        stiffness: Option<f64>,
    ) -> DesignPoint {
        DesignPoint {
            axial_stiffness_n: stiffness,
            ..DesignPoint::nominal_with(&self.cfg, Some(d), mu, tension)
        }
    }
}

#[pymethods]
impl Surrogate {
    /// Loads a surrogate file (`rom train`'s output); `path=None` loads the shipped one.
    /// `config` (a drive TOML) is checked against the configuration the surrogate was trained
    /// on; by default the surrogate's own is used.
    #[staticmethod]
    #[pyo3(signature = (path=None, config=None))]
    fn load(path: Option<PathBuf>, config: Option<PathBuf>) -> PyResult<Self> {
        let file = match &path {
            Some(p) => rom::SurrogateFile::load(p),
            None => {
                rom::SurrogateFile::from_bytes(SHIPPED_MODEL, rom::model_file::SHIPPED_MODEL_PATH)
            }
        }
        .map_err(rom_error)?;
        let cfg = file.drive_config(config.as_deref()).map_err(rom_error)?;
        Ok(Self { file, cfg })
    }

    /// The steady slip distribution at centre distance `d` (m), as `rom predict --format
    /// json`: mean, std, quantiles, the surrogate's own uncertainty, and
    /// `quantile_function_pct` as an (levels, 2) numpy array of (probability, slip %).
    /// `mu`, `tension` (N) and `stiffness` (EA, N; surrogates trained over it) default to the
    /// configuration's; `samples` friction samples spread mu +- 1 %.
    #[pyo3(signature = (d, mu=None, tension=None, stiffness=None, samples=rom::predict::DEFAULT_SAMPLES, allow_extrapolation=false))]
    #[allow(clippy::too_many_arguments)]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        d: f64,
        mu: Option<f64>,
        tension: Option<f64>,
        stiffness: Option<f64>,
        samples: usize,
        allow_extrapolation: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.point(d, mu, tension, stiffness);
        let dist = rom::predict_distribution(
            &self.file.surrogate,
            &self.cfg,
            &q,
            samples,
            allow_extrapolation,
        )
        .map_err(rom_error)?;
        let out = to_python(py, &dist)?;
        let flat: Vec<f64> = dist
            .quantile_function_pct
            .iter()
            .flatten()
            .copied()
            .collect();
        let n = dist.quantile_function_pct.len();
        let qf = PyArray1::from_vec(py, flat).reshape([n, 2])?;
        out.set_item("quantile_function_pct", qf)?;
        Ok(out)
    }

    /// `predict` over the rows of an (n, k) array: columns d, then optionally mu, tension and
    /// stiffness. Returns a dict of numpy arrays: `mean_slip_pct`, `std_slip_pct`,
    /// `surrogate_std_pct` (n,), `quantiles_pct` (n, 5: p05 p25 p50 p75 p95),
    /// `quantile_function_pct` (n, levels) at `probability_levels` (levels,), and
    /// `extrapolating` (n,). One point outside the trained ranges refuses the call unless
    /// `allow_extrapolation`. Releases the GIL.
    #[pyo3(signature = (points, samples=rom::predict::DEFAULT_SAMPLES, allow_extrapolation=false))]
    fn predict_many<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        samples: usize,
        allow_extrapolation: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let shape = points.shape();
        let (n, k) = (shape[0], shape[1]);
        if !(1..=4).contains(&k) {
            return Err(error(format!(
                "points must have 1 to 4 columns (d, mu, tension, stiffness), got {k}"
            )));
        }
        let view = points.as_array();
        let qs: Vec<DesignPoint> = (0..n)
            .map(|i| {
                let col = |j: usize| (j < k).then(|| view[[i, j]]);
                self.point(view[[i, 0]], col(1), col(2), col(3))
            })
            .collect();
        let dists = py.detach(|| {
            qs.iter()
                .enumerate()
                .map(|(i, q)| {
                    rom::predict_distribution(
                        &self.file.surrogate,
                        &self.cfg,
                        q,
                        samples,
                        allow_extrapolation,
                    )
                    .map_err(|e| (i, e))
                })
                .collect::<Result<Vec<_>, _>>()
        });
        let dists = dists.map_err(|(i, e)| error(format!("point {i}: {}", rom_message(e))))?;
        let levels = self.file.surrogate.probability_levels.clone();
        let nl = levels.len();
        let col = |f: fn(&rom::Distribution) -> f64| dists.iter().map(f).collect::<Vec<f64>>();
        let out = PyDict::new(py);
        out.set_item(
            "mean_slip_pct",
            PyArray1::from_vec(py, col(|d| d.mean_slip_pct)),
        )?;
        out.set_item(
            "std_slip_pct",
            PyArray1::from_vec(py, col(|d| d.std_slip_pct)),
        )?;
        out.set_item(
            "surrogate_std_pct",
            PyArray1::from_vec(py, col(|d| d.surrogate_std_pct)),
        )?;
        let quantiles: Vec<f64> = dists
            .iter()
            .flat_map(|d| {
                let q = &d.quantiles_pct;
                [q.p05, q.p25, q.p50, q.p75, q.p95]
            })
            .collect();
        out.set_item(
            "quantiles_pct",
            PyArray1::from_vec(py, quantiles).reshape([n, 5])?,
        )?;
        let qf: Vec<f64> = dists
            .iter()
            .flat_map(|d| d.quantile_function_pct.iter().map(|p| p[1]))
            .collect();
        out.set_item(
            "quantile_function_pct",
            PyArray1::from_vec(py, qf).reshape([n, nl])?,
        )?;
        out.set_item("probability_levels", PyArray1::from_vec(py, levels))?;
        let extrapolating: Vec<bool> = dists.iter().map(|d| d.extrapolating).collect();
        out.set_item("extrapolating", PyArray1::from_vec(py, extrapolating))?;
        Ok(out)
    }

    /// The design inputs the surrogate was trained over, with their ranges.
    #[getter]
    fn ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file.header.ranges)
    }

    /// The drive configuration (TOML) the surrogate is used on.
    #[getter]
    fn config(&self) -> String {
        self.cfg.to_toml_string()
    }
}

fn read_dataset(dir: &std::path::Path) -> PyResult<twin::measured::DataSet> {
    twin::measured::read_dataset(dir, twin::signal::MIN_STEADY_SAMPLES).map_err(error)
}

/// Reads a `belt-measurements/1` data set: the manifest's fields and, per run, its label,
/// file, centre distance, metadata and the recording as numpy arrays (`time_s`,
/// `driver_rpm`, `driven_rpm`).
#[pyfunction]
fn read_measurements<'py>(py: Python<'py>, dir: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let set = read_dataset(&dir)?;
    let m = &set.manifest;
    let out = PyDict::new(py);
    out.set_item("format", twin::measured::FORMAT)?;
    out.set_item("description", m.description.clone())?;
    out.set_item("driver_pulley_diameter_m", m.driver_pulley_diameter_m)?;
    out.set_item("driven_pulley_diameter_m", m.driven_pulley_diameter_m)?;
    let runs = PyList::empty(py);
    for (entry, rec) in m.runs.iter().zip(&set.recordings) {
        let r = PyDict::new(py);
        r.set_item("label", &entry.label)?;
        r.set_item("file", &entry.file)?;
        r.set_item("center_distance_m", entry.center_distance_m)?;
        r.set_item("metadata", to_python(py, &entry.metadata)?)?;
        r.set_item("time_s", PyArray1::from_vec(py, rec.time_s.clone()))?;
        r.set_item("driver_rpm", PyArray1::from_vec(py, rec.driver_rpm.clone()))?;
        r.set_item("driven_rpm", PyArray1::from_vec(py, rec.driven_rpm.clone()))?;
        runs.append(r)?;
    }
    out.set_item("runs", runs)?;
    Ok(out)
}

/// Belt-looseness diagnosis from measured speeds (`rom diagnose`): one verdict per label, as
/// in `diagnosis.json`.
#[pyfunction]
#[pyo3(signature = (dir, model=None, config=None))]
fn diagnose<'py>(
    py: Python<'py>,
    dir: PathBuf,
    model: Option<PathBuf>,
    config: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let s = Surrogate::load(model, config)?;
    let set = read_dataset(&dir)?;
    let verdicts = py
        .detach(|| twin::diagnose::diagnose(&s.file.surrogate, &s.cfg, &set))
        .map_err(error)?;
    to_python(py, &verdicts)
}

/// Calibration against measured data (`rom calibrate --format json`): `free` lists the free
/// parameters (friction, tension, ratio, stiffness, distances | spaced-distances; default
/// friction and tension, plus the distances when a run gives none). `confirm` runs the
/// full-order model at the fitted point; `leave_one_out` adds the leave-one-out predictions.
#[pyfunction]
#[pyo3(signature = (dir, free=None, tolerance=5.0, confirm=true, leave_one_out=false, model=None, config=None))]
#[allow(clippy::too_many_arguments)]
fn calibrate<'py>(
    py: Python<'py>,
    dir: PathBuf,
    free: Option<Vec<String>>,
    tolerance: f64,
    confirm: bool,
    leave_one_out: bool,
    model: Option<PathBuf>,
    config: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    use twin::calibrate::{targets_from_dataset, CalibrationReport, FreeSet};
    let s = Surrogate::load(model, config)?;
    let set = read_dataset(&dir)?;
    let targets = targets_from_dataset(&set, &s.cfg).map_err(error)?;
    let free = match free {
        Some(names) => names.join(",").parse::<FreeSet>().map_err(error)?,
        None => FreeSet::default_for(&targets),
    };
    let report = py
        .detach(|| {
            CalibrationReport::run(
                &s.file.surrogate,
                &s.cfg,
                &targets,
                free,
                tolerance,
                confirm,
                leave_one_out,
                twin::calibrate::PREDICTIVE_FOM_RUNS,
            )
        })
        .map_err(error)?;
    to_python(py, &report)
}

/// The sim-to-real gap diagnosis (`rom gap --format json`): where the twin misses, which
/// unmodelled effect explains it, and how far the gap shrinks with it. `holdout` lists labels
/// withheld from the fits (default: leave one label out at a time).
#[pyfunction]
#[pyo3(signature = (dir, holdout=None, model=None, config=None))]
fn gap<'py>(
    py: Python<'py>,
    dir: PathBuf,
    holdout: Option<Vec<String>>,
    model: Option<PathBuf>,
    config: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let s = Surrogate::load(model, config)?;
    let set = read_dataset(&dir)?;
    let opts = twin::gap::GapOptions {
        holdout: holdout.unwrap_or_default(),
        ..Default::default()
    };
    let report = py
        .detach(|| twin::gap::gap(&s.file.surrogate, &s.cfg, &set, &opts))
        .map_err(error)?;
    to_python(py, &report)
}

/// A toothed belt's tooth-load surrogate (issue 13) with the drive configuration it is used on.
#[pyclass(frozen, module = "beltwin")]
struct ToothSurrogate {
    file: rom::tooth::ToothSurrogateFile,
    cfg: ValidConfig,
}

#[pymethods]
impl ToothSurrogate {
    /// Loads a tooth-load surrogate file (`rom train --config TOOTHED.toml`'s output);
    /// `path=None` loads the shipped one (the seed paper's drive). `config` (a drive TOML) is
    /// checked against the configuration it was trained on; by default its own is used.
    #[staticmethod]
    #[pyo3(signature = (path=None, config=None))]
    fn load(path: Option<PathBuf>, config: Option<PathBuf>) -> PyResult<Self> {
        let file = match &path {
            Some(p) => rom::tooth::ToothSurrogateFile::load(p),
            None => rom::tooth::ToothSurrogateFile::from_bytes(
                SHIPPED_TOOTH_MODEL,
                rom::tooth::SHIPPED_TOOTH_MODEL_PATH,
            ),
        }
        .map_err(rom_error)?;
        let cfg = file.drive_config(config.as_deref()).map_err(rom_error)?;
        Ok(Self { file, cfg })
    }

    /// The maximum-tooth-load distribution at side gap `side_gap` (m), load torque
    /// `load_torque` (N m) and static shaft load `shaft_load` (N), each the configuration's
    /// when None, as `rom predict --config TOOTHED.toml --format json`: mean pass peak with
    /// its 90 % interval, pass-peak quantiles, and the run's largest tooth load with its
    /// interval (N).
    #[pyo3(signature = (side_gap=None, load_torque=None, shaft_load=None, allow_extrapolation=false))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        side_gap: Option<f64>,
        load_torque: Option<f64>,
        shaft_load: Option<f64>,
        allow_extrapolation: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q =
            DesignPoint::nominal(&self.cfg).with_tooth_inputs(side_gap, load_torque, shaft_load);
        let p = self
            .file
            .surrogate
            .predict(&self.cfg, &q, allow_extrapolation)
            .map_err(rom_error)?;
        to_python(py, &p)
    }
}

#[pymodule]
fn _beltwin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("BeltwinError", m.py().get_type::<BeltwinError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Surrogate>()?;
    m.add_class::<ToothSurrogate>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(read_measurements, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(gap, m)?)?;
    Ok(())
}
