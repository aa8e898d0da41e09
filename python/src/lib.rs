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

/// A fitted surrogate of any kind (`rom::Kind`: slip, or a toothed belt's tooth loads) with
/// the drive configuration it is used on.
#[pyclass(frozen, module = "beltwin")]
struct Surrogate {
    model: rom::ModelFile,
    cfg: ValidConfig,
}

impl Surrogate {
    /// The slip surrogate, for the calls only that kind answers.
    fn slip(&self) -> PyResult<&rom::SurrogateFile> {
        match &self.model {
            rom::ModelFile::Slip(f) => Ok(f),
            other => Err(error(format!(
                "this call needs a slip surrogate; this model is a {}",
                other.kind().name()
            ))),
        }
    }

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
    /// Loads a model file of any kind (`rom train`'s output; its header names the kind);
    /// `path=None` loads the shipped model (embedded, `rom::shipped`) of `kind` ("slip" or
    /// "tooth-load"), by default the kind `config` trains (a toothed drive: tooth loads).
    /// `config` (a drive TOML) is checked against the configuration the surrogate was trained
    /// on; by default the surrogate's own is used.
    #[staticmethod]
    #[pyo3(signature = (path=None, config=None, kind=None))]
    fn load(path: Option<PathBuf>, config: Option<PathBuf>, kind: Option<&str>) -> PyResult<Self> {
        let shipped = match kind {
            None => None,
            Some("slip") => Some(rom::Kind::Slip),
            Some("tooth-load") => Some(rom::Kind::ToothLoad),
            Some(k) => {
                return Err(error(format!(
                    "kind `{k}` is not a surrogate kind (\"slip\" or \"tooth-load\")"
                )))
            }
        };
        let (model, cfg) = match (&path, shipped) {
            (None, Some(k)) => {
                let model = k.shipped().map_err(rom_error)?;
                let cfg = model.drive_config(config.as_deref()).map_err(rom_error)?;
                (model, cfg)
            }
            _ => rom::ModelFile::open(path.as_deref(), config.as_deref()).map_err(rom_error)?,
        };
        Ok(Self { model, cfg })
    }

    /// The kind of the model: "slip" or "tooth-load".
    #[getter]
    fn kind(&self) -> &'static str {
        match self.model.kind() {
            rom::Kind::Slip => "slip",
            rom::Kind::ToothLoad => "tooth-load",
        }
    }

    /// The model's prediction, as `rom predict --format json` prints it for the model's kind.
    /// A slip surrogate: the steady slip distribution at centre distance `d` (m, required):
    /// mean, std, quantiles, the surrogate's own uncertainty, and `quantile_function_pct` as
    /// an (levels, 2) numpy array of (probability, slip %); `mu`, `tension` (N) and `stiffness`
    /// (EA, N; surrogates trained over it) default to the configuration's; `samples` friction
    /// samples spread mu +- 1 %. A tooth-load surrogate: the maximum-tooth-load distribution
    /// at side gap `side_gap` (m), load torque `load_torque` (N m) and static shaft load
    /// `shaft_load` (N), each the configuration's when None: mean pass peak with its 90 %
    /// interval, pass-peak quantiles, and the run's largest tooth load with its interval (N).
    #[pyo3(signature = (d=None, mu=None, tension=None, stiffness=None, samples=rom::predict::DEFAULT_SAMPLES, allow_extrapolation=false, side_gap=None, load_torque=None, shaft_load=None))]
    #[allow(clippy::too_many_arguments)]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        d: Option<f64>,
        mu: Option<f64>,
        tension: Option<f64>,
        stiffness: Option<f64>,
        samples: usize,
        allow_extrapolation: bool,
        side_gap: Option<f64>,
        load_torque: Option<f64>,
        shaft_load: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        use fom::params::Variable;
        let kind = self.model.kind();
        let given = [
            (Variable::CenterDistance, "d", d),
            (Variable::Friction, "mu", mu),
            (Variable::InstallationTension, "tension", tension),
            (Variable::AxialStiffness, "stiffness", stiffness),
            (Variable::SideGap, "side_gap", side_gap),
            (Variable::LoadTorque, "load_torque", load_torque),
            (Variable::ShaftLoad, "shaft_load", shaft_load),
        ];
        for (v, name, x) in given {
            if x.is_none() && kind.required().contains(&v) {
                return Err(error(format!("{name} is required by a {}", kind.name())));
            }
            if x.is_some() && !kind.inputs().contains(&v) {
                return Err(error(format!(
                    "{name} is not an input of a {} (its inputs: {})",
                    kind.name(),
                    given
                        .iter()
                        .filter(|(v, ..)| kind.inputs().contains(v))
                        .map(|(_, n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
        let nominal = DesignPoint::nominal(&self.cfg);
        let q = self
            .point(
                d.unwrap_or(nominal.center_distance_m),
                mu,
                tension,
                stiffness,
            )
            .with_tooth_inputs(side_gap, load_torque, shaft_load);
        let request = rom::kind::Request {
            point: q,
            samples,
            allow_extrapolation,
        };
        let pred = self.model.predict(&self.cfg, &request).map_err(rom_error)?;
        let out = py
            .import("json")?
            .call_method1("loads", (pred.to_json(self.model.model_id()),))?;
        // The quantile function as an (levels, 2) array, for the kinds that return one.
        if let Ok(qf) = out.get_item("quantile_function_pct") {
            let rows: Vec<[f64; 2]> = qf.extract()?;
            let flat: Vec<f64> = rows.iter().flatten().copied().collect();
            let qf = PyArray1::from_vec(py, flat).reshape([rows.len(), 2])?;
            out.set_item("quantile_function_pct", qf)?;
        }
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
        let slip = self.slip()?;
        let dists = py.detach(|| {
            qs.iter()
                .enumerate()
                .map(|(i, q)| {
                    rom::predict_distribution(
                        &slip.surrogate,
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
        let levels = self.slip()?.surrogate.probability_levels.clone();
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
        let extrapolating: Vec<bool> = dists.iter().map(|d| d.extrapolated).collect();
        out.set_item("extrapolating", PyArray1::from_vec(py, extrapolating))?;
        Ok(out)
    }

    /// The design inputs the surrogate was trained over, with their ranges.
    #[getter]
    fn ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let ranges: serde_json::Map<String, serde_json::Value> = self
            .model
            .ranges()
            .into_iter()
            .map(|(v, r)| (v.key().to_string(), serde_json::json!(r)))
            .collect();
        to_python(py, &ranges)
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
    let s = Surrogate::load(model, config, None)?;
    let slip = s.slip()?;
    let set = read_dataset(&dir)?;
    let verdicts = py
        .detach(|| twin::diagnose::diagnose(&slip.surrogate, &s.cfg, &set))
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
    let s = Surrogate::load(model, config, None)?;
    let slip = s.slip()?;
    let set = read_dataset(&dir)?;
    let targets = targets_from_dataset(&set, &s.cfg).map_err(error)?;
    let free = match free {
        Some(names) => names.join(",").parse::<FreeSet>().map_err(error)?,
        None => FreeSet::default_for(&targets),
    };
    let report = py
        .detach(|| {
            CalibrationReport::run(
                &slip.surrogate,
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
    let s = Surrogate::load(model, config, None)?;
    let slip = s.slip()?;
    let set = read_dataset(&dir)?;
    let opts = twin::gap::GapOptions {
        holdout: holdout.unwrap_or_default(),
        ..Default::default()
    };
    let report = py
        .detach(|| twin::gap::gap(&slip.surrogate, &s.cfg, &set, &opts))
        .map_err(error)?;
    to_python(py, &report)
}

#[pymodule]
fn _beltwin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("BeltwinError", m.py().get_type::<BeltwinError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Surrogate>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(read_measurements, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(gap, m)?)?;
    Ok(())
}
