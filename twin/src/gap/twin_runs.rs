//! The twin's side of the gap: reduced-resolution full-order runs at each label's calibrated
//! point, without and with each candidate effect, turned into recordings the way the
//! measurement was taken, so that `features` reads both alike.

use fom::{DesignPoint, DriveConfig, RunOptions};
use serde::Serialize;

use crate::error::{Result, TwinError};
use crate::measured::Recording;
use crate::sensor::{measure, SensorModel};

/// Resolution of the twin's runs in `rom gap`: half the default drive's segments at twice its
/// step (4x cheaper). The candidates' signatures are differences between runs at the same
/// resolution; the slip level comes from the surrogate (full resolution, calibrated).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Resolution {
    pub segments: usize,
    pub step_s: f64,
    /// Shortest and longest run, s: a twin run lasts as long as the recording it is compared
    /// with (its steady window then sits as long after the start), within these bounds.
    pub min_duration_s: f64,
    pub max_duration_s: f64,
}

impl Default for Resolution {
    fn default() -> Self {
        Self {
            segments: 120,
            step_s: 2.0e-5,
            min_duration_s: 2.5,
            max_duration_s: 8.0,
        }
    }
}

/// A mechanical candidate effect of the catalogue with its magnitude parameter: the magnitude of
/// the sensitivity run, the bound of the fit, and the specification that switches it on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Variant {
    /// Catalogue name.
    pub effect: &'static str,
    /// A discrete choice made before the fit (which pulley, how many blades), or empty.
    pub choice: String,
    /// The fitted magnitude's name.
    pub parameter: &'static str,
    pub reference: f64,
    pub max: f64,
}

impl Variant {
    /// `rom simulate --effect` specification at magnitude `m`.
    pub fn spec(&self, m: f64) -> String {
        match self.effect {
            "pulley-eccentricity" => format!("pulley-eccentricity:{},runout_m={m}", self.choice),
            "blade-pass-pulsation" => format!("blade-pass-pulsation:{},amplitude={m}", self.choice),
            "stribeck-friction" => format!(
                "stribeck-friction:dynamic_ratio={},stribeck_speed_m_s=0.05",
                1.0 - m
            ),
            "belt-hysteresis" => {
                format!("belt-hysteresis:stiffness_ratio={m},relaxation_s=0.01")
            }
            "bearing-drag" => format!("bearing-drag:coulomb_nm={m}"),
            other => unreachable!("{other} is not a mechanical candidate"),
        }
    }

    /// The cells only this variant moves among the catalogue's effects: its own line, at a
    /// frequency no other effect excites (the shaft it sits on turning once, the fan's blades
    /// passing). Empty for effects without one (docs/decisions/gap-signature-line.md).
    pub fn line_cells(&self) -> Vec<usize> {
        use crate::gap::features::{cell_index, Band, Cell, Signal, Statistic, Window};
        let line = |signal, band| {
            cell_index(Cell::new(
                Window::Steady,
                signal,
                Statistic::Amplitude,
                band,
            ))
        };
        match (self.effect, self.choice.as_str()) {
            ("pulley-eccentricity", "pulley=driver") => vec![
                line(Signal::DriverSpeed, Band::Driver1x),
                line(Signal::DrivenSpeed, Band::Driver1x),
            ],
            ("pulley-eccentricity", "pulley=driven") => {
                vec![line(Signal::DrivenSpeed, Band::Driven1x)]
            }
            ("blade-pass-pulsation", _) => vec![line(Signal::DrivenSpeed, Band::BladePass)],
            _ => Vec::new(),
        }
    }

    /// The frequency of the variant's own line in orders of the driver shaft, at transmission
    /// ratio `ratio` (driven over driver pitch diameter, so that the driven shaft turns at
    /// 1 / `ratio` of the driver's speed, slip aside) and `blades` fan blades; `None` for an
    /// effect without a line of its own.
    pub fn line_order(&self, ratio: f64, blades: u32) -> Option<f64> {
        match (self.effect, self.choice.as_str()) {
            ("pulley-eccentricity", "pulley=driver") => Some(1.0),
            ("pulley-eccentricity", "pulley=driven") => Some(1.0 / ratio),
            ("blade-pass-pulsation", _) => Some(f64::from(blades) / ratio),
            _ => None,
        }
    }
}

/// The mechanical candidates, with the blade count `blades` chosen from the data. Reference
/// magnitudes are those of the catalogue's signature table or larger, so that the sensitivity run's signature stands clear of its own noise (behind the
/// heavy fan, blade-pass 0.3 and a driven-pulley runout of 1 mm give lines of about 5 and 2.5
/// noise floors over 2 s); bounds are physical limits well past what a running drive shows
/// (2 mm runout, half the load torque pulsating, dynamic friction at 40 % of static, half of EA
/// relaxing, 5 N m of drag, a quarter of the fan's torque at speed).
pub fn variants(blades: u32) -> Vec<Variant> {
    let v = |effect, choice: &str, parameter, reference, max| Variant {
        effect,
        choice: choice.to_string(),
        parameter,
        reference,
        max,
    };
    vec![
        v(
            "pulley-eccentricity",
            "pulley=driver",
            "runout_m",
            5e-4,
            2e-3,
        ),
        v(
            "pulley-eccentricity",
            "pulley=driven",
            "runout_m",
            1e-3,
            2e-3,
        ),
        v(
            "blade-pass-pulsation",
            &format!("blades={blades}"),
            "amplitude",
            0.3,
            0.5,
        ),
        v("stribeck-friction", "", "1 - dynamic_ratio", 0.4, 0.6),
        v("belt-hysteresis", "", "stiffness_ratio", 0.2, 0.5),
        v("bearing-drag", "", "coulomb_nm", 1.0, 5.0),
    ]
}

/// The configuration of one twin run: `cfg` moved to `q`, at `res`, with the effect `spec`.
pub fn run_config(
    cfg: &DriveConfig,
    q: &DesignPoint,
    res: &Resolution,
    sample_interval_s: f64,
    duration_s: f64,
    spec: Option<&str>,
) -> Result<fom::ValidConfig> {
    let mut c = q.moved(cfg)?;
    c.belt.segments = res.segments;
    c.simulation.step_s = fom::config::StepSize::Seconds(res.step_s);
    // Output rows at the recording's interval, a whole number of steps.
    let k = (sample_interval_s / res.step_s).round().max(1.0);
    c.simulation.output_interval_s = k * res.step_s;
    c.simulation.duration_s = duration_s.clamp(res.min_duration_s, res.max_duration_s);
    c.simulation.steady_start_s = None;
    c.simulation.until_settled = None;
    if let Some(spec) = spec {
        c.effects
            .set_from_spec(spec)
            .map_err(|m| TwinError::Calibration(format!("effect {spec}: {m}")))?;
    }
    Ok(c.check()?)
}

/// Rows of one twin run.
pub fn run(cfg: &fom::ValidConfig) -> Result<Vec<fom::OutputRow>> {
    Ok(fom::simulate(cfg, RunOptions::default())?.rows)
}

/// A recording of twin rows, with its driven speed rescaled from the model's ratio to the
/// measurement's (`model_ratio / measured_ratio`) and its slip moved by `slip_shift_pct`
/// (the surrogate's calibrated level minus this run's), read by the sensor model (with its
/// fixed seed, so that runs with and without an effect see the same noise and their difference
/// is the effect's).
pub fn twin_recording(
    rows: &[fom::OutputRow],
    model_ratio: f64,
    measured_ratio: f64,
    slip_shift_pct: f64,
    sensor: &SensorModel,
) -> Recording {
    scaled_twin_recording(
        rows,
        model_ratio,
        measured_ratio,
        slip_shift_pct,
        [1.0; 2],
        sensor,
    )
}

/// [`twin_recording`] with the driver's and the driven speed then scaled by `scale` before the
/// sensor reads them (`gap::reading::twin_features` reads a twin at the measured speeds).
pub fn scaled_twin_recording(
    rows: &[fom::OutputRow],
    model_ratio: f64,
    measured_ratio: f64,
    slip_shift_pct: f64,
    scale: [f64; 2],
    sensor: &SensorModel,
) -> Recording {
    let adjusted: Vec<fom::OutputRow> = rows
        .iter()
        .map(|r| {
            let mut r = *r;
            // slip = 100 (1 - R n2 / n1): moving it by ds moves n2 by -n1 ds / (100 R).
            r.driven_rpm = r.driven_rpm * model_ratio / measured_ratio
                - r.driver_rpm * slip_shift_pct / (100.0 * measured_ratio);
            r.driver_rpm *= scale[0];
            r.driven_rpm *= scale[1];
            r
        })
        .collect();
    measure(&adjusted, sensor)
}
