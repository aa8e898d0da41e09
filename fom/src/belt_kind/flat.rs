//! Flat belts and V-belts: the land contact alone (penalty normal law and regularised friction,
//! `integrator.rs`), with the wedge's effective coefficient for a V-belt
//! (`statics::effective_friction`). Every hook is the baseline.

use std::any::Any;

use super::BeltContact;
use crate::config::BeltKind;

/// No contact beyond the land's.
#[derive(Debug, Clone, Copy)]
pub struct LandOnly(pub BeltKind);

impl BeltContact for LandOnly {
    fn name(&self) -> &str {
        self.0.name()
    }

    fn clone_box(&self) -> Box<dyn BeltContact> {
        Box::new(*self)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
