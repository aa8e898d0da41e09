//! `pulley-eccentricity`: radial runout of one pulley. The contact circle's centre sits a
//! distance e (m) from the shaft axis and turns with the shaft:
//! c = s + e (cos(theta + phi), sin(theta + phi)), theta the shaft angle, phi the phase.
//! Typical runout of V-belt pulleys: ISO 254 allows 0.2 mm radial runout up to 200 mm pitch
//! diameter; worn or badly mounted pulleys reach several tenths of a millimetre.

use serde::{Deserialize, Serialize};

use super::{Effect, ShaftSelector};

/// Parameters of `[effects.pulley-eccentricity]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PulleyEccentricity {
    /// Which pulley runs out.
    pub pulley: ShaftSelector,
    /// Runout e: distance of the contact circle's centre from the shaft axis, m.
    pub runout_m: f64,
    /// Phase phi of the runout at shaft angle zero, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

impl super::Catalogued for PulleyEccentricity {
    fn check(&self) -> Result<(), String> {
        if !(self.runout_m.is_finite() && self.runout_m >= 0.0 && self.runout_m < 0.01) {
            return Err(format!(
                "effects.pulley-eccentricity.runout_m = {} must lie in [0, 0.01) m",
                self.runout_m
            ));
        }
        if !self.phase_deg.is_finite() {
            return Err("effects.pulley-eccentricity.phase_deg must be finite".into());
        }
        Ok(())
    }
}

impl Effect for PulleyEccentricity {
    fn name(&self) -> &str {
        "pulley-eccentricity"
    }

    fn contact_center_m(
        &self,
        pulley: usize,
        shaft_center_m: [f64; 2],
        angle_rad: f64,
    ) -> [f64; 2] {
        if pulley != self.pulley.index() {
            return shaft_center_m;
        }
        let a = angle_rad + self.phase_deg.to_radians();
        [
            shaft_center_m[0] + self.runout_m * a.cos(),
            shaft_center_m[1] + self.runout_m * a.sin(),
        ]
    }
}
