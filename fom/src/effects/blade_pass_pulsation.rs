//! `blade-pass-pulsation`: the fan's load torque pulsates at the blade-pass frequency z n2
//! (each of the z blades passing the cut-off of the scroll; Bleier, Fan Handbook, 1998, ch. 16):
//! T_load -> T_load (1 + a sin(z theta2 + phi)), theta2 the fan shaft angle.

use serde::{Deserialize, Serialize};

use super::Effect;
use crate::model::DRIVEN;

/// Parameters of `[effects.blade-pass-pulsation]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BladePassPulsation {
    /// Number of fan blades z.
    pub blades: u32,
    /// Relative amplitude a of the load-torque pulsation.
    pub amplitude: f64,
    /// Phase phi at fan shaft angle zero, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

impl super::Catalogued for BladePassPulsation {
    fn check(&self) -> Result<(), String> {
        if self.blades == 0 {
            return Err("effects.blade-pass-pulsation.blades must be at least 1".into());
        }
        if !(self.amplitude.is_finite() && (0.0..1.0).contains(&self.amplitude)) {
            return Err(format!(
                "effects.blade-pass-pulsation.amplitude = {} must lie in [0, 1)",
                self.amplitude
            ));
        }
        if !self.phase_deg.is_finite() {
            return Err("effects.blade-pass-pulsation.phase_deg must be finite".into());
        }
        Ok(())
    }
}

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
