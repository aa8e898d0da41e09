//! `belt-hysteresis`: viscoelastic axial damping of the belt beyond the baseline's
//! stiffness-proportional damping: a standard linear solid in every axial element, parametrised
//! as a one-term Prony series the way finite-element codes take viscoelastic data (Findley, Lai
//! & Onaran 1976, sec. 5.2): the belt's EA is its instantaneous stiffness; an arm of stiffness
//! g EA in series with a dashpot of relaxation time tau, parallel to an elastic spring
//! (1 - g) EA, so the relaxed (static) stiffness is (1 - g) EA (`belt::AxialHysteresis`,
//! `DriveConfig::static_axial_stiffness_n`). The instantaneous stiffness, and with it the
//! explicit step limit, stays that of the baseline belt. Each element's strain cycles once per belt
//! revolution between slack- and tight-span levels and loses the hysteresis loop's energy:
//! the rubber's loss factor heats the belt (Gerbert, Traction Belt Mechanics, 1999, ch. 11).

use serde::{Deserialize, Serialize};

use super::Effect;

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

impl super::Catalogued for BeltHysteresis {
    fn check(&self) -> Result<(), String> {
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

impl Effect for BeltHysteresis {
    fn name(&self) -> &str {
        "belt-hysteresis"
    }

    fn belt_hysteresis(&self) -> Option<(f64, f64)> {
        Some((self.stiffness_ratio, self.relaxation_s))
    }
}
