//! `belt-hysteresis`: viscoelastic axial damping of the belt beyond the baseline's
//! stiffness-proportional damping: a standard linear solid in every axial element (a spring of
//! stiffness ratio r = k2 / (EA / l0) in series with a dashpot of relaxation time tau, parallel to
//! the elastic spring; `belt::AxialHysteresis`). Each element's strain cycles once per belt
//! revolution between slack- and tight-span levels and loses the hysteresis loop's energy:
//! the rubber's loss factor heats the belt (Gerbert, Traction Belt Mechanics, 1999, ch. 11).

use serde::{Deserialize, Serialize};

use super::Effect;

/// Parameters of `[effects.belt-hysteresis]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeltHysteresis {
    /// Stiffness of the viscoelastic arm relative to the axial stiffness EA, (0, 1].
    pub stiffness_ratio: f64,
    /// Relaxation time of the arm, s.
    pub relaxation_s: f64,
}

impl super::Catalogued for BeltHysteresis {
    fn check(&self) -> Result<(), String> {
        if !(self.stiffness_ratio > 0.0 && self.stiffness_ratio <= 1.0) {
            return Err(format!(
                "effects.belt-hysteresis.stiffness_ratio = {} must lie in (0, 1]",
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

impl Effect for BeltHysteresis {
    fn name(&self) -> &str {
        "belt-hysteresis"
    }

    fn belt_hysteresis(&self) -> Option<(f64, f64)> {
        Some((self.stiffness_ratio, self.relaxation_s))
    }
}
