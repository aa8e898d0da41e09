//! `bearing-drag`: extra drag on the fan shaft beyond the configured load, Coulomb plus viscous,
//! T = -(T_c tanh(omega / 0.5 rad/s) + c omega) (the constant and speed-proportional parts of a
//! rolling bearing's frictional moment and seal drag; SKF, Rolling bearings catalogue, 2018,
//! "Friction"). Worn bearings, a dragging seal or a rubbing impeller show as this.

use super::{BearingDrag, Effect};
use crate::config::DRIVEN;
use crate::drive::LOAD_SMOOTHING_RAD_S;

impl BearingDrag {
    /// Drag torque magnitude at shaft speed omega (rad/s), N m, opposing the rotation.
    pub fn drag_nm(&self, omega_rad_s: f64) -> f64 {
        self.coulomb_nm * (omega_rad_s / LOAD_SMOOTHING_RAD_S).tanh()
            + self.viscous_nm_s * omega_rad_s
    }
}

impl Effect for BearingDrag {
    fn name(&self) -> &str {
        "bearing-drag"
    }

    fn shaft_torque_nm(
        &self,
        pulley: usize,
        _t: f64,
        _angle: f64,
        omega: f64,
        baseline_nm: f64,
    ) -> f64 {
        if pulley != DRIVEN {
            return baseline_nm;
        }
        baseline_nm - self.drag_nm(omega)
    }
}
