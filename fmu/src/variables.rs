//! The variables of each FMU kind: one table, from which `rom export-fmu` writes the model
//! description and the FMU's binary maps value references at run time (the value reference of a
//! variable is its index in the table).

use fom::params::Variable as DesignVariable;
use fom::pulley::ShaftDrive;
use fom::{DesignPoint, DriveConfig};

/// An FMI 2.0 base type; every value is held as an `f64` (a Boolean as 0 or 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Type {
    Real,
    Integer,
    Boolean,
}

/// An FMI 2.0 causality (the ones these FMUs use).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Fixed before initialisation.
    Parameter,
    Input,
    Output,
}

/// One variable of an FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct Var {
    pub name: String,
    pub ty: Type,
    pub causality: Causality,
    /// Start value (inputs and parameters; outputs are calculated).
    pub start: f64,
    /// Allowed range written into the model description (the trained box for a surrogate).
    pub range: Option<[f64; 2]>,
    /// Unit, one of [`UNITS`].
    pub unit: Option<&'static str>,
    pub description: String,
}

impl Var {
    fn real(name: &str, causality: Causality, unit: Option<&'static str>, text: &str) -> Self {
        Self {
            name: name.into(),
            ty: Type::Real,
            causality,
            start: 0.0,
            range: None,
            unit,
            description: text.into(),
        }
    }

    fn boolean(name: &str, causality: Causality, start: bool, text: &str) -> Self {
        Self {
            ty: Type::Boolean,
            start: f64::from(u8::from(start)),
            ..Self::real(name, causality, None, text)
        }
    }
}

/// The units these FMUs use: name, SI base-unit exponents (kg, m, s, rad) and factor.
pub const UNITS: [(&str, [i32; 4], f64); 5] = [
    ("m", [0, 1, 0, 0], 1.0),
    ("N", [1, 1, -2, 0], 1.0),
    ("N.m", [1, 2, -2, 0], 1.0),
    // 1 rpm = 2 pi / 60 rad/s.
    ("rpm", [0, 0, -1, 1], std::f64::consts::PI / 30.0),
    ("%", [0, 0, 0, 0], 0.01),
];

/// The unit of a design variable, read from its key's suffix (`fom::params::Variable::key`).
fn unit_of_key(key: &str) -> Option<&'static str> {
    if key.ends_with("_nm") {
        Some("N.m")
    } else if key.ends_with("_n") {
        Some("N")
    } else if key.ends_with("_m") {
        Some("m")
    } else {
        None
    }
}

/// Names of the surrogate FMU's outputs after its inputs and parameters, in order.
pub const SURROGATE_OUTPUTS: [(&str, &str); 8] = [
    (
        "mean_slip_pct",
        "mean steady slip over the friction uncertainty (seed paper eq. 1), %",
    ),
    ("std_slip_pct", "standard deviation of the steady slip, %"),
    ("slip_p05_pct", "5 % quantile of the steady slip, %"),
    ("slip_p25_pct", "25 % quantile of the steady slip, %"),
    ("slip_p50_pct", "median steady slip, %"),
    ("slip_p75_pct", "75 % quantile of the steady slip, %"),
    ("slip_p95_pct", "95 % quantile of the steady slip, %"),
    (
        "surrogate_std_pct",
        "the surrogate's own standard deviation of the mean slip, %",
    ),
];

/// The point a surrogate is asked at before any input is set: the configuration's nominal
/// point with its installation tension, as `rom predict` takes for the inputs it is not given.
pub fn surrogate_start_point(cfg: &DriveConfig, inputs: &[DesignVariable]) -> DesignPoint {
    let mut q = DesignPoint::nominal(cfg);
    if inputs.contains(&DesignVariable::InstallationTension) {
        if let Some(t) = cfg.belt.installation_tension_n {
            q.installation_tension_n = t;
        }
    }
    q
}

/// The slip surrogate FMU's variables: one input per trained variable (range: the trained
/// box), the friction-sample count and the extrapolation switch, the predicted distribution.
pub fn surrogate_variables(
    cfg: &DriveConfig,
    ranges: &training::DesignRanges,
) -> Vec<(Var, Option<DesignVariable>)> {
    let inputs = ranges.variables();
    let q = surrogate_start_point(cfg, &inputs);
    let mut vars = Vec::new();
    for v in &inputs {
        let range = ranges.get(*v);
        let nominal = q.value_or_config(*v, cfg);
        let start = match range {
            Some([lo, hi]) if !(lo..=hi).contains(&nominal) => 0.5 * (lo + hi),
            _ => nominal,
        };
        let mut var = Var::real(
            v.key(),
            Causality::Input,
            unit_of_key(v.key()),
            &format!("{} (trained range in min and max)", v.describe()),
        );
        var.start = start;
        var.range = range;
        vars.push((var, Some(*v)));
    }
    vars.push((
        Var {
            ty: Type::Integer,
            start: rom::predict::DEFAULT_SAMPLES as f64,
            range: Some([1.0, rom::predict::MAX_SAMPLES as f64]),
            ..Var::real(
                "samples",
                Causality::Parameter,
                None,
                "friction samples propagated (rom predict --samples)",
            )
        },
        None,
    ));
    vars.push((
        Var::boolean(
            "allow_extrapolation",
            Causality::Parameter,
            false,
            "answer outside the trained box (else such a step fails with a logged message)",
        ),
        None,
    ));
    for (name, text) in SURROGATE_OUTPUTS {
        vars.push((Var::real(name, Causality::Output, Some("%"), text), None));
    }
    vars.push((
        Var::boolean(
            "extrapolated",
            Causality::Output,
            false,
            "true when the answer lies outside the trained box (allow_extrapolation)",
        ),
        None,
    ));
    vars
}

/// Names of the full-order FMU's outputs, in `fom::output::OUTPUT_COLUMNS` order after time.
pub const FOM_OUTPUTS: [(&str, Option<&str>, &str); 7] = [
    ("driver_speed_rpm", Some("rpm"), "driver shaft speed"),
    ("driven_speed_rpm", Some("rpm"), "driven shaft speed"),
    (
        "slip_pct",
        Some("%"),
        "belt slip (seed paper eq. 1); NaN until the driver turns",
    ),
    (
        "tight_span_tension_n",
        Some("N"),
        "axial force at the tight span's midpoint",
    ),
    (
        "slack_span_tension_n",
        Some("N"),
        "axial force at the slack span's midpoint",
    ),
    (
        "driver_torque_nm",
        Some("N.m"),
        "motor torque on the driver shaft",
    ),
    (
        "driven_torque_nm",
        Some("N.m"),
        "load torque on the driven shaft",
    ),
];

/// Name of the full-order FMU's motor supply input.
pub const MOTOR_ON: &str = "motor_on";
/// Name of the full-order FMU's extra load torque input.
pub const EXTRA_LOAD: &str = "extra_load_torque_nm";

/// The full-order FMU's variables: the motor supply (when the driver has a motor) and an
/// extra load torque on the driven shaft (when it has a load), then the outputs, each the mean
/// over the last communication step (as a row of `rom simulate` is over its output interval).
pub fn fom_variables(cfg: &fom::ValidConfig) -> Result<Vec<Var>, String> {
    let model = fom::Model::from_config(cfg).map_err(|e| e.to_string())?;
    let mut vars = Vec::new();
    if matches!(model.pulleys[0].drive, ShaftDrive::Motor(_)) {
        vars.push(Var::boolean(
            MOTOR_ON,
            Causality::Input,
            true,
            "motor supply on (the configuration's motor, from its start time) or off",
        ));
    }
    if matches!(model.pulleys[1].drive, ShaftDrive::Load(_)) {
        vars.push(Var::real(
            EXTRA_LOAD,
            Causality::Input,
            Some("N.m"),
            "load torque added to the configuration's constant load on the driven shaft, \
             opposing rotation",
        ));
    }
    if vars.is_empty() {
        return Err(
            "the full-order FMU needs a motor on the driver or a load on the driven shaft \
             (driver.motor, driven.load): this drive has neither input"
                .into(),
        );
    }
    for (name, unit, text) in FOM_OUTPUTS {
        let text = format!("{text}, mean over the last communication step");
        vars.push(Var::real(name, Causality::Output, unit, &text));
    }
    Ok(vars)
}
