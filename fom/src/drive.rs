//! What turns or brakes a pulley: induction motor, prescribed speed, load torque.

use crate::config::{LoadConfig, MotorConfig, SpeedProfileConfig, TorqueProfileConfig};
use std::f64::consts::PI;

/// rpm -> rad/s.
pub const RPM_TO_RAD_S: f64 = 2.0 * PI / 60.0;

/// Piecewise-linear table y(t), held constant outside its range.
#[derive(Debug, Clone)]
pub struct Table {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl Table {
    pub fn new(t: Vec<f64>, y: Vec<f64>) -> Self {
        Self { t, y }
    }

    pub fn eval(&self, t: f64) -> f64 {
        let n = self.t.len();
        if t <= self.t[0] {
            return self.y[0];
        }
        if t >= self.t[n - 1] {
            return self.y[n - 1];
        }
        let k = self.t.partition_point(|tk| *tk <= t);
        let (t0, t1) = (self.t[k - 1], self.t[k]);
        let f = (t - t0) / (t1 - t0);
        self.y[k - 1] + f * (self.y[k] - self.y[k - 1])
    }
}

/// Induction motor, steady-state torque from the Kloss formula
/// T = 2 T_b / (s / s_b + s_b / s), s = (omega_s - omega) / omega_s
/// (Kloss 1911; e.g. Fitzgerald & Kingsley, Electric Machinery, 6th ed., sec. 6.5).
#[derive(Debug, Clone)]
pub struct Motor {
    pub synchronous_rad_s: f64,
    pub breakdown_torque_nm: f64,
    pub breakdown_slip: f64,
    pub start_time_s: f64,
}

impl Motor {
    pub fn new(c: &MotorConfig) -> Self {
        Self {
            synchronous_rad_s: c.synchronous_rpm * RPM_TO_RAD_S,
            breakdown_torque_nm: c.breakdown_torque_nm,
            breakdown_slip: c.breakdown_slip,
            start_time_s: c.start_time_s,
        }
    }

    pub fn torque_nm(&self, t: f64, omega: f64) -> f64 {
        if t < self.start_time_s {
            return 0.0;
        }
        let s = (self.synchronous_rad_s - omega) / self.synchronous_rad_s;
        let sb = self.breakdown_slip;
        // Kloss: 2 T_b s s_b / (s^2 + s_b^2), smooth through s = 0 (generator side for s < 0).
        2.0 * self.breakdown_torque_nm * s * sb / (s * s + sb * sb)
    }
}

/// Prescribed angular speed profile, rad/s.
#[derive(Debug, Clone)]
pub struct SpeedProfile(Table);

impl SpeedProfile {
    pub fn new(c: &SpeedProfileConfig) -> Self {
        Self(Table::new(
            c.time_s.clone(),
            c.rpm.iter().map(|r| r * RPM_TO_RAD_S).collect(),
        ))
    }

    pub fn omega(&self, t: f64) -> f64 {
        self.0.eval(t)
    }
}

/// Load torque braking a shaft.
#[derive(Debug, Clone)]
pub struct Load {
    pub constant_nm: f64,
    pub viscous_nm_s: f64,
    pub fan_nm_s2: f64,
    profile: Option<TorqueProfile>,
}

#[derive(Debug, Clone)]
enum TorqueProfile {
    Table(Table),
    CosineRamp {
        start_s: f64,
        end_s: f64,
        torque_nm: f64,
    },
}

/// Speed below which the constant (Coulomb) part of the load is smoothed to zero, rad/s.
pub(crate) const LOAD_SMOOTHING_RAD_S: f64 = 0.5;

impl Load {
    pub fn new(c: &LoadConfig) -> Self {
        Self {
            constant_nm: c.constant_nm,
            viscous_nm_s: c.viscous_nm_s,
            fan_nm_s2: c.fan_nm_s2,
            profile: c.profile.as_ref().map(|p| match p {
                TorqueProfileConfig::Table { time_s, torque_nm } => {
                    TorqueProfile::Table(Table::new(time_s.clone(), torque_nm.clone()))
                }
                TorqueProfileConfig::CosineRamp {
                    start_s,
                    end_s,
                    torque_nm,
                } => TorqueProfile::CosineRamp {
                    start_s: *start_s,
                    end_s: *end_s,
                    torque_nm: *torque_nm,
                },
            }),
        }
    }

    /// Extra torque of the time profile, N m.
    fn extra_nm(&self, t: f64) -> f64 {
        match &self.profile {
            None => 0.0,
            Some(TorqueProfile::Table(tab)) => tab.eval(t),
            Some(TorqueProfile::CosineRamp {
                start_s,
                end_s,
                torque_nm,
            }) => {
                let f = ((t - start_s) / (end_s - start_s)).clamp(0.0, 1.0);
                // Half-cosine ramp 0 -> 1 with zero slope at both ends.
                torque_nm * 0.5 * (1.0 - (PI * f).cos())
            }
        }
    }

    /// Braking torque magnitude at speed omega, N m (applied against the rotation).
    /// The constant and profile parts fade in over |omega| < 0.5 rad/s (tanh) so the load is
    /// continuous through standstill.
    pub fn brake_torque_nm(&self, t: f64, omega: f64) -> f64 {
        let sign = (omega / LOAD_SMOOTHING_RAD_S).tanh();
        // T = c0 + c1 |w| + c2 w^2 (+ profile), fan affinity law T ~ w^2.
        sign * (self.constant_nm + self.extra_nm(t))
            + self.viscous_nm_s * omega
            + self.fan_nm_s2 * omega * omega.abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kloss_torque_peaks_at_breakdown_slip() {
        let m = Motor {
            synchronous_rad_s: 100.0,
            breakdown_torque_nm: 20.0,
            breakdown_slip: 0.2,
            start_time_s: 0.0,
        };
        assert!((m.torque_nm(0.0, 80.0) - 20.0).abs() < 1e-12);
        assert!(m.torque_nm(0.0, 100.0).abs() < 1e-12);
        assert!(m.torque_nm(0.0, 79.0) < 20.0 && m.torque_nm(0.0, 81.0) < 20.0);
    }

    #[test]
    fn table_interpolates_and_holds_ends() {
        let t = Table::new(vec![0.0, 1.0, 3.0], vec![0.0, 10.0, 30.0]);
        assert_eq!(t.eval(-1.0), 0.0);
        assert!((t.eval(0.5) - 5.0).abs() < 1e-12);
        assert!((t.eval(2.0) - 20.0).abs() < 1e-12);
        assert_eq!(t.eval(9.0), 30.0);
    }

    #[test]
    fn fan_load_opposes_rotation_in_both_directions() {
        let l = Load::new(&LoadConfig {
            constant_nm: 0.0,
            viscous_nm_s: 0.0,
            fan_nm_s2: 2e-3,
            profile: None,
        });
        assert!((l.brake_torque_nm(0.0, 100.0) - 20.0).abs() < 1e-12);
        assert!((l.brake_torque_nm(0.0, -100.0) + 20.0).abs() < 1e-12);
    }
}
