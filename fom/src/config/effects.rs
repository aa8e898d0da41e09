//! `[effects]`: one optional table per catalogue effect, all off by default. The parameters
//! and their checks live here; what each effect does to the step is its file in `effects/`
//! (`docs/extending/effect.md`).

use serde::{Deserialize, Serialize};

use super::drive::{DRIVEN, DRIVER};

/// Which shaft an effect acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShaftSelector {
    Driver,
    Driven,
}

impl ShaftSelector {
    /// Index of the pulley in the model's pulley list (`DRIVER`, `DRIVEN`).
    pub fn index(self) -> usize {
        match self {
            ShaftSelector::Driver => DRIVER,
            ShaftSelector::Driven => DRIVEN,
        }
    }
}

/// The `[effects]` section of a drive configuration: one optional table per catalogue effect,
/// all off by default. With none set the section is not written, so configuration hashes of
/// drives without effects do not change.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, rename_all = "kebab-case")]
pub struct EffectsConfig {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pulley_eccentricity: Option<PulleyEccentricity>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blade_pass_pulsation: Option<BladePassPulsation>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stribeck_friction: Option<StribeckFriction>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub belt_hysteresis: Option<BeltHysteresis>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bearing_drag: Option<BearingDrag>,
    /// The speed sensors (read by the twin's sensor model; no change to the mechanics).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tachometer: Option<Tachometer>,
}

/// Parameters of `[effects.pulley-eccentricity]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PulleyEccentricity {
    /// Which pulley runs out.
    pub pulley: ShaftSelector,
    /// Runout e: distance of the contact circle's centre from the shaft axis, m.
    pub runout_m: f64,
    /// Phase phi of the runout at shaft angle zero, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

impl PulleyEccentricity {
    /// The table's first error, naming the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(self.runout_m.is_finite() && self.runout_m >= 0.0 && self.runout_m < 0.01) {
            return Err(format!(
                "effects.pulley-eccentricity.runout_m = {} must lie in [0, 0.01) m",
                self.runout_m
            ));
        }
        if !self.phase_deg.is_finite() {
            return Err("effects.pulley-eccentricity.phase_deg must be finite".into());
        }
        Ok(())
    }
}

/// Parameters of `[effects.blade-pass-pulsation]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BladePassPulsation {
    /// Number of fan blades z.
    pub blades: u32,
    /// Relative amplitude a of the load-torque pulsation.
    pub amplitude: f64,
    /// Phase phi at fan shaft angle zero, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

impl BladePassPulsation {
    /// The table's first error, naming the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        if self.blades == 0 {
            return Err("effects.blade-pass-pulsation.blades must be at least 1".into());
        }
        if !(self.amplitude.is_finite() && (0.0..1.0).contains(&self.amplitude)) {
            return Err(format!(
                "effects.blade-pass-pulsation.amplitude = {} must lie in [0, 1)",
                self.amplitude
            ));
        }
        if !self.phase_deg.is_finite() {
            return Err("effects.blade-pass-pulsation.phase_deg must be finite".into());
        }
        Ok(())
    }
}

/// Parameters of `[effects.stribeck-friction]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StribeckFriction {
    /// Dynamic over static coefficient, mu_d / mu_s, in (0, 1].
    pub dynamic_ratio: f64,
    /// Stribeck speed v_s, m/s: the sliding speed at which friction has fallen to the dynamic
    /// value.
    pub stribeck_speed_m_s: f64,
}

impl StribeckFriction {
    /// The table's first error, naming the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(self.dynamic_ratio > 0.0 && self.dynamic_ratio <= 1.0) {
            return Err(format!(
                "effects.stribeck-friction.dynamic_ratio = {} must lie in (0, 1]",
                self.dynamic_ratio
            ));
        }
        if !(self.stribeck_speed_m_s.is_finite() && self.stribeck_speed_m_s > 0.0) {
            return Err(format!(
                "effects.stribeck-friction.stribeck_speed_m_s = {} must be positive",
                self.stribeck_speed_m_s
            ));
        }
        Ok(())
    }
}

/// Parameters of `[effects.belt-hysteresis]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeltHysteresis {
    /// Relaxation fraction g: the viscoelastic arm's share of the instantaneous axial stiffness
    /// EA, in (0, 1).
    pub stiffness_ratio: f64,
    /// Relaxation time of the arm, s.
    pub relaxation_s: f64,
}

impl BeltHysteresis {
    /// The table's first error, naming the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(self.stiffness_ratio > 0.0 && self.stiffness_ratio < 1.0) {
            return Err(format!(
                "effects.belt-hysteresis.stiffness_ratio = {} must lie in (0, 1): it is the \
                 share of EA that relaxes",
                self.stiffness_ratio
            ));
        }
        if !(self.relaxation_s.is_finite() && self.relaxation_s > 0.0) {
            return Err(format!(
                "effects.belt-hysteresis.relaxation_s = {} must be positive",
                self.relaxation_s
            ));
        }
        Ok(())
    }
}

/// Parameters of `[effects.bearing-drag]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingDrag {
    /// Coulomb (speed-independent) drag torque, N m.
    #[serde(default)]
    pub coulomb_nm: f64,
    /// Viscous drag coefficient, N m s/rad.
    #[serde(default)]
    pub viscous_nm_s: f64,
}

impl BearingDrag {
    /// The table's first error, naming the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        for (k, v) in [
            ("coulomb_nm", self.coulomb_nm),
            ("viscous_nm_s", self.viscous_nm_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "effects.bearing-drag.{k} = {v} must be a non-negative finite number"
                ));
            }
        }
        Ok(())
    }
}

/// Parameters of `[effects.tachometer]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tachometer {
    /// Pulses per shaft revolution (teeth of the target wheel).
    pub pulses_per_rev: u32,
    /// Resolution of the pulse timer, s (0: exact pulse times).
    #[serde(default)]
    pub timer_resolution_s: f64,
    /// Share of pulses that go missing, [0, 0.5).
    #[serde(default)]
    pub missing_pulse_share: f64,
}

impl Tachometer {
    /// The table's first error, naming the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        if self.pulses_per_rev == 0 {
            return Err("effects.tachometer.pulses_per_rev must be at least 1".into());
        }
        if !(self.timer_resolution_s.is_finite() && self.timer_resolution_s >= 0.0) {
            return Err(format!(
                "effects.tachometer.timer_resolution_s = {} must be zero or positive",
                self.timer_resolution_s
            ));
        }
        if !(0.0..0.5).contains(&self.missing_pulse_share) {
            return Err(format!(
                "effects.tachometer.missing_pulse_share = {} must lie in [0, 0.5)",
                self.missing_pulse_share
            ));
        }
        Ok(())
    }
}

/// An effect's magnitude parameter that a training campaign can vary and a surrogate can take
/// as an input (`params::Variable::Effect`). The configuration must have the effect's table:
/// its other parameters (which pulley, how many blades, ...) come from there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffectParameter {
    Runout,
    BladePassAmplitude,
    StribeckDynamicRatio,
    HysteresisStiffnessRatio,
    BearingCoulomb,
}

impl EffectParameter {
    pub const ALL: [EffectParameter; 5] = [
        EffectParameter::Runout,
        EffectParameter::BladePassAmplitude,
        EffectParameter::StribeckDynamicRatio,
        EffectParameter::HysteresisStiffnessRatio,
        EffectParameter::BearingCoulomb,
    ];

    /// `effect-name.key`, as in settings files and design CSV headers.
    pub const fn key(self) -> &'static str {
        match self {
            EffectParameter::Runout => "pulley-eccentricity.runout_m",
            EffectParameter::BladePassAmplitude => "blade-pass-pulsation.amplitude",
            EffectParameter::StribeckDynamicRatio => "stribeck-friction.dynamic_ratio",
            EffectParameter::HysteresisStiffnessRatio => "belt-hysteresis.stiffness_ratio",
            EffectParameter::BearingCoulomb => "bearing-drag.coulomb_nm",
        }
    }

    /// Position in `ALL`.
    pub fn index(self) -> usize {
        Self::ALL.iter().position(|p| *p == self).expect("listed")
    }

    /// The configuration's value; an effect that is off has its baseline value (zero
    /// magnitude, or a dynamic ratio of 1).
    pub fn read(self, c: &EffectsConfig) -> f64 {
        match self {
            EffectParameter::Runout => c.pulley_eccentricity.map_or(0.0, |e| e.runout_m),
            EffectParameter::BladePassAmplitude => {
                c.blade_pass_pulsation.map_or(0.0, |e| e.amplitude)
            }
            EffectParameter::StribeckDynamicRatio => {
                c.stribeck_friction.map_or(1.0, |e| e.dynamic_ratio)
            }
            EffectParameter::HysteresisStiffnessRatio => {
                c.belt_hysteresis.map_or(0.0, |e| e.stiffness_ratio)
            }
            EffectParameter::BearingCoulomb => c.bearing_drag.map_or(0.0, |e| e.coulomb_nm),
        }
    }

    /// Sets the value in the configuration's table of the effect, which must be present.
    pub fn write(self, c: &mut EffectsConfig, x: f64) -> Result<(), String> {
        let missing = || {
            let name = self.key().split('.').next().unwrap_or_default();
            format!(
                "design variable {} needs an [effects.{name}] table in the configuration \
                 (its other parameters come from there)",
                self.key()
            )
        };
        match self {
            EffectParameter::Runout => {
                c.pulley_eccentricity.as_mut().ok_or_else(missing)?.runout_m = x
            }
            EffectParameter::BladePassAmplitude => {
                c.blade_pass_pulsation
                    .as_mut()
                    .ok_or_else(missing)?
                    .amplitude = x
            }
            EffectParameter::StribeckDynamicRatio => {
                c.stribeck_friction
                    .as_mut()
                    .ok_or_else(missing)?
                    .dynamic_ratio = x
            }
            EffectParameter::HysteresisStiffnessRatio => {
                c.belt_hysteresis
                    .as_mut()
                    .ok_or_else(missing)?
                    .stiffness_ratio = x
            }
            EffectParameter::BearingCoulomb => {
                c.bearing_drag.as_mut().ok_or_else(missing)?.coulomb_nm = x
            }
        }
        Ok(())
    }
}

/// Names of the effects a configuration can switch on, as in `[effects.<name>]`.
pub const EFFECT_NAMES: [&str; 6] = [
    "pulley-eccentricity",
    "blade-pass-pulsation",
    "stribeck-friction",
    "belt-hysteresis",
    "bearing-drag",
    "tachometer",
];

impl EffectsConfig {
    /// Names of the effects switched on (with the tachometer), in catalogue order.
    pub fn names(&self) -> Vec<String> {
        let on = [
            self.pulley_eccentricity.is_some(),
            self.blade_pass_pulsation.is_some(),
            self.stribeck_friction.is_some(),
            self.belt_hysteresis.is_some(),
            self.bearing_drag.is_some(),
            self.tachometer.is_some(),
        ];
        EFFECT_NAMES
            .iter()
            .zip(on)
            .filter(|(_, on)| *on)
            .map(|(name, _)| name.to_string())
            .collect()
    }

    /// Whether no effect is switched on.
    pub fn is_empty(&self) -> bool {
        self == &Self::default()
    }

    /// Checks every parameter, in catalogue order; the message names the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        self.pulley_eccentricity.map_or(Ok(()), |e| e.check())?;
        self.blade_pass_pulsation.map_or(Ok(()), |e| e.check())?;
        self.stribeck_friction.map_or(Ok(()), |e| e.check())?;
        self.belt_hysteresis.map_or(Ok(()), |e| e.check())?;
        self.bearing_drag.map_or(Ok(()), |e| e.check())?;
        self.tachometer.as_ref().map_or(Ok(()), Tachometer::check)
    }

    /// Switches on (or replaces) one effect from a short specification (all or nothing)
    /// `name:key=value,key=value` (e.g. `bearing-drag:coulomb_nm=0.5`); the keys are those of
    /// its `[effects.<name>]` table.
    pub fn set_from_spec(&mut self, spec: &str) -> Result<(), String> {
        let (name, params) = spec.split_once(':').unwrap_or((spec, ""));
        let name = name.trim();
        if !EFFECT_NAMES.contains(&name) {
            return Err(format!(
                "unknown effect `{name}` (choose from {})",
                EFFECT_NAMES.join(", ")
            ));
        }
        let mut table = toml::Table::new();
        for kv in params.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (k, v) = kv
                .split_once('=')
                .ok_or_else(|| format!("effect `{name}`: `{kv}` is not key=value"))?;
            let v = v.trim();
            // Numbers stay numbers; anything else (a pulley name) is a string.
            let value = match (v.parse::<i64>(), v.parse::<f64>()) {
                (Ok(i), _) => toml::Value::Integer(i),
                (_, Ok(x)) => toml::Value::Float(x),
                _ => toml::Value::String(v.to_string()),
            };
            table.insert(k.trim().to_string(), value);
        }
        // This configuration as TOML with the effect's table put in, read back: the keys are
        // checked by the same serde rules as a file's.
        let mut all = toml::Table::try_from(&*self).map_err(|e| e.to_string())?;
        all.insert(name.to_string(), toml::Value::Table(table));
        let next: EffectsConfig = toml::Value::Table(all)
            .try_into()
            .map_err(|e: toml::de::Error| format!("effect `{name}`: {}", e.message().trim()))?;
        next.check()?;
        *self = next;
        Ok(())
    }
}
