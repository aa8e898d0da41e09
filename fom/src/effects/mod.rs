//! Optional physics that the baseline twin leaves out (eccentric pulleys, angle-dependent load
//! torque, other friction laws, ...), plugged into the step without editing it.
//!
//! The shape is that of rapier's `PhysicsHooks` (rapier `src/pipeline/physics_hooks.rs`): a
//! narrow trait whose methods the step calls at the points where an effect can act, each with
//! the baseline as its default, so an effect overrides only what it changes. A new effect is
//! one file in this folder implementing [`Effect`]; with no effect the step computes exactly
//! the baseline (the hooks are not called).
//!
//! Where the step calls them (`integrator.rs`):
//! - [`Effect::contact_center_m`]: once per step and pulley, the centre of the pulley's contact
//!   circle from the shaft centre and angle (e.g. runout of an eccentric pulley);
//! - [`Effect::shaft_torque_nm`]: once per step and pulley, the external shaft torque from time,
//!   shaft angle and speed, given the baseline drive's torque (e.g. blade-pass pulsation,
//!   bearing drag);
//! - [`Effect::friction_law`]: once when the effect is added to a model, the belt-pulley friction
//!   law (e.g. a Stribeck curve);
//! - [`Effect::belt_hysteresis`]: once when the effect is added, a viscoelastic arm in the
//!   belt's axial elements (`belt::AxialHysteresis`).
//!
//! What a sensor makes of the speeds is not part of the step: the twin's sensor model
//! (`twin/src/sensor.rs`) turns a run into a recording.

pub mod bearing_drag;
pub mod belt_hysteresis;
pub mod blade_pass_pulsation;
pub mod pulley_eccentricity;
pub mod stribeck_friction;
pub mod tachometer;

use std::fmt::Debug;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

pub use bearing_drag::BearingDrag;
pub use belt_hysteresis::BeltHysteresis;
pub use blade_pass_pulsation::BladePassPulsation;
pub use pulley_eccentricity::PulleyEccentricity;
pub use stribeck_friction::StribeckFriction;
pub use tachometer::Tachometer;

use crate::contact::FrictionLaw;
use crate::model::{DRIVEN, DRIVER};

/// One optional physical effect. Every method defaults to the baseline.
pub trait Effect: Debug + Send + Sync {
    /// The effect's name in configurations and reports (e.g. `pulley-eccentricity`).
    fn name(&self) -> &str;

    /// Centre of pulley `pulley`'s contact circle, m, given its shaft centre and angle (rad).
    fn contact_center_m(
        &self,
        _pulley: usize,
        shaft_center_m: [f64; 2],
        _angle_rad: f64,
    ) -> [f64; 2] {
        shaft_center_m
    }

    /// External torque on pulley `pulley`'s shaft, N m (counter-clockwise positive), at time
    /// `time_s`, shaft angle and speed, given the baseline drive's torque `baseline_nm`.
    fn shaft_torque_nm(
        &self,
        _pulley: usize,
        _time_s: f64,
        _angle_rad: f64,
        _omega_rad_s: f64,
        baseline_nm: f64,
    ) -> f64 {
        baseline_nm
    }

    /// The friction law of the belt-pulley contacts, given the baseline's.
    fn friction_law(&self, baseline: FrictionLaw) -> FrictionLaw {
        baseline
    }

    /// A viscoelastic arm for the belt's axial elements: (stiffness relative to EA,
    /// relaxation time in s), or none (the baseline).
    fn belt_hysteresis(&self) -> Option<(f64, f64)> {
        None
    }
}

/// The effects acting on a model, applied in order.
#[derive(Debug, Clone, Default)]
pub struct Effects {
    list: Vec<Arc<dyn Effect>>,
}

impl Effects {
    /// Adds an effect after those already present.
    pub fn push(&mut self, effect: Arc<dyn Effect>) {
        self.list.push(effect);
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// The effects, in order.
    pub fn iter(&self) -> impl Iterator<Item = &Arc<dyn Effect>> {
        self.list.iter()
    }

    /// Names of the effects, in order.
    pub fn names(&self) -> Vec<&str> {
        self.list.iter().map(|e| e.name()).collect()
    }

    pub(crate) fn contact_center_m(
        &self,
        pulley: usize,
        shaft: [f64; 2],
        angle_rad: f64,
    ) -> [f64; 2] {
        self.list
            .iter()
            .fold(shaft, |c, e| e.contact_center_m(pulley, c, angle_rad))
    }

    pub(crate) fn shaft_torque_nm(
        &self,
        pulley: usize,
        time_s: f64,
        angle_rad: f64,
        omega_rad_s: f64,
        baseline_nm: f64,
    ) -> f64 {
        self.list.iter().fold(baseline_nm, |t, e| {
            e.shaft_torque_nm(pulley, time_s, angle_rad, omega_rad_s, t)
        })
    }
}

/// Which shaft an effect acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShaftSelector {
    Driver,
    Driven,
}

impl ShaftSelector {
    /// Index of the pulley in `Model::pulleys`.
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

/// What every catalogue effect has besides its hooks: checked parameters.
pub(crate) trait Catalogued: Effect {
    /// The parameters' error, naming the key, if any.
    fn check(&self) -> Result<(), String>;
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
        let mut names: Vec<String> = self
            .switched_on()
            .iter()
            .map(|e| e.name().to_string())
            .collect();
        if self.tachometer.is_some() {
            names.push("tachometer".into());
        }
        names
    }

    /// Whether no effect is switched on.
    pub fn is_empty(&self) -> bool {
        self == &Self::default()
    }

    /// The effects switched on that act on the mechanics, in catalogue order (the tachometer
    /// acts on the sensors only).
    fn switched_on(&self) -> Vec<Arc<dyn Catalogued>> {
        let mut on: Vec<Arc<dyn Catalogued>> = Vec::new();
        if let Some(e) = self.pulley_eccentricity {
            on.push(Arc::new(e));
        }
        if let Some(e) = self.blade_pass_pulsation {
            on.push(Arc::new(e));
        }
        if let Some(e) = self.stribeck_friction {
            on.push(Arc::new(e));
        }
        if let Some(e) = self.belt_hysteresis {
            on.push(Arc::new(e));
        }
        if let Some(e) = self.bearing_drag {
            on.push(Arc::new(e));
        }
        on
    }

    /// Checks every parameter; the message names the key.
    pub(crate) fn check(&self) -> Result<(), String> {
        self.switched_on().iter().try_for_each(|e| e.check())?;
        self.tachometer.as_ref().map_or(Ok(()), Tachometer::check)
    }

    /// The effects switched on, in catalogue order.
    pub fn build(&self) -> Effects {
        Effects {
            list: self
                .switched_on()
                .into_iter()
                .map(|e| e as Arc<dyn Effect>)
                .collect(),
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spec_switches_an_effect_on_with_its_parameters() {
        let mut c = EffectsConfig::default();
        c.set_from_spec("pulley-eccentricity:pulley=driven,runout_m=2e-4,phase_deg=30")
            .unwrap();
        assert_eq!(
            c.pulley_eccentricity,
            Some(PulleyEccentricity {
                pulley: ShaftSelector::Driven,
                runout_m: 2e-4,
                phase_deg: 30.0
            })
        );
        assert_eq!(c.build().names(), ["pulley-eccentricity"]);
        assert_eq!(c.names(), ["pulley-eccentricity"]);
        c.set_from_spec("tachometer:pulses_per_rev=30").unwrap();
        assert_eq!(c.names(), ["pulley-eccentricity", "tachometer"]);
        // The sensor does not act on the mechanics.
        assert_eq!(c.build().names(), ["pulley-eccentricity"]);
    }

    #[test]
    fn bad_specs_name_what_is_wrong() {
        let mut c = EffectsConfig::default();
        let e = c.set_from_spec("warp-drive:x=1").unwrap_err();
        assert!(
            e.contains("warp-drive") && e.contains("bearing-drag"),
            "{e}"
        );
        let e = c.set_from_spec("bearing-drag:colomb_nm=1").unwrap_err();
        assert!(e.contains("colomb_nm"), "{e}");
        let e = c
            .set_from_spec("blade-pass-pulsation:blades=8,amplitude=1.5")
            .unwrap_err();
        assert!(e.contains("amplitude"), "{e}");
        assert!(c.is_empty());
    }
}
