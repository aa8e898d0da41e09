//! Belt kinds plugged into the step: what a kind of belt adds to the land contact of
//! `integrator.rs` (the penalty normal law and the regularised friction every kind has).
//!
//! The shape is that of `effects` (rapier's `PhysicsHooks`, rapier
//! `src/pipeline/physics_hooks.rs`): a narrow trait, [`BeltContact`], whose methods the step,
//! the energy balance, the stability estimate and the run call at fixed points, each with the
//! baseline (no extra contact) as its default. A kind is one file in this folder implementing
//! it, registered by one line in [`build`]; nothing outside this folder names a kind
//! (docs/extending/belt-kind.md).
//!
//! Where they are called:
//! - [`BeltContact::explicit_forces`]: once per step, after the belt's internal forces and
//!   before the predicted velocities (e.g. the teeth's normal forces);
//! - [`BeltContact::add_reaction_torques`]: once per step, the reactions of those forces on
//!   the pulleys, before the land contact's friction;
//! - [`BeltContact::friction`]: once per step with friction on, after the land contact's
//!   friction;
//! - [`BeltContact::elastic_energy_j`], [`BeltContact::stable_step_limit_s`],
//!   [`BeltContact::check_health`]: the energy balance, the step's stability estimate and the
//!   run's health check;
//! - [`BeltContact::circulates_freely`], [`BeltContact::reset`]: the static-equilibrium search;
//! - [`BeltContact::recorder`]: once per run, what the kind records beyond the output rows
//!   (a [`Recorder`], its result a [`KindRecord`] in `RunResult`).

pub mod flat;
pub mod tooth_record;
pub mod toothed;

use std::any::Any;
use std::fmt::Debug;
use std::sync::Arc;

use crate::belt::Belt;
use crate::config::{BeltKind, ValidConfig};
use crate::error::FomError;
use crate::pulley::Pulley;

/// What a belt kind adds to the belt-pulley contact. Every method defaults to the baseline:
/// no extra contact.
pub trait BeltContact: Debug + Send + Sync {
    /// The kind's name, as in `belt.kind`.
    fn name(&self) -> &str;

    /// A boxed copy (the model is cloned, e.g. to run one equilibrium several times).
    fn clone_box(&self) -> Box<dyn BeltContact>;

    /// The kind as `Any`, for its own recorder and for tests that look inside it.
    fn as_any(&self) -> &dyn Any;

    /// The kind as `Any`, mutable.
    fn as_any_mut(&mut self) -> &mut dyn Any;

    /// Adds explicit contact forces to the belt's segment forces; returns the power they
    /// dissipate, W.
    fn explicit_forces(&mut self, _belt: &mut Belt, _pulleys: &[Pulley]) -> f64 {
        0.0
    }

    /// Adds this step's reactions of the explicit forces to the belt torque on each pulley,
    /// N m.
    fn add_reaction_torques(&self, _belt_torque_nm: &mut [f64]) {}

    /// Implicit friction of the extra contact on the belt's velocities, against pulley
    /// surfaces turning at `omega_surface_rad_s`; reactions go to `belt_torque_nm`. Returns
    /// the power it dissipates, W.
    fn friction(
        &mut self,
        _belt: &mut Belt,
        _pulleys: &[Pulley],
        _omega_surface_rad_s: &[f64],
        _dt_s: f64,
        _belt_torque_nm: &mut [f64],
    ) -> f64 {
        0.0
    }

    /// Elastic energy stored in the extra contact, J.
    fn elastic_energy_j(&self, _belt: &Belt, _pulleys: &[Pulley]) -> f64 {
        0.0
    }

    /// Largest stable step of the extra contact's explicit part on a segment of mass
    /// `mass_kg`, s (infinite: no limit).
    fn stable_step_limit_s(&self, _mass_kg: f64) -> f64 {
        f64::INFINITY
    }

    /// An error when the extra contact has failed (e.g. a tooth jumped its groove).
    fn check_health(&self, _time_s: f64) -> Result<(), FomError> {
        Ok(())
    }

    /// Whether the belt's circulation around the loop is a neutral mode at rest (it floats
    /// in a backlash), to be left out of the equilibrium search's residual.
    fn circulates_freely(&self) -> bool {
        false
    }

    /// Clears what the extra contact tracks since the last reset (after the equilibrium
    /// search).
    fn reset(&mut self) {}

    /// What a run of `cfg` records of this kind beyond the output rows, if anything.
    fn recorder(&self, _cfg: &ValidConfig) -> Option<Box<dyn Recorder>> {
        None
    }
}

impl Clone for Box<dyn BeltContact> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// Records what a belt kind adds to a run's output (e.g. tooth loads).
pub trait Recorder: Send {
    /// After every dynamic step, at the step's end time.
    fn step(&mut self, contact: &dyn BeltContact, time_s: f64);

    /// At the end of each output row (time `time_s`); `inv_steps` is one over the steps in
    /// the row, for means.
    fn row(
        &mut self,
        contact: &dyn BeltContact,
        belt: &Belt,
        pulleys: &[Pulley],
        time_s: f64,
        inv_steps: f64,
    );

    /// The record of the run.
    fn finish(self: Box<Self>) -> Arc<dyn KindRecord>;
}

/// A belt kind's record of a run (`RunResult::record`).
pub trait KindRecord: Debug + Send + Sync {
    fn as_any(&self) -> &dyn Any;
}

/// The extra contact of the configuration's belt kind, on the belt and pulleys as laid out
/// (`l0_m`: the unstretched belt length). One line per kind.
pub fn build(
    cfg: &ValidConfig,
    belt: &Belt,
    pulleys: &[Pulley],
    l0_m: f64,
) -> Result<Box<dyn BeltContact>, FomError> {
    match cfg.belt.kind {
        BeltKind::Flat | BeltKind::VBelt => Ok(Box::new(flat::LandOnly(cfg.belt.kind))),
        BeltKind::Toothed => toothed::build(cfg, belt, pulleys, l0_m),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::{StepMode, StepWorkspace};
    use crate::model::Model;

    /// A kind that overrides nothing: every hook at its default.
    #[derive(Debug, Clone)]
    struct Inert;

    impl BeltContact for Inert {
        fn name(&self) -> &str {
            "inert"
        }
        fn clone_box(&self) -> Box<dyn BeltContact> {
            Box::new(Inert)
        }
        fn as_any(&self) -> &dyn Any {
            self
        }
        fn as_any_mut(&mut self) -> &mut dyn Any {
            self
        }
    }

    /// The default hooks are the baseline bit for bit: the default drive (a V-belt) steps to
    /// the same state, energy ledger and stability estimate with a kind that overrides nothing.
    #[test]
    fn default_hooks_change_nothing_bit_for_bit() {
        let cfg = ValidConfig::default_hvac();
        let mut a = Model::from_config(&cfg).unwrap();
        assert_eq!(a.belt_contact.name(), "v-belt");
        let mut b = a.clone();
        b.belt_contact = Box::new(Inert);
        assert_eq!(
            a.stable_step_estimate_s().to_bits(),
            b.stable_step_estimate_s().to_bits()
        );
        let (mut wa, mut wb) = (StepWorkspace::default(), StepWorkspace::default());
        for k in 0..400 {
            let mode = StepMode::test_schedule(k);
            a.step(mode, &mut wa);
            b.step(mode, &mut wb);
        }
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.belt.x), bits(&b.belt.x));
        assert_eq!(bits(&a.belt.vy), bits(&b.belt.vy));
        assert_eq!(bits(&a.belt_torque_nm), bits(&b.belt_torque_nm));
        assert_eq!(
            a.ledger.dissipated_j.to_bits(),
            b.ledger.dissipated_j.to_bits()
        );
        assert_eq!(
            a.mechanical_energy_j().to_bits(),
            b.mechanical_energy_j().to_bits()
        );
        assert!(a.check_health().is_ok() && b.check_health().is_ok());
    }
}
