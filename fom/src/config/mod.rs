//! Drive configuration: the TOML file format, its tables (one file each) and its validation.
//! Design-point changes to a configuration go through `params::DesignPoint::apply`.
//!
//! Every physical quantity is SI and carries its unit in the key name. Unknown keys are rejected
//! (serde `deny_unknown_fields`) so that a typo never silently falls back to a default.
//!
//! The configuration is a leaf of the crate: it imports serde, std, `error`, `readable` and the steady
//! window's lengths (`steady.rs`, itself a leaf), never a model type. Checking happens once:
//! [`DriveConfig::check`] turns a configuration into a [`ValidConfig`], which is what model
//! building and every run take (docs/decisions/validated-config.md).

pub mod belt;
pub mod contact;
pub mod drive;
pub mod effects;
pub mod limits;
pub mod simulation;

use serde::{Deserialize, Deserializer, Serialize};
use std::path::Path;

pub use belt::{BeltConfig, BeltKind, BeltLengthSpec, TeethConfig};
pub use contact::{ContactConfig, ToothContactConfig};
pub use drive::{
    LoadConfig, MotorConfig, PulleyConfig, SpeedProfileConfig, TorqueProfileConfig, DRIVEN, DRIVER,
};
pub use effects::{EffectParameter, EffectsConfig};
pub(crate) use limits::strain_exceeds;
pub use limits::{
    DEFAULT_MAX_STRAIN, MAX_OUTPUT_ROWS, MAX_STEPS, RELAXATION_MAX_S, TYPICAL_WORKING_STRAIN,
};
pub(crate) use simulation::check_step_count;
pub use simulation::{SimulationConfig, StepSize, UntilSettled};

use crate::error::FomError;

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

/// A configuration that has passed [`DriveConfig::check`]: the only kind model building and
/// runs accept, so nothing downstream checks it again. Read it as a [`DriveConfig`] (it
/// dereferences to one); to change it, take the data out ([`ValidConfig::into_inner`]), edit
/// and check again.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(transparent)]
pub struct ValidConfig(DriveConfig);

impl std::ops::Deref for ValidConfig {
    type Target = DriveConfig;

    fn deref(&self) -> &DriveConfig {
        &self.0
    }
}

impl AsRef<DriveConfig> for ValidConfig {
    fn as_ref(&self) -> &DriveConfig {
        &self.0
    }
}

impl ValidConfig {
    /// The default HVAC fan drive shipped with the project (`fom/configs/hvac.toml`).
    pub fn default_hvac() -> Self {
        DriveConfig::from_toml_str(DEFAULT_HVAC_TOML, "built-in fom/configs/hvac.toml")
            .expect("the shipped default configuration is valid")
    }

    /// The configuration data, to edit (check it again to run it).
    pub fn into_inner(self) -> DriveConfig {
        self.0
    }

    /// The configuration with another simulated duration, checked again.
    pub fn with_duration(self, duration_s: f64) -> Result<Self, FomError> {
        let mut c = self.0;
        c.simulation.duration_s = duration_s;
        c.check()
    }
}

impl DriveConfig {
    /// Reads and validates a configuration file.
    pub fn from_file(path: &Path) -> Result<ValidConfig, FomError> {
        let text = std::fs::read_to_string(path).map_err(|e| FomError::Io {
            context: format!("reading config {}", path.display()),
            source: e,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates TOML text; `origin` names the source in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<ValidConfig, FomError> {
        let cfg: DriveConfig = toml::from_str(text).map_err(|e| FomError::Config {
            origin: origin.to_string(),
            message: e.to_string().trim().to_string(),
        })?;
        cfg.check_as(origin)
    }

    /// The default HVAC fan drive shipped with the project (`fom/configs/hvac.toml`), as
    /// editable data; `ValidConfig::default_hvac` is the same drive ready to run.
    pub fn default_hvac() -> Self {
        ValidConfig::default_hvac().into_inner()
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

    /// Checks every value once and returns the validated configuration; the error names the
    /// key and the offending value.
    pub fn check(&self) -> Result<ValidConfig, FomError> {
        self.check_as("configuration")
    }

    /// [`DriveConfig::check`] with `origin` naming the source in the error.
    pub fn check_as(&self, origin: &str) -> Result<ValidConfig, FomError> {
        match self.first_error() {
            None => Ok(ValidConfig(self.clone())),
            Some(message) => Err(FomError::Config {
                origin: origin.to_string(),
                message,
            }),
        }
    }

    /// The first error, table by table in file order, if any.
    fn first_error(&self) -> Option<String> {
        self.check_tables().err()
    }

    fn check_tables(&self) -> Result<(), String> {
        self.simulation.check()?;
        self.belt.check()?;
        self.contact.check()?;
        let (b, c) = (&self.belt, &self.contact);
        b.kind
            .check_kind_tables(c.groove_angle_deg, b.teeth.is_some(), c.tooth.is_some())?;
        if let Some(t) = &b.teeth {
            t.check()?;
        }
        if let Some(t) = &c.tooth {
            t.check()?;
        }
        self.effects.check()?;
        self.check_pulleys()
    }

    /// The pulleys' tables, their roles (motor or speed profile on the driver, load on the
    /// driven shaft) and that they do not overlap.
    fn check_pulleys(&self) -> Result<(), String> {
        self.driver.check("driver")?;
        self.driven.check("driven")?;
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
        if d <= r1 + r2 + self.belt.thickness_m {
            return Err(format!(
                "pulleys overlap: centre distance {d:.4} m is not larger than the sum of pitch \
                 radii plus belt thickness ({:.4} m)",
                r1 + r2 + self.belt.thickness_m
            ));
        }
        Ok(())
    }
}

/// The shipped default drive, compiled in so that the binary works from any directory.
pub const DEFAULT_HVAC_TOML: &str = include_str!("../../configs/hvac.toml");
