//! `stribeck-friction`: the belt-pulley friction falls from its static value (the configured
//! coefficient) to a dynamic value as the contact slides faster, along the cubic step of the
//! seed paper "arc-tooth-synchronous-belt-recurdyn", eq. 4 (`contact::FrictionLaw::Stribeck`).
//! Rubber on cast iron typically loses 20-40 % of its friction in sliding.

use serde::{Deserialize, Serialize};

use super::Effect;
use crate::contact::FrictionLaw;

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

impl super::Catalogued for StribeckFriction {
    fn check(&self) -> Result<(), String> {
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
