//! `pulley-eccentricity`: radial runout of one pulley. The contact circle's centre sits a
//! distance e (m) from the shaft axis and turns with the shaft:
//! c = s + e (cos(theta + phi), sin(theta + phi)), theta the shaft angle, phi the phase.
//! Typical runout of V-belt pulleys: ISO 254 allows 0.2 mm radial runout up to 200 mm pitch
//! diameter; worn or badly mounted pulleys reach several tenths of a millimetre.

use super::{Effect, PulleyEccentricity};

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
