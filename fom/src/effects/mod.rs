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

// The parameter tables are configuration data (`config/effects.rs`); re-exported here so an
// effect's parameters and its hooks are found under one name.
pub use crate::config::effects::{
    BearingDrag, BeltHysteresis, BladePassPulsation, EffectParameter, EffectsConfig,
    PulleyEccentricity, ShaftSelector, StribeckFriction, Tachometer, EFFECT_NAMES,
};

use crate::contact::FrictionLaw;

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

impl EffectsConfig {
    /// The effects switched on that act on the mechanics, in catalogue order (the tachometer
    /// acts on the sensors only).
    pub fn build(&self) -> Effects {
        let mut on = Effects::default();
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
