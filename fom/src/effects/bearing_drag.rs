//! `bearing-drag`: extra drag on the fan shaft beyond the configured load, Coulomb plus viscous,
//! T = -(T_c tanh(omega / 0.5 rad/s) + c omega) (the constant and speed-proportional parts of a
//! rolling bearing's frictional moment and seal drag; SKF, Rolling bearings catalogue, 2018,
//! "Friction"). Worn bearings, a dragging seal or a rubbing impeller show as this.

use serde::{Deserialize, Serialize};

use super::Effect;
use crate::drive::LOAD_SMOOTHING_RAD_S;
use crate::model::DRIVEN;

/// Parameters of `[effects.bearing-drag]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingDrag {
    /// Coulomb (speed-independent) drag torque, N m.
    #[serde(default)]
    pub coulomb_nm: f64,
    /// Viscous drag coefficient, N m s/rad.
    #[serde(default)]
    pub viscous_nm_s: f64,
}

impl super::Catalogued for BearingDrag {
    fn check(&self) -> Result<(), String> {
        for (k, v) in [
            ("coulomb_nm", self.coulomb_nm),
            ("viscous_nm_s", self.viscous_nm_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "effects.bearing-drag.{k} = {v} must be a non-negative finite number"
                ));
            }
        }
        Ok(())
    }
}

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
