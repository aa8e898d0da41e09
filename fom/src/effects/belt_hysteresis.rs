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

use super::{BeltHysteresis, Effect};

impl Effect for BeltHysteresis {
    fn name(&self) -> &str {
        "belt-hysteresis"
    }

    fn belt_hysteresis(&self) -> Option<(f64, f64)> {
        Some((self.stiffness_ratio, self.relaxation_s))
    }
}
