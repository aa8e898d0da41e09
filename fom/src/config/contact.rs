//! `[contact]` and `[contact.tooth]`: the belt-pulley contact law's parameters. Data and its
//! checks only; the laws are `contact`.

use serde::{Deserialize, Serialize};

use super::limits::{non_negative, positive};

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactConfig {
    /// Penalty stiffness K per contact point, N/m^n (paper eq. 4).
    pub stiffness_n_m: f64,
    /// Damping factor D in F_n = K delta^n (1 + D d(delta)/dt), s/m (paper eq. 4).
    pub damping_s_m: f64,
    /// Hertz exponent n (paper eq. 4).
    pub exponent: f64,
    /// Friction coefficient mu. With `groove_angle_deg` it is the material coefficient and the
    /// wedge raises it to mu / sin(angle / 2); without, it is already the effective coefficient.
    pub friction: f64,
    /// V-groove included angle, degrees (optional).
    #[serde(default)]
    pub groove_angle_deg: Option<f64>,
    /// Velocity threshold v_th of the regularised Coulomb law (paper eq. 5), m/s.
    pub velocity_threshold_m_s: f64,
    /// Tooth-groove contact of a `kind = "toothed"` belt.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tooth: Option<ToothContactConfig>,
}

impl ContactConfig {
    /// The table's first error (`[contact.tooth]` apart), naming the key and the offending
    /// value.
    pub(crate) fn check(&self) -> Result<(), String> {
        let c = self;
        positive("contact.stiffness_n_m", c.stiffness_n_m)?;
        non_negative("contact.damping_s_m", c.damping_s_m)?;
        if !(c.exponent.is_finite() && (1.0..=3.0).contains(&c.exponent)) {
            return Err(format!(
                "contact.exponent = {} must lie in [1, 3]",
                c.exponent
            ));
        }
        non_negative("contact.friction", c.friction)?;
        if let Some(a) = c.groove_angle_deg {
            if !(a.is_finite() && a > 10.0 && a < 90.0) {
                return Err(format!(
                    "contact.groove_angle_deg = {a} must lie in (10, 90)"
                ));
            }
        }
        positive("contact.velocity_threshold_m_s", c.velocity_threshold_m_s)?;
        Ok(())
    }
}

/// `[contact.tooth]`: the tooth-groove contact of a toothed belt (seed paper
/// "arc-tooth-synchronous-belt-recurdyn", eq. 3-5).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToothContactConfig {
    /// Side gap (backlash) g: groove width less tooth width at the land line, m.
    pub side_gap_m: f64,
    /// Radial clearance between the tooth tip and the groove bottom of a centred tooth, m, in
    /// [0, g / 2]. Absent: g / 2, a groove arc concentric with the tooth's (uniform clearance).
    /// Less moves the groove arc's centre outward by g / 2 - clearance, so the side gap stays at
    /// the flanks and the tip reaches the groove bottom (0: the tip touches at rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_clearance_m: Option<f64>,
    /// Stiffness exponent m1 of eq. 3 (1: the tooth's linear elasticity).
    pub stiffness_exponent: f64,
    /// Damping c0 of eq. 3 reached at `damping_full_penetration_m`, per contact point,
    /// N (s/m)^m2 / m^m3.
    pub damping_c0: f64,
    /// Damping exponent m2 of eq. 3 (on the penetration rate).
    pub damping_exponent: f64,
    /// Indentation exponent m3 >= 1 of eq. 3 (on the penetration).
    pub indentation_exponent: f64,
    /// Penetration at which the haversine step of eq. 3 reaches c0, m.
    pub damping_full_penetration_m: f64,
    /// Static friction coefficient mu_s (eq. 4).
    pub static_friction: f64,
    /// Dynamic friction coefficient mu_d (eq. 4).
    pub dynamic_friction: f64,
    /// Static critical speed v_s (eq. 4), m/s.
    pub static_speed_m_s: f64,
    /// Dynamic critical speed v_d > v_s (eq. 4), m/s.
    pub dynamic_speed_m_s: f64,
}

impl ToothContactConfig {
    pub(crate) fn check(&self) -> Result<(), String> {
        let non_negative = |key: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "contact.tooth.{key} = {v} must be a non-negative number"
                ))
            }
        };
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "contact.tooth.{key} = {v} must be a positive number"
                ))
            }
        };
        non_negative("side_gap_m", self.side_gap_m)?;
        if let Some(c) = self.tip_clearance_m {
            if !(c.is_finite() && (0.0..=0.5 * self.side_gap_m).contains(&c)) {
                return Err(format!(
                    "contact.tooth.tip_clearance_m = {c} must lie in [0, side_gap_m / 2 = {}]",
                    0.5 * self.side_gap_m
                ));
            }
        }
        if !(self.stiffness_exponent.is_finite() && (1.0..=3.0).contains(&self.stiffness_exponent))
        {
            return Err(format!(
                "contact.tooth.stiffness_exponent = {} must lie in [1, 3]",
                self.stiffness_exponent
            ));
        }
        non_negative("damping_c0", self.damping_c0)?;
        positive("damping_exponent", self.damping_exponent)?;
        if !(self.indentation_exponent.is_finite() && self.indentation_exponent >= 1.0) {
            return Err(format!(
                "contact.tooth.indentation_exponent = {} must be at least 1 (paper eq. 3: m3 >= 1)",
                self.indentation_exponent
            ));
        }
        positive(
            "damping_full_penetration_m",
            self.damping_full_penetration_m,
        )?;
        non_negative("static_friction", self.static_friction)?;
        non_negative("dynamic_friction", self.dynamic_friction)?;
        positive("static_speed_m_s", self.static_speed_m_s)?;
        if !(self.dynamic_speed_m_s.is_finite() && self.dynamic_speed_m_s > self.static_speed_m_s) {
            return Err(format!(
                "contact.tooth.dynamic_speed_m_s = {} must exceed static_speed_m_s = {}",
                self.dynamic_speed_m_s, self.static_speed_m_s
            ));
        }
        Ok(())
    }
}
