//! `stribeck-friction`: the belt-pulley friction falls from its static value (the configured
//! coefficient) to a dynamic value as the contact slides faster, along the cubic step of the
//! seed paper "arc-tooth-synchronous-belt-recurdyn", eq. 4 (`contact::FrictionLaw::Stribeck`).
//! Rubber on cast iron typically loses 20-40 % of its friction in sliding.

use super::{Effect, StribeckFriction};
use crate::contact::FrictionLaw;

impl Effect for StribeckFriction {
    fn name(&self) -> &str {
        "stribeck-friction"
    }

    fn friction_law(&self, baseline: FrictionLaw) -> FrictionLaw {
        match baseline {
            FrictionLaw::RegularisedCoulomb {
                mu,
                velocity_threshold_m_s,
            } => FrictionLaw::Stribeck {
                static_mu: mu,
                dynamic_mu: self.dynamic_ratio * mu,
                stribeck_speed_m_s: self.stribeck_speed_m_s,
                velocity_threshold_m_s,
            },
            other => other,
        }
    }
}
