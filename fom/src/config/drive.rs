//! `[driver]` and `[driven]`: the pulleys, the motor or speed profile on the driver, the load
//! on the driven shaft.

use serde::{Deserialize, Serialize};

use super::exact_array;
use super::limits::{finite_all, non_negative, positive, table};

/// Index of the driver pulley (`[driver]`) in the model's pulley list.
pub const DRIVER: usize = 0;
/// Index of the driven pulley (`[driven]`) in the model's pulley list.
pub const DRIVEN: usize = 1;

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

impl PulleyConfig {
    /// The table's first error; `name` (`driver` or `driven`) prefixes every key.
    pub(crate) fn check(&self, name: &str) -> Result<(), String> {
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
