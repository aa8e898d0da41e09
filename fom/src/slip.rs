//! Belt slip: the one definition every command uses (simulated runs, measured recordings,
//! surrogate snapshots).

/// Share of a run's largest driver speed below which a sample carries no slip information
/// (standstill and the first instants of start-up).
pub const STANDSTILL_SHARE: f64 = 0.05;

/// Transmission ratio R_t of paper eq. (1): driven over driver pitch size (diameters or radii,
/// the same for both).
#[inline]
pub fn transmission_ratio(driver_pitch: f64, driven_pitch: f64) -> f64 {
    driven_pitch / driver_pitch
}

/// Belt slip by the seed paper's eq. (1): s = 100 (1 - R_t n_driven / n_driver), %, with the
/// transmission ratio R_t = driven / driver pitch diameter. The speeds may be in any one unit
/// (rpm, rad/s, or angles turned in the same interval).
#[inline]
pub fn slip_pct(ratio: f64, driver_speed: f64, driven_speed: f64) -> f64 {
    100.0 * (1.0 - ratio * driven_speed / driver_speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slip_is_zero_at_the_kinematic_ratio_and_grows_as_the_driven_lags() {
        assert_eq!(slip_pct(2.0, 1800.0, 900.0), 0.0);
        assert!((slip_pct(2.0, 1800.0, 882.0) - 2.0).abs() < 1e-12);
    }
}
