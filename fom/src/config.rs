//! Drive configuration: the TOML file format and its validation. Design-point changes to a
//! configuration go through `params::DesignPoint::apply`.
//!
//! Every physical quantity is SI and carries its unit in the key name. Unknown keys are rejected
//! (serde `deny_unknown_fields`) so that a typo never silently falls back to a default.

pub use crate::belt::kind::BeltKind;
use crate::contact::ContactLaw;
use crate::effects::{EffectParameter, EffectsConfig};
use crate::error::FomError;
use serde::{Deserialize, Deserializer, Serialize};
use std::path::Path;

/// Most output rows one run keeps (64 bytes each: 6.4 GB of the machine's memory).
pub const MAX_OUTPUT_ROWS: f64 = 1e8;

/// Most integrator steps one run may take, static-equilibrium search included: about 16 days
/// on one core for the default 240-segment belt (~14 us per step, README "Measured figures").
/// `step_s = 1e-12` ran for days with no word before (issue 14); a step count beyond this is
/// a typo, not a study.
pub const MAX_STEPS: f64 = 1e11;

/// Rated elongation assumed when `belt.max_strain` is absent: 10 %, the upper end of the
/// installation elongation of elastomer flat and round belts; cord-reinforced V-belts and
/// flat belts are rated far lower, so set `belt.max_strain` from the maker's data.
pub const DEFAULT_MAX_STRAIN: f64 = 0.10;

/// Static strain above which a run warns: 3 %, beyond the working strain of cord-reinforced
/// belts (the default V-belt runs at 1.25 %: 250 N on EA 20 kN).
pub const TYPICAL_WORKING_STRAIN: f64 = 0.03;

/// Relative tolerance of the strain limits: a belt installed at exactly its limit passes.
const STRAIN_TOLERANCE: f64 = 1e-9;

/// Whether `strain` exceeds `limit` by more than rounding.
pub(crate) fn strain_exceeds(strain: f64, limit: f64) -> bool {
    strain > limit * (1.0 + STRAIN_TOLERANCE)
}

/// Deserialises a fixed-size array of numbers, refusing any other length (serde's arrays stop
/// reading after N elements, so `[0.42, 0.0, 0.0]` would pass as a point in the plane).
pub fn exact_array<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    let n = v.len();
    v.try_into()
        .map_err(|_| serde::de::Error::invalid_length(n, &format!("exactly {N} numbers").as_str()))
}

/// [`exact_array`] for an optional array.
pub fn exact_array_opt<'de, D: Deserializer<'de>, const N: usize>(
    d: D,
) -> Result<Option<[f64; N]>, D::Error> {
    #[derive(Deserialize)]
    struct Exact<const N: usize>(#[serde(deserialize_with = "exact_array")] [f64; N]);
    Ok(Option::<Exact<N>>::deserialize(d)?.map(|e| e.0))
}

/// The complete description of a two-pulley open belt drive and of the numerical run.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DriveConfig {
    pub simulation: SimulationConfig,
    pub belt: BeltConfig,
    pub contact: ContactConfig,
    pub driver: PulleyConfig,
    pub driven: PulleyConfig,
    /// Optional physics the baseline leaves out (`[effects.<name>]`), all off by default.
    #[serde(default, skip_serializing_if = "EffectsConfig::is_empty")]
    pub effects: EffectsConfig,
}

/// The integrator step of a configuration: `step_s = 1.0e-5` or `step_s = "auto"`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepSize {
    /// A fixed step, s.
    Seconds(f64),
    /// The largest stable step that divides the output interval, chosen when the model is
    /// built (it depends on the belt, the effects and the design point).
    Auto,
}

impl Serialize for StepSize {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            StepSize::Seconds(v) => s.serialize_f64(*v),
            StepSize::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for StepSize {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Word(String),
        }
        match Raw::deserialize(d) {
            Ok(Raw::Number(v)) => Ok(StepSize::Seconds(v)),
            Ok(Raw::Word(w)) if w == "auto" => Ok(StepSize::Auto),
            _ => Err(serde::de::Error::custom(
                "step_s must be a number of seconds or \"auto\"",
            )),
        }
    }
}

/// Time integration and output settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SimulationConfig {
    /// Simulated time after static equilibrium, s.
    pub duration_s: f64,
    /// Integrator step: seconds, below the explicit stability limit (checked when the model is
    /// built), or `"auto"`: the largest step within that limit that divides the output
    /// interval (`Model::resolve_step`).
    pub step_s: StepSize,
    /// Interval of the output rows, s; each row holds the mean over the preceding interval.
    pub output_interval_s: f64,
    /// Start of the steady window, s, fixed by the user; absent (the default), the one
    /// steady-state definition (`fom::steady`) finds it. Either way the summary says whether
    /// the run had settled.
    #[serde(default)]
    pub steady_start_s: Option<f64>,
    /// Run until settled (`fom::steady`): `duration_s` is then the longest run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until_settled: Option<UntilSettled>,
    /// Gravity vector in the drive plane, m/s^2 (x along the line of centres, y up).
    #[serde(default, deserialize_with = "exact_array")]
    pub gravity_m_s2: [f64; 2],
}

/// Ending a run once it has settled.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UntilSettled {
    /// The run is not stopped before this time, s.
    pub min_duration_s: f64,
    /// Steady running needed before the run stops, s (at least `fom::steady::SHORTEST_WINDOW_S`).
    pub steady_length_s: f64,
}

impl UntilSettled {
    /// Least window the settling verdict rests on, s: the default's, or the steady length if
    /// shorter. The run goes on until the steady window found is `steady_length_s` long, so
    /// the start-up is never forced into it.
    pub fn judging_window_s(&self) -> f64 {
        crate::steady::MIN_WINDOW_S.min(self.steady_length_s)
    }
}

impl Default for UntilSettled {
    /// At least 3 s (the default drive's fan runs up in about 1.5 s) and 2 s of steady running
    /// (2000 samples at 1 kHz), as training had before runs ended on settling.
    fn default() -> Self {
        Self {
            min_duration_s: 3.0,
            steady_length_s: 2.0,
        }
    }
}

/// How the unstretched belt length is specified: exactly one of the three.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BeltLengthSpec {
    /// Unstretched pitch length L0, m.
    UnstretchedLength { length_m: f64 },
    /// Static strain (L(d) - L0) / L0 at the configured centre distance.
    PreStrain { strain: f64 },
    /// Static span tension T0 at a reference centre distance d_ref:
    /// L0 = L(d_ref) / (1 + T0 / EA). Moving the pulleys closer than d_ref lowers the tension.
    InstallationTension {
        tension_n: f64,
        reference_center_distance_m: f64,
    },
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BeltConfig {
    pub kind: BeltKind,
    /// Number of rigid segments N.
    pub segments: usize,
    #[serde(default)]
    pub unstretched_length_m: Option<f64>,
    #[serde(default)]
    pub pre_strain: Option<f64>,
    /// The belt's rated elongation: the largest static strain it may be installed at (a
    /// fraction; the maker's figure). Absent: `DEFAULT_MAX_STRAIN`. Above
    /// `TYPICAL_WORKING_STRAIN` a run warns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_strain: Option<f64>,
    #[serde(default)]
    pub installation_tension_n: Option<f64>,
    /// Centre distance at which `installation_tension_n` holds; absent = the configured one.
    #[serde(default)]
    pub reference_center_distance_m: Option<f64>,
    /// Axial stiffness EA, N.
    pub axial_stiffness_n: f64,
    /// Bending stiffness EI, N m^2.
    pub bending_stiffness_n_m2: f64,
    /// Shear stiffness kappa G A, N (Timoshenko).
    pub shear_stiffness_n: f64,
    /// Mass per unit length rho A, kg/m.
    pub mass_per_length_kg_m: f64,
    /// Belt thickness h, m; the pulley contact surface lies h/2 inside the pitch line.
    pub thickness_m: f64,
    /// Axial strain-rate damping: damping force = axial_damping_s * EA * strain rate, s.
    pub axial_damping_s: f64,
    /// Stiffness-proportional damping time constant of the shear/bending block, s.
    pub bending_damping_s: f64,
    /// The teeth of a `kind = "toothed"` belt.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub teeth: Option<crate::belt::teeth::TeethConfig>,
}

impl BeltConfig {
    /// The belt's rated elongation: `max_strain`, or `DEFAULT_MAX_STRAIN`.
    pub fn max_strain(&self) -> f64 {
        self.max_strain.unwrap_or(DEFAULT_MAX_STRAIN)
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactConfig {
    /// Penalty stiffness K per contact point, N/m^n (paper eq. 4).
    pub stiffness_n_m: f64,
    /// Damping factor D in F_n = K delta^n (1 + D d(delta)/dt), s/m (paper eq. 4).
    pub damping_s_m: f64,
    /// Hertz exponent n (paper eq. 4).
    pub exponent: f64,
    /// Friction coefficient mu. With `groove_angle_deg` it is the material coefficient and the
    /// wedge raises it to mu / sin(angle / 2); without, it is already the effective coefficient.
    pub friction: f64,
    /// V-groove included angle, degrees (optional).
    #[serde(default)]
    pub groove_angle_deg: Option<f64>,
    /// Velocity threshold v_th of the regularised Coulomb law (paper eq. 5), m/s.
    pub velocity_threshold_m_s: f64,
    /// Tooth-groove contact of a `kind = "toothed"` belt.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tooth: Option<crate::contact::tooth::ToothContactConfig>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PulleyConfig {
    /// Centre position, m.
    #[serde(deserialize_with = "exact_array")]
    pub center_m: [f64; 2],
    /// Pitch diameter, m.
    pub pitch_diameter_m: f64,
    /// Polar moment of inertia of everything on the shaft (pulley, rotor or impeller), kg m^2.
    pub inertia_kg_m2: f64,
    /// Viscous bearing damping, N m s/rad.
    #[serde(default)]
    pub bearing_damping_n_m_s: f64,
    /// Induction motor on this shaft (driver only).
    #[serde(default)]
    pub motor: Option<MotorConfig>,
    /// Prescribed speed profile (driver only); excludes `motor`.
    #[serde(default)]
    pub speed_profile: Option<SpeedProfileConfig>,
    /// Load torque on this shaft (driven only).
    #[serde(default)]
    pub load: Option<LoadConfig>,
}

/// Induction motor, steady-state Kloss torque-speed curve.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotorConfig {
    pub synchronous_rpm: f64,
    pub breakdown_torque_nm: f64,
    /// Slip at breakdown torque, dimensionless (0 < s_b < 1).
    pub breakdown_slip: f64,
    /// Supply switched on at this time, s (motor torque is zero before).
    #[serde(default)]
    pub start_time_s: f64,
}

/// Piecewise-linear angular speed versus time; constant after the last point.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpeedProfileConfig {
    pub time_s: Vec<f64>,
    pub rpm: Vec<f64>,
}

/// Load torque braking the driven shaft:
/// T = constant + viscous * omega + fan * omega^2 + extra(t), always opposing rotation.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LoadConfig {
    #[serde(default)]
    pub constant_nm: f64,
    #[serde(default)]
    pub viscous_nm_s: f64,
    /// Fan-law coefficient, N m s^2 (torque ~ speed squared, power ~ speed cubed).
    #[serde(default)]
    pub fan_nm_s2: f64,
    #[serde(default)]
    pub profile: Option<TorqueProfileConfig>,
}

/// Extra load torque as a function of time.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TorqueProfileConfig {
    /// Piecewise-linear table; constant after the last point.
    Table {
        time_s: Vec<f64>,
        torque_nm: Vec<f64>,
    },
    /// Smooth ramp 0 -> torque_nm between start_s and end_s (half cosine).
    CosineRamp {
        start_s: f64,
        end_s: f64,
        torque_nm: f64,
    },
}

impl TorqueProfileConfig {
    /// The profile's largest |torque|, N m (the design variable `load_torque_nm`).
    pub fn peak_torque_nm(&self) -> f64 {
        match self {
            TorqueProfileConfig::Table { torque_nm, .. } => {
                torque_nm.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
            }
            TorqueProfileConfig::CosineRamp { torque_nm, .. } => torque_nm.abs(),
        }
    }

    /// When the profile reaches its last value, s.
    pub fn end_s(&self) -> f64 {
        match self {
            TorqueProfileConfig::Table { time_s, .. } => time_s.last().copied().unwrap_or(0.0),
            TorqueProfileConfig::CosineRamp { end_s, .. } => *end_s,
        }
    }
}

impl DriveConfig {
    /// Reads and validates a configuration file.
    pub fn from_file(path: &Path) -> Result<Self, FomError> {
        let text = std::fs::read_to_string(path).map_err(|e| FomError::Io {
            context: format!("reading config {}", path.display()),
            source: e,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates TOML text; `origin` names the source in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, FomError> {
        let cfg: DriveConfig = toml::from_str(text).map_err(|e| FomError::Config {
            origin: origin.to_string(),
            message: e.to_string().trim().to_string(),
        })?;
        cfg.check().map_err(|message| FomError::Config {
            origin: origin.to_string(),
            message,
        })?;
        Ok(cfg)
    }

    /// The default HVAC fan drive shipped with the project (`fom/configs/hvac.toml`).
    pub fn default_hvac() -> Self {
        Self::from_toml_str(DEFAULT_HVAC_TOML, "built-in fom/configs/hvac.toml")
            .expect("the shipped default configuration is valid")
    }

    /// Serialises to TOML (used for calibrated configurations and surrogate provenance).
    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).expect("configuration serialises")
    }

    /// Centre distance between driver and driven pulley, m.
    pub fn center_distance_m(&self) -> f64 {
        let dx = self.driven.center_m[0] - self.driver.center_m[0];
        let dy = self.driven.center_m[1] - self.driver.center_m[1];
        dx.hypot(dy)
    }

    /// Share of the belt's axial stiffness EA that holds under static load: 1 - g with `belt-hysteresis`
    /// (relaxation fraction g of a one-term Prony series: EA is the instantaneous stiffness, EA
    /// (1 - g) the relaxed one; Findley, Lai & Onaran 1976, sec. 5.2), else 1.
    pub fn relaxed_stiffness_share(&self) -> f64 {
        // `read` gives 0 when the effect is off.
        1.0 - EffectParameter::HysteresisStiffnessRatio.read(&self.effects)
    }

    /// Relaxed (static) axial stiffness of the belt, EA (1 - g), N: the one the static tension,
    /// the installation stretch and the laid-out geometry follow.
    pub fn static_axial_stiffness_n(&self) -> f64 {
        self.belt.axial_stiffness_n * self.relaxed_stiffness_share()
    }

    /// Effective friction coefficient acting in the plane of the drive (the belt kind decides
    /// what a groove angle does).
    pub fn effective_friction(&self) -> f64 {
        self.belt
            .kind
            .effective_friction(self.contact.friction, self.contact.groove_angle_deg)
    }

    /// Transmission ratio R_t = driven / driver pitch diameter (seed paper eq. 1).
    pub fn transmission_ratio(&self) -> f64 {
        crate::slip::transmission_ratio(self.driver.pitch_diameter_m, self.driven.pitch_diameter_m)
    }

    /// The contact law between belt and pulleys: the penalty normal law and the friction law
    /// of this belt kind.
    pub fn contact_law(&self) -> ContactLaw {
        let c = &self.contact;
        ContactLaw {
            stiffness_n_m: c.stiffness_n_m,
            damping_s_m: c.damping_s_m,
            exponent: c.exponent,
            friction: self.belt.kind.friction_law(
                c.friction,
                c.groove_angle_deg,
                c.velocity_threshold_m_s,
            ),
        }
    }

    /// The configuration with another simulated duration, validated again.
    pub fn with_duration(mut self, duration_s: f64) -> Result<Self, FomError> {
        self.simulation.duration_s = duration_s;
        self.validate()?;
        Ok(self)
    }

    /// The integrator step a run of this configuration takes, s: the fixed `step_s`, or the one
    /// `"auto"` picks for the model it builds (`Model::resolve_step`).
    pub fn resolved_step_s(&self) -> Result<f64, FomError> {
        match self.simulation.step_s {
            StepSize::Seconds(s) => Ok(s),
            StepSize::Auto => Ok(crate::Model::from_config(self)?.params.step_s),
        }
    }

    /// How the belt length is specified (validated: exactly one way).
    pub fn length_spec(&self) -> BeltLengthSpec {
        let b = &self.belt;
        if let Some(length_m) = b.unstretched_length_m {
            BeltLengthSpec::UnstretchedLength { length_m }
        } else if let Some(strain) = b.pre_strain {
            BeltLengthSpec::PreStrain { strain }
        } else {
            BeltLengthSpec::InstallationTension {
                tension_n: b.installation_tension_n.unwrap_or(0.0),
                reference_center_distance_m: b
                    .reference_center_distance_m
                    .unwrap_or_else(|| self.center_distance_m()),
            }
        }
    }

    /// Checks every value; the error names the key and the offending value.
    pub fn validate(&self) -> Result<(), FomError> {
        self.check().map_err(|message| FomError::Config {
            origin: "configuration".into(),
            message,
        })
    }

    fn check(&self) -> Result<(), String> {
        let s = &self.simulation;
        positive("simulation.duration_s", s.duration_s)?;
        positive("simulation.output_interval_s", s.output_interval_s)?;
        // The run's rows are kept in memory until it ends: refuse what would not fit rather
        // than abort on the allocation (issue 14).
        let rows = s.duration_s / s.output_interval_s;
        if rows > MAX_OUTPUT_ROWS {
            return Err(format!(
                "simulation.duration_s = {} at simulation.output_interval_s = {} makes {rows:.3e} \
                 output rows ({:.1} GB in memory); at most {MAX_OUTPUT_ROWS:.0e}: lengthen the \
                 output interval or shorten the run",
                s.duration_s,
                s.output_interval_s,
                rows * std::mem::size_of::<crate::OutputRow>() as f64 / 1e9
            ));
        }
        if let StepSize::Seconds(step_s) = s.step_s {
            positive("simulation.step_s", step_s)?;
            check_step_count(s, step_s)?;
        }
        if s.duration_s < 2.0 * s.output_interval_s {
            return Err(format!(
                "simulation.duration_s = {} is shorter than two output intervals ({} s): the \
                 run would have no rows to summarise",
                s.duration_s,
                2.0 * s.output_interval_s
            ));
        }
        if let Some(t) = s.steady_start_s {
            if !(t.is_finite() && t >= 0.0 && t < s.duration_s) {
                return Err(format!(
                    "simulation.steady_start_s = {t} must lie in [0, duration_s = {})",
                    s.duration_s
                ));
            }
        }
        if let Some(u) = s.until_settled {
            positive("simulation.until_settled.min_duration_s", u.min_duration_s)?;
            if !(u.steady_length_s >= crate::steady::SHORTEST_WINDOW_S
                && u.steady_length_s <= u.min_duration_s.min(s.duration_s))
            {
                return Err(format!(
                    "simulation.until_settled.steady_length_s = {} must lie in [{}, \
                     min(min_duration_s = {}, duration_s = {})]",
                    u.steady_length_s,
                    crate::steady::SHORTEST_WINDOW_S,
                    u.min_duration_s,
                    s.duration_s
                ));
            }
        }
        finite_all("simulation.gravity_m_s2", &s.gravity_m_s2)?;

        let b = &self.belt;
        crate::limits::check_model_size(b.segments, b.teeth.as_ref().map(|t| t.count))?;
        if b.segments < 16 {
            return Err(format!(
                "belt.segments = {} is too few (at least 16)",
                b.segments
            ));
        }
        let n_specs = [
            b.unstretched_length_m.is_some(),
            b.pre_strain.is_some(),
            b.installation_tension_n.is_some(),
        ]
        .iter()
        .filter(|x| **x)
        .count();
        if n_specs != 1 {
            return Err(format!(
                "belt: give exactly one of unstretched_length_m, pre_strain, installation_tension_n \
                 (found {n_specs})"
            ));
        }
        if let Some(l) = b.unstretched_length_m {
            positive("belt.unstretched_length_m", l)?;
        }
        if let Some(m) = b.max_strain {
            if !(m.is_finite() && m > 0.0 && m <= 0.5) {
                return Err(format!(
                    "belt.max_strain = {m} must lie in (0, 0.5] (a fraction: 0.05 is 5 %)"
                ));
            }
        }
        if let Some(e) = b.pre_strain {
            let limit = b.max_strain();
            if !(e.is_finite() && e > 0.0) || strain_exceeds(e, limit) {
                return Err(format!(
                    "belt.pre_strain = {e} must lie in (0, belt.max_strain = {limit}] (the \
                     belt's rated elongation{})",
                    if b.max_strain.is_none() {
                        "; absent, the default; set it from the maker's data"
                    } else {
                        ""
                    }
                ));
            }
        }
        if let Some(t) = b.installation_tension_n {
            positive("belt.installation_tension_n", t)?;
        }
        if let Some(d) = b.reference_center_distance_m {
            positive("belt.reference_center_distance_m", d)?;
        }
        positive("belt.axial_stiffness_n", b.axial_stiffness_n)?;
        positive("belt.bending_stiffness_n_m2", b.bending_stiffness_n_m2)?;
        positive("belt.shear_stiffness_n", b.shear_stiffness_n)?;
        positive("belt.mass_per_length_kg_m", b.mass_per_length_kg_m)?;
        positive("belt.thickness_m", b.thickness_m)?;
        non_negative("belt.axial_damping_s", b.axial_damping_s)?;
        non_negative("belt.bending_damping_s", b.bending_damping_s)?;

        let c = &self.contact;
        positive("contact.stiffness_n_m", c.stiffness_n_m)?;
        non_negative("contact.damping_s_m", c.damping_s_m)?;
        if !(c.exponent.is_finite() && (1.0..=3.0).contains(&c.exponent)) {
            return Err(format!(
                "contact.exponent = {} must lie in [1, 3]",
                c.exponent
            ));
        }
        non_negative("contact.friction", c.friction)?;
        if let Some(a) = c.groove_angle_deg {
            if !(a.is_finite() && a > 10.0 && a < 90.0) {
                return Err(format!(
                    "contact.groove_angle_deg = {a} must lie in (10, 90)"
                ));
            }
        }
        positive("contact.velocity_threshold_m_s", c.velocity_threshold_m_s)?;
        b.kind
            .check_kind_tables(c.groove_angle_deg, b.teeth.is_some(), c.tooth.is_some())?;
        if let Some(t) = &b.teeth {
            t.check()?;
        }
        if let Some(t) = &c.tooth {
            t.check()?;
        }
        self.effects.check()?;

        self.driver.validate("driver")?;
        self.driven.validate("driven")?;
        match (&self.driver.motor, &self.driver.speed_profile) {
            (Some(_), Some(_)) => {
                return Err(
                    "driver: give either [driver.motor] or [driver.speed_profile], not both".into(),
                )
            }
            (None, None) => {
                return Err("driver: needs [driver.motor] or [driver.speed_profile]".into())
            }
            _ => {}
        }
        if self.driver.load.is_some() {
            return Err("driver.load: a load belongs on the driven pulley".into());
        }
        if self.driven.motor.is_some() || self.driven.speed_profile.is_some() {
            return Err("driven: motor and speed_profile belong on the driver".into());
        }
        let d = self.center_distance_m();
        let (r1, r2) = (
            0.5 * self.driver.pitch_diameter_m,
            0.5 * self.driven.pitch_diameter_m,
        );
        if d <= r1 + r2 + b.thickness_m {
            return Err(format!(
                "pulleys overlap: centre distance {d:.4} m is not larger than the sum of pitch \
                 radii plus belt thickness ({:.4} m)",
                r1 + r2 + b.thickness_m
            ));
        }
        Ok(())
    }
}

impl PulleyConfig {
    fn validate(&self, name: &str) -> Result<(), String> {
        finite_all(&format!("{name}.center_m"), &self.center_m)?;
        positive(&format!("{name}.pitch_diameter_m"), self.pitch_diameter_m)?;
        positive(&format!("{name}.inertia_kg_m2"), self.inertia_kg_m2)?;
        non_negative(
            &format!("{name}.bearing_damping_n_m_s"),
            self.bearing_damping_n_m_s,
        )?;
        if let Some(m) = &self.motor {
            positive(&format!("{name}.motor.synchronous_rpm"), m.synchronous_rpm)?;
            positive(
                &format!("{name}.motor.breakdown_torque_nm"),
                m.breakdown_torque_nm,
            )?;
            if !(m.breakdown_slip > 0.0 && m.breakdown_slip < 1.0) {
                return Err(format!(
                    "{name}.motor.breakdown_slip = {} must lie in (0, 1)",
                    m.breakdown_slip
                ));
            }
            non_negative(&format!("{name}.motor.start_time_s"), m.start_time_s)?;
        }
        if let Some(p) = &self.speed_profile {
            table(&format!("{name}.speed_profile"), &p.time_s, &p.rpm)?;
            if p.rpm.iter().any(|v| *v < 0.0) {
                return Err(format!(
                    "{name}.speed_profile.rpm: speeds must be non-negative"
                ));
            }
        }
        if let Some(l) = &self.load {
            non_negative(&format!("{name}.load.constant_nm"), l.constant_nm)?;
            non_negative(&format!("{name}.load.viscous_nm_s"), l.viscous_nm_s)?;
            non_negative(&format!("{name}.load.fan_nm_s2"), l.fan_nm_s2)?;
            match &l.profile {
                Some(TorqueProfileConfig::Table { time_s, torque_nm }) => {
                    table(&format!("{name}.load.profile"), time_s, torque_nm)?
                }
                Some(TorqueProfileConfig::CosineRamp {
                    start_s,
                    end_s,
                    torque_nm,
                }) => {
                    non_negative(&format!("{name}.load.profile.start_s"), *start_s)?;
                    finite_all(&format!("{name}.load.profile.torque_nm"), &[*torque_nm])?;
                    if !(end_s.is_finite() && end_s > start_s) {
                        return Err(format!(
                            "{name}.load.profile: end_s = {end_s} must be after start_s = {start_s}"
                        ));
                    }
                }
                None => {}
            }
        }
        Ok(())
    }
}

/// Checks a run's step `step_s` (fixed, or chosen by `Model::resolve_step`) against its output
/// interval and the step-count limit `MAX_STEPS`.
pub(crate) fn check_step_count(s: &SimulationConfig, step_s: f64) -> Result<(), String> {
    if s.output_interval_s < step_s {
        return Err(format!(
            "simulation.output_interval_s = {} is shorter than simulation.step_s = {step_s}",
            s.output_interval_s
        ));
    }
    let steps = (s.duration_s + crate::simulation::RELAXATION_MAX_S) / step_s;
    if steps > MAX_STEPS {
        return Err(format!(
            "simulation.step_s = {step_s} over simulation.duration_s = {} s (plus up to {} s of \
             static-equilibrium search) makes {steps:.3e} steps; at most {MAX_STEPS:.0e} \
             (about 16 days on one core): lengthen the step (step_s = \"auto\" picks the \
             largest stable one) or shorten the run",
            s.duration_s,
            crate::simulation::RELAXATION_MAX_S
        ));
    }
    Ok(())
}

fn positive(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{key} = {v} must be a positive finite number"))
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(format!("{key} = {v} must be a non-negative finite number"))
    }
}

fn finite_all(key: &str, v: &[f64]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{key} = {v:?} must be finite"))
    }
}

fn table(key: &str, t: &[f64], y: &[f64]) -> Result<(), String> {
    if t.is_empty() || t.len() != y.len() {
        return Err(format!(
            "{key}: time_s and values must be non-empty and of equal length ({} vs {})",
            t.len(),
            y.len()
        ));
    }
    finite_all(&format!("{key}.time_s"), t)?;
    finite_all(&format!("{key} values"), y)?;
    if t.windows(2).any(|w| w[1] <= w[0]) {
        return Err(format!("{key}.time_s must be strictly increasing"));
    }
    Ok(())
}

/// The shipped default drive, compiled in so that the binary works from any directory.
pub const DEFAULT_HVAC_TOML: &str = include_str!("../configs/hvac.toml");
