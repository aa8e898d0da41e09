//! The surrogate's physics-based input feature: the traction capacity of the belt at a design
//! point, computed from geometry alone (no simulation).

use fom::{DesignPoint, DriveConfig};

/// Traction capacity at a design point on configuration `cfg`, N: the largest span-tension
/// difference the belt can carry before gross slip, 2 T0 tanh(mu alpha / 2), from the capstan
/// law T_t / T_s = exp(mu alpha) with T_t + T_s = 2 T0 (Euler-Eytelwein; Johnson, Contact
/// Mechanics, 1985, sec. 8.7). T0 is the static span tension of a flexible belt and alpha the
/// wrap on the smaller pulley. Slip turns from creep to gross slip where the load's tension
/// difference approaches it, so it is the input that makes the knee axis-aligned.
pub fn capacity_feature_n(cfg: &DriveConfig, p: &DesignPoint) -> f64 {
    capacity_n(
        p.static_tension_n(cfg),
        p.smaller_wrap_angle_rad(cfg),
        p.friction,
    )
}

/// 2 T0 tanh(mu alpha / 2), N (see [`capacity_feature_n`]).
pub fn capacity_n(t0_n: f64, alpha_rad: f64, mu: f64) -> f64 {
    2.0 * t0_n * (0.5 * mu * alpha_rad).tanh()
}

/// Share of the trained box, by traction capacity, that makes up the knee band: the loosest
/// 5 % (on the default drive the knee, capacity below the ~144 N the fan needs, is ~3 % of the
/// box and the onset up to ~160 N another ~2 %).
pub const KNEE_CAPACITY_SHARE: f64 = 0.05;

/// Latin-hypercube points the knee band's capacity quantile is computed from.
const KNEE_BAND_SAMPLES: usize = 4000;

/// The knee band of a trained box: the traction capacity (N) below which the share
/// `KNEE_CAPACITY_SHARE` of the box lies, from a fixed Latin hypercube over `ranges`. One
/// definition, for the knee's uncertainty calibration and `rom validate --knee`.
pub fn knee_band_capacity_n(
    cfg: &DriveConfig,
    ranges: &[(fom::params::Variable, [f64; 2])],
) -> f64 {
    let mut u: Vec<f64> = training::latin_hypercube(ranges, KNEE_BAND_SAMPLES, 0x6b6e6565)
        .iter()
        .map(|q| capacity_feature_n(cfg, q))
        .collect();
    u.sort_by(f64::total_cmp);
    fom::stats::quantile(&u, KNEE_CAPACITY_SHARE)
}
