//! `blade-pass-pulsation`: the fan's load torque pulsates at the blade-pass frequency z n2
//! (each of the z blades passing the cut-off of the scroll; Bleier, Fan Handbook, 1998, ch. 16):
//! T_load -> T_load (1 + a sin(z theta2 + phi)), theta2 the fan shaft angle.

use super::{BladePassPulsation, Effect};
use crate::config::DRIVEN;

impl Effect for BladePassPulsation {
    fn name(&self) -> &str {
        "blade-pass-pulsation"
    }

    fn shaft_torque_nm(
        &self,
        pulley: usize,
        _t: f64,
        angle: f64,
        _w: f64,
        baseline_nm: f64,
    ) -> f64 {
        if pulley != DRIVEN {
            return baseline_nm;
        }
        let phase = self.blades as f64 * angle + self.phase_deg.to_radians();
        baseline_nm * (1.0 + self.amplitude * phase.sin())
    }
}
