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
//!   law (e.g. a Stribeck curve).
//!
//! What a sensor makes of the speeds is not part of the step: the twin's sensor model
//! (`twin/src/sensor.rs`) turns a run into a recording.

use std::fmt::Debug;
use std::sync::Arc;

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

    pub(crate) fn friction_law(&self, baseline: FrictionLaw) -> FrictionLaw {
        self.list.iter().fold(baseline, |l, e| e.friction_law(l))
    }
}
