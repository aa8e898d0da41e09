//! `tachometer`: the speed sensors themselves (pulses per revolution, the resolution of the timer
//! that stamps the pulses, the share of pulses that go missing), so that synthetic measurements
//! and the twin compare like with like. Nothing changes in the mechanics: the table is read by
//! the twin's sensor model (`twin/src/sensor.rs`) when a run is written as a measurement.

use serde::{Deserialize, Serialize};

/// Parameters of `[effects.tachometer]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tachometer {
    /// Pulses per shaft revolution (teeth of the target wheel).
    pub pulses_per_rev: u32,
    /// Resolution of the pulse timer, s (0: exact pulse times).
    #[serde(default)]
    pub timer_resolution_s: f64,
    /// Share of pulses that go missing, [0, 0.5).
    #[serde(default)]
    pub missing_pulse_share: f64,
}

impl Tachometer {
    pub(crate) fn check(&self) -> Result<(), String> {
        if self.pulses_per_rev == 0 {
            return Err("effects.tachometer.pulses_per_rev must be at least 1".into());
        }
        if !(self.timer_resolution_s.is_finite() && self.timer_resolution_s >= 0.0) {
            return Err(format!(
                "effects.tachometer.timer_resolution_s = {} must be zero or positive",
                self.timer_resolution_s
            ));
        }
        if !(0.0..0.5).contains(&self.missing_pulse_share) {
            return Err(format!(
                "effects.tachometer.missing_pulse_share = {} must lie in [0, 0.5)",
                self.missing_pulse_share
            ));
        }
        Ok(())
    }
}
